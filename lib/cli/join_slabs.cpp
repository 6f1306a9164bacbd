// `isoloft join-slabs`: one object's z slab meshes joined (mesh/slab_join.h),
// checked closed, written with an optional JSON report (both or neither).
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/mesh/decimate.h"
#include "isoloft/mesh/slab_join.h"

namespace isoloft::cli {

int Commands::join_slabs() {
  // Outputs replace no part and not each other (checked before any reading).
  for (const std::string* out : {&j_.output, &j_.report}) {
    if (out->empty()) continue;
    for (const std::string& p : j_.parts)
      if (output_key(*out) == output_key(p)) throw ParamError("join-slabs: " + *out + " would replace the part " + p);
  }
  if (!j_.report.empty() && output_key(j_.report) == output_key(j_.output))
    throw ParamError("join-slabs: --report " + j_.report + " is the joined mesh's path");
  std::vector<TriMesh> parts;
  for (const std::string& p : j_.parts) {
    activity_ = "reading " + p;
    parts.push_back(read_mesh(p));
  }
  activity_ = "joining " + std::to_string(parts.size()) + " slabs";
  SlabJoinResult r = isoloft::join_slabs(parts);
  const long joined_triangles = long(r.mesh.triangles.size());
  // Not local, so not in the slabs: the joined (checked) mesh, checked again.
  if (j_.decimate_error > 0 && r.check.closed && r.check.manifold && r.check.oriented) {
    activity_ = "decimating the joined mesh";
    DecimateParams d;
    d.max_error = j_.decimate_error;
    decimate(r.mesh, d);
    r.check = check_mesh(r.mesh);
  }
  const MeshCheck& c = r.check;
  const std::string what = "join-slabs: the " + std::to_string(parts.size()) + " parts " + j_.parts.front() + " .. " +
                           j_.parts.back();
  if (!c.closed || !c.manifold || !c.oriented)
    throw InputError(j_.output, what + " do not join into a closed oriented manifold (" + std::to_string(c.boundary_edges) +
                                    " boundary edges, " + std::to_string(c.nonmanifold_edges) + " non-manifold edges, " +
                                    std::to_string(r.unmatched) + " cut vertices without a partner): slabs of one run "
                                    "(--z-slab I/S, I = 1..S), bottom up?");
  if (r.mesh.triangles.empty() && !j_.allow_empty)
    throw InputError(j_.output, what + " have no triangles (--allow-empty writes the empty surface)");
  const nlohmann::json report = {
      {"parts", j_.parts},        {"output", j_.output},         {"triangles", r.mesh.triangles.size()},
      {"vertices", r.mesh.vertices.size()}, {"welded", r.welded}, {"unmatched", r.unmatched},
      {"closed", c.closed},       {"manifold", c.manifold},      {"oriented", c.oriented},
      {"components", c.components}, {"euler", c.euler},          {"volume", c.volume},
      {"area", c.area},           {"triangles_joined", joined_triangles}, {"decimate_error", j_.decimate_error}};
  activity_ = "writing " + j_.output;
  AtomicFile mesh(j_.output);
  write_mesh(mesh.temp_path(), r.mesh);
  std::optional<AtomicFile> rep;
  if (!j_.report.empty()) {
    rep.emplace(j_.report);
    write_text_atomic(rep->temp_path(), report.dump(2) + "\n");
  }
  mesh.commit();
  if (rep) rep->commit();
  return 0;
}

}  // namespace isoloft::cli
