#include "isoloft/mesh/mesh_spill.h"

namespace isoloft {

MeshSpill::MeshSpill(const std::string& dir) : v_(dir, "a mesh's vertices"), t_(dir, "a mesh's triangles") {}

void MeshSpill::take(TriMesh& m) {
  v_.append(m.vertices.data(), m.vertices.size() * sizeof(m.vertices[0]));
  t_.append(m.triangles.data(), m.triangles.size() * sizeof(m.triangles[0]));
  nv_ += m.vertices.size();
  nt_ += m.triangles.size();
  m.vertices.clear();
  m.triangles.clear();
}

TriMesh MeshSpill::load() const {
  TriMesh m;
  m.vertices.resize(nv_);
  m.triangles.resize(nt_);
  v_.read(0, m.vertices.data(), nv_ * sizeof(m.vertices[0]));
  t_.read(0, m.triangles.data(), nt_ * sizeof(m.triangles[0]));
  return m;
}

}  // namespace isoloft
