#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>

#include "io/io_test_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/nrrd.h"

namespace fs = std::filesystem;
using isoloft::AtomicFile;
using isoloft::test::TempDir;

TEST(AtomicFile, TempPathIsHiddenSiblingWithSameExtension) {
  TempDir dir;
  AtomicFile f(dir.file("out.ply"));
  const fs::path t(f.temp_path());
  EXPECT_EQ(t.parent_path(), dir.path());
  EXPECT_EQ(t.extension(), ".ply");
  EXPECT_EQ(t.filename().string().front(), '.') << t;
  EXPECT_NE(t.filename(), "out.ply");
  AtomicFile g(dir.file("out.ply"));
  EXPECT_NE(f.temp_path(), g.temp_path()) << "two writers to one path must not share a temp file";
}

TEST(AtomicFile, CommitMovesTempOntoFinalPath) {
  TempDir dir;
  const std::string out = dir.file("a.txt");
  isoloft::test::write_text(out, "old");
  {
    AtomicFile f(out);
    isoloft::test::write_text(f.temp_path(), "new");
    EXPECT_EQ(isoloft::test::read_text(out), "old") << "final file must not change before commit";
    f.commit();
    EXPECT_TRUE(f.committed());
    EXPECT_THROW(f.commit(), isoloft::Error);
  }
  EXPECT_EQ(isoloft::test::read_text(out), "new");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"a.txt"}) << "temp file left behind";
}

TEST(AtomicFile, ExceptionBeforeCommitLeavesNoFile) {
  TempDir dir;
  const std::string out = dir.file("b.ply");
  try {
    AtomicFile f(out);
    isoloft::test::write_text(f.temp_path(), "half a mesh");
    throw std::runtime_error("writer failed");
  } catch (const std::runtime_error&) {
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_TRUE(dir.entries().empty()) << "left: " << dir.entries().front();
}

TEST(AtomicFile, ExceptionBeforeCommitKeepsOldFile) {
  TempDir dir;
  const std::string out = dir.file("c.txt");
  isoloft::test::write_text(out, "previous run");
  try {
    AtomicFile f(out);
    isoloft::test::write_text(f.temp_path(), "partial");
    throw std::runtime_error("writer failed");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(isoloft::test::read_text(out), "previous run");
  EXPECT_EQ(dir.entries().size(), 1u);
}

TEST(AtomicFile, CommitWithoutTempFileThrows) {
  TempDir dir;
  AtomicFile f(dir.file("never.txt"));
  EXPECT_THROW(f.commit(), isoloft::Error);
  EXPECT_FALSE(fs::exists(dir.file("never.txt")));
}

TEST(AtomicFile, CreatesParentDirectories) {
  TempDir dir;
  const std::string out = dir.file("x/y/z/out.txt");
  AtomicFile f(out);
  EXPECT_TRUE(fs::is_directory(dir.file("x/y/z")));
  isoloft::test::write_text(f.temp_path(), "ok");
  f.commit();
  EXPECT_EQ(isoloft::test::read_text(out), "ok");
}

TEST(AtomicFile, EnsureParentDirFailsOnAFile) {
  TempDir dir;
  isoloft::test::write_text(dir.file("plain"), "not a directory");
  EXPECT_THROW(isoloft::ensure_parent_dir(dir.file("plain/sub/out.txt")), isoloft::Error);
  EXPECT_NO_THROW(isoloft::ensure_parent_dir("relative_name_without_dir.txt"));
}

TEST(AtomicFile, UnfinishedStreamingWriterLeavesNoFile) {
  TempDir dir;
  const std::string out = dir.file("vol.nrrd");
  {
    isoloft::NrrdWriter w(out, 4, 3, 2, {1, 1, 1}, {0, 0, 0});
    w.write_plane(isoloft::Grid2f(4, 3, 1.0f));
    // destroyed without finish(), e.g. by an exception in the pipeline
  }
  EXPECT_TRUE(dir.entries().empty()) << "left: " << dir.entries().front();
}

// One output that cannot be placed (its path is a directory): none of the
// run's outputs appear, and no staged file is left.
TEST(OutputSet, AFailingOutputLeavesNone) {
  TempDir dir;
  fs::create_directories(dir.file("b.ply"));
  {
    isoloft::OutputSet out;
    isoloft::test::write_text(out.stage(dir.file("a.ply")), "a");
    isoloft::test::write_text(out.stage(dir.file("b.ply")), "b");
    isoloft::test::write_text(out.stage(dir.file("c.ply")), "c");
    EXPECT_THROW(out.commit(), isoloft::Error);
  }
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"b.ply"}) << "only the directory that was there";
}

TEST(OutputSet, AnExceptionBeforeCommitLeavesNone) {
  TempDir dir;
  try {
    isoloft::OutputSet out;
    isoloft::test::write_text(out.stage(dir.file("a.ply")), "a");
    isoloft::test::write_text(out.stage(dir.file("r.json")), "{}");
    throw std::runtime_error("a later output failed");
  } catch (const std::runtime_error&) {
  }
  EXPECT_TRUE(dir.entries().empty());
}
