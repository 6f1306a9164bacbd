// The mesh output streamed (issue 37): each label's file written once final
// and its mesh freed, the combined PLY joined from spilled parts; the same
// bytes as written at the end, and nothing left when the run fails.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "cli/cli_test_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/volume.h"
#include "isoloft/methods/params.h"
#include "isoloft/run.h"

using namespace isoloft;
namespace fs = std::filesystem;

namespace {

// A fresh folder per test (its own: the unity batches share one namespace).
class StreamDir {
 public:
  StreamDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() / ("isoloft_stream_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~StreamDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  [[nodiscard]] std::string file(const std::string& name) const { return (path_ / name).string(); }
  [[nodiscard]] const fs::path& path() const { return path_; }
  [[nodiscard]] std::vector<std::string> entries() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(path_)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  fs::path path_;
};

std::string streamed_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

RunResult run_stream_labels(const StreamDir& dir, const std::string& out, bool free_meshes,
                     std::function<void(const std::string&)> activity = {}) {
  InputRequest req;
  req.paths = {dir.file("seg.nii.gz")};
  const Inputs in = read_inputs(req);
  RunOptions o;
  o.free_meshes = free_meshes;
  o.activity = std::move(activity);
  o.outputs.push_back(std::make_unique<MeshOutput>(dir.file(out)));
  return run(in, method_defaults(Method::Levin), o);
}

}  // namespace

TEST(StreamedMeshes, SameBytesAsWrittenAtTheEnd) {
  StreamDir dir;
  isoloft::test::write_two_labels(dir.file("seg.nii.gz"));
  const RunResult held = run_stream_labels(dir, "a.ply", false);
  const RunResult streamed = run_stream_labels(dir, "b.ply", true);
  ASSERT_EQ(streamed.objects.size(), 2u);
  EXPECT_EQ(streamed_bytes(dir.file("a.ply")), streamed_bytes(dir.file("b.ply")));
  for (std::size_t i = 0; i < held.objects.size(); ++i) {
    const RunObject& h = held.objects[i];
    const RunObject& s = streamed.objects[i];
    EXPECT_FALSE(h.object.mesh_freed);
    EXPECT_TRUE(s.object.mesh_freed) << "written once final, then freed";
    EXPECT_TRUE(s.object.mesh.vertices.empty());
    EXPECT_EQ(s.object.triangle_count(), h.object.mesh.triangles.size());
    EXPECT_EQ(s.object.vertex_count(), h.object.mesh.vertices.size());
    const std::string name = fs::path(s.file).filename().string();
    EXPECT_EQ(streamed_bytes(h.file), streamed_bytes(s.file)) << name;
  }
  EXPECT_EQ(dir.entries().size(), 1u + 2u * 3u) << "the input and 3 files per run: no scratch file left";
}

TEST(StreamedMeshes, AFailureAfterTheObjectsAreWrittenLeavesNoFile) {
  StreamDir dir;
  isoloft::test::write_two_labels(dir.file("seg.nii.gz"));
  // Every object is streamed before the outputs' finish; the run fails there.
  EXPECT_THROW(run_stream_labels(dir, "m.ply", true,
                          [](const std::string& what) {
                            if (what.rfind("writing", 0) == 0) throw Error("stopped");
                          }),
               Error);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"seg.nii.gz"}) << "no label file, no staged or scratch file";
}

TEST(StreamedMeshes, PlyPartWriterJoinsPartsInTheOrderGiven) {
  StreamDir dir;
  TriMesh a, b;
  a.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  a.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  b.vertices = {{5, 5, 5}, {6, 5, 5}, {5, 6, 5}};
  b.triangles = {{0, 1, 2}};
  const auto place = [](const Vec3f& v) { return Vec3f(v.x() * 0.5f, v.y() + 1.0f, v.z() * 2.0f); };  // no -0: the frame writes +0
  PlyPartWriter parts(dir.path().string());
  const std::size_t pa = parts.add(a, place, false);
  const std::size_t pb = parts.add(b, place, true);
  parts.write(dir.file("joined.ply"), {pb, pa}, {{0, 0, 255}, {255, 0, 0}}, "LPS");
  // The same by hand: placed, b reversed, merged b first.
  TriMesh pa_m = a, pb_m = b;
  for (Vec3f& v : pa_m.vertices) v = place(v);
  for (Vec3f& v : pb_m.vertices) v = place(v);
  for (auto& t : pb_m.triangles) std::swap(t[1], t[2]);
  std::vector<Rgb> colours;
  const TriMesh merged = merge_meshes({pb_m, pa_m}, {{0, 0, 255}, {255, 0, 0}}, &colours);
  MeshWriteOptions mo;
  mo.frame = PatientFrame{};  // the identity: names the space, places nothing
  mo.colors = &colours;
  write_mesh(dir.file("merged.ply"), merged, mo);
  EXPECT_EQ(streamed_bytes(dir.file("joined.ply")), streamed_bytes(dir.file("merged.ply")));
  EXPECT_EQ(dir.entries().size(), 2u) << "the scratch file has no name";
  // From the parts in memory (a run's combined mesh when not streamed): the same bytes.
  write_ply_parts(dir.file("parts.ply"), {{&b, place, true, {0, 0, 255}}, {&a, place, false, {255, 0, 0}}}, "LPS");
  EXPECT_EQ(streamed_bytes(dir.file("parts.ply")), streamed_bytes(dir.file("merged.ply")));
  TriMesh bad = b;
  bad.triangles[0][2] = 3;
  EXPECT_THROW(write_ply_parts(dir.file("bad.ply"), {{&a, place, false, {}}, {&bad, place, false, {}}}, ""), Error)
      << "a triangle past its own part's vertices";
  EXPECT_FALSE(fs::exists(dir.file("bad.ply")));
}
