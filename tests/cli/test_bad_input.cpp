// The bad-input matrix of issues 17 and 27: every input fails fast with a
// one-line error naming the flag, file or line and the problem, exit 1 (2 for
// a usage error), and leaves no file behind; runs ended by SIGINT, SIGTERM or
// SIGHUP leave no temp file; stale temps of killed runs are never input.
// Hostile files (issue 27): no hang (FIFOs, devices, teem's ZRL reader), no
// file read from outside the header's folder, no silent wrong result (exact
// labels, checksums, sizes), warnings for legal but suspicious annotations.
#include <gtest/gtest.h>
#include <zlib.h>
#include <signal.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#include <nifti2_io.h>
#include <sys/stat.h>

#include "cli/cli_test_util.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/png.h"
#include "isoloft/io/volume.h"

using namespace isoloft;
using isoloft::test::Cli;
using isoloft::test::CliRun;
namespace fs = std::filesystem;

namespace {

std::set<std::string> listing(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::recursive_directory_iterator(dir)) names.insert(fs::relative(e.path(), dir).string());
  names.erase("stdout.txt");
  names.erase("stderr.txt");
  return names;
}

// A polyline file: a circle of `n` vertices, radius r, on each slice z.
std::string circle_polylines(int size, double r, const std::vector<double>& z, int n = 48) {
  std::ostringstream o;
  o.precision(17);
  o << "isoloft-polylines 1\nsize " << size << " " << size << "\n";
  for (double zz : z) {
    o << "slice " << zz << "\ncontour\n";
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * i / n;
      o << size / 2.0 + r * std::cos(a) << " " << size / 2.0 + r * std::sin(a) << "\n";
    }
  }
  return o.str();
}

// An all-black 8-bit grey PNG of width x height, deflated row by row (a real
// image the size its header claims, without holding it in memory).
void write_blank_png(const std::string& path, std::uint32_t width, std::uint32_t height) {
  std::string png("\x89PNG\r\n\x1a\n", 8);
  auto be32 = [](std::uint32_t v) { return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)}; };
  auto chunk = [&](const std::string& type, const std::string& data) {
    const std::string body = type + data;
    const auto crc = std::uint32_t(crc32(0, reinterpret_cast<const Bytef*>(body.data()), uInt(body.size())));
    png += be32(std::uint32_t(data.size())) + body + be32(crc);
  };
  chunk("IHDR", be32(width) + be32(height) + std::string("\x08\x00\x00\x00\x00", 5));
  z_stream z{};
  deflateInit(&z, Z_BEST_COMPRESSION);
  std::vector<Bytef> row(width + 1, 0), out(1 << 16);  // filter byte 0, then the pixels
  std::string idat;
  for (std::uint32_t y = 0; y <= height; ++y) {
    const bool last = y == height;
    z.next_in = row.data();
    z.avail_in = last ? 0 : uInt(row.size());
    do {
      z.next_out = out.data();
      z.avail_out = uInt(out.size());
      deflate(&z, last ? Z_FINISH : Z_NO_FLUSH);
      idat.append(reinterpret_cast<const char*>(out.data()), out.size() - z.avail_out);
    } while (z.avail_out == 0);
  }
  deflateEnd(&z);
  chunk("IDAT", idat);
  chunk("IEND", "");
  std::ofstream(path, std::ios::binary) << png;
}

class BadInput : public Cli {
 protected:
  // A 64 px synthetic sphere (contour PNGs).
  std::string sphere() {
    if (!fs::exists(p("sphere"))) {
      const CliRun r = run("synth sphere --size 64 --z-spacing 8 --out " + p("sphere"));
      EXPECT_EQ(r.code, 0) << r.err;
    }
    return p("sphere");
  }
  void text(const std::string& name, const std::string& content) { std::ofstream(p(name), std::ios::binary) << content; }

  // Runs `args`; expects exit `code`, `message` in a one-line stderr, and no
  // new file in the test directory.
  void expect_error(const std::string& args, int code, const std::string& message) {
    const auto before = listing(dir_);
    const CliRun r = run(args);
    EXPECT_EQ(r.code, code) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << args << "\nwanted: " << message << "\ngot: " << r.err;
    EXPECT_EQ(r.err.find("bad_alloc"), std::string::npos) << r.err;
    const std::string last = r.err.substr(r.err.rfind('\n', r.err.size() - 2) + 1);
    EXPECT_EQ(last.rfind("isoloft: error: ", 0) == 0 || code == 2, true) << "last line is the error: " << r.err;
    EXPECT_EQ(listing(dir_), before) << args << ": left files behind";
  }
};

// Inputs that once hung or took the machine's memory: refused by the budget
// before the work, naming the flag and the estimate.
TEST_F(BadInput, WorkOverTheBudgetIsRefusedBeforeItStarts) {
  fs::create_directories(p("big"));
  // The audit's case was 20000^2 at the default 4G; 8000^2 (~1 GB estimated
  // on one thread) under 512M keeps the test's own work small.
  write_blank_png(p("big/a.png"), 8000, 8000);
  write_blank_png(p("big/b.png"), 8000, 8000);
  expect_error("reconstruct " + p("big") + " -o " + p("m.ply") + " --max-memory 512M", 1,
               "--max-memory: decoding 2 slice image(s)");
  const std::string s = sphere();
  text("zstep.json", R"({"interp": {"z_step": 1e-6}})");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --params " + p("zstep.json"), 1, "--max-memory: the object (");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --volume " + p("v.nrrd") + " --z-spacing 1e5", 1,
               "--max-memory: the object (");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --volume " + p("v.nrrd") + " --z-spacing 1e4 --max-memory 0 --max-output 100M",
               1, "--max-output: the object (");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --z-spacing 1e9", 1, "--max-memory");
  text("size.txt", circle_polylines(1 << 20, 30, {0, 1}));
  expect_error("reconstruct " + p("size.txt") + " -o " + p("m.ply"), 1,
               "--max-memory: the contour stage of 2 slices of 1048576x1048576 px");
  text("far.txt", circle_polylines(128, 30, {0, 1e9}));
  expect_error("reconstruct " + p("far.txt") + " -o " + p("m.ply"), 1, "--max-memory: the object (");
  text("circle.txt", circle_polylines(128, 30, {0, 1}));
  expect_error("reconstruct " + p("circle.txt") + " -o " + p("m.ply") + " --raster-resolution 100000", 2,
               "--raster-resolution: must be [0, 20000], got 100000");
  // 20000 px across a 128 px grid: fine rasters of ~19500^2 px per slice in flight.
  expect_error("reconstruct " + p("circle.txt") + " -o " + p("m.ply") + " --raster-resolution 20000 --max-memory 1G", 1,
               "--max-memory: the object (");
  fs::create_directories(p("two"));
  write_circle(p("two/a.png"));
  write_circle(p("two/b.png"));
  expect_error("reconstruct " + p("two") + " -o " + p("m.ply") + " --slice-z 0,1e9", 1, "--max-memory");
  expect_error("reconstruct " + p("two") + " -o " + p("m.ply") + " --max-memory 4X", 1, "--max-memory: '4X' is not a size");
}

// Inputs that once gave a 0-triangle "closed manifold" or an open mesh, exit 0.
TEST_F(BadInput, AnEmptySurfaceIsAnErrorThatSaysWhy) {
  const std::string s = sphere();
  fs::create_directories(p("white"));
  Grid2u8 one(1, 1, 255);
  write_png(p("white/a.png"), one);
  write_png(p("white/b.png"), one);
  expect_error("reconstruct " + p("white") + " -o " + p("m.ply"), 1, "is empty (0 triangles)");
  text("thin.txt", circle_polylines(128, 30, {0, 1e-9}));
  expect_error("reconstruct " + p("thin.txt") + " -o " + p("m.ply"), 1, "less than one plane step interp.z_step");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --z-spacing 1e-12", 1, "less than one plane step interp.z_step");
  text("iso.json", R"({"mc": {"iso": 1e30}})");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --params " + p("iso.json"), 1, "never rises above mc.iso");
  text("depth.json", R"({"interp": {"cap_depth": -5}})");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --params " + p("depth.json"), 1, "interp.cap_depth: must be > 0");
  // An open contour left open bounds nothing: no surface around the curve.
  fs::create_directories(p("open"));
  Grid2u8 arc(48, 48, 0);
  for (int i = 0; i <= 400; ++i) {
    const double a = M_PI * i / 400;
    arc(int(std::lround(24 + 12 * std::cos(a))), int(std::lround(24 + 12 * std::sin(a)))) = 255;
  }
  for (const char* n : {"a.png", "b.png", "c.png"}) write_png(p(std::string("open/") + n), arc);
  expect_error("reconstruct " + p("open") + " -o " + p("m.ply"), 1, "nothing to reconstruct");
  // --allow-empty keeps the documented way to write it anyway.
  const CliRun r = run("reconstruct " + p("white") + " -o " + p("empty.ply") + " --allow-empty");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(read_mesh(p("empty.ply")).triangles.empty());
}

// Values checked on their real type; flags that do nothing in the mode are errors.
TEST_F(BadInput, ParametersAreRangeCheckedAndFlagsMustApply) {
  const std::string s = sphere();
  text("nmin.json", R"({"mpu": {"n_min": 4294967297}})");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --params " + p("nmin.json"), 1, "mpu.n_min: must be");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --decimate-error nan", 2, "--decimate-error: must be >= 0, got nan");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --sign-guard nan", 2, "--sign-guard: must be >= 0, got nan");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --z-spacing nan", 2, "--z-spacing: 'nan' is not a finite number > 0");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --pixel-size inf", 2, "--pixel-size: 'inf' is not a finite number > 0");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --labels 1", 1, "--labels: only with label input");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --raster-resolution 2000", 1,
               "--raster-resolution: has no effect here, only with a polyline input");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --method levin --n-min 10", 1,
               "--n-min: has no effect here, only with --method isoloft, marker2006");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --method levin --dump-stages " + p("st"), 1,
               "--dump-stages: has no effect here");
  text("circle.txt", circle_polylines(128, 30, {0, 1}));
  expect_error("reconstruct " + p("circle.txt") + " -o " + p("m.ply") + " --max-gap 3", 1, "--max-gap: has no effect here");
}

// Errors that named no file, or the wrong one.
TEST_F(BadInput, ErrorsNameTheFileAndLine) {
  text("flat.txt", "isoloft-polylines 1\nsize 64 64\nslice 0\ncontour\n10 10\n20 20\n30 30\nslice 1\ncontour\n10 10\n30 10\n20 30\n");
  expect_error("reconstruct " + p("flat.txt") + " -o " + p("m.ply"), 1, "flat.txt:4: contour has zero area");
}

// Line endings and a UTF-8 byte-order mark change nothing.
TEST_F(BadInput, CrOnlyLinesAndABomReadLikeLf) {
  const std::string lf = circle_polylines(128, 30, {0, 1, 2});
  std::string cr = lf;
  std::replace(cr.begin(), cr.end(), '\n', '\r');
  text("lf.txt", lf);
  text("cr.txt", cr);
  text("bom.txt", "\xEF\xBB\xBF" + lf);
  for (const char* n : {"lf", "cr", "bom"}) {
    const CliRun r = run("reconstruct " + p(std::string(n) + ".txt") + " -o " + p(std::string(n) + ".ply"));
    ASSERT_EQ(r.code, 0) << n << ": " << r.err;
  }
  const TriMesh a = read_mesh(p("lf.ply")), b = read_mesh(p("cr.ply")), c = read_mesh(p("bom.ply"));
  EXPECT_GT(a.triangles.size(), 0u);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.vertices, c.vertices);
}

// A dead process id (no such process), for stale temp names.
long dead_pid() {
  for (long pid = 4194000; pid > 1000; --pid)
    if (::kill(pid_t(pid), 0) != 0 && errno == ESRCH) return pid;
  return 0;
}

TEST_F(BadInput, StaleTempsOfKilledRunsAreNeverInputAndAreSwept) {
  const long dead = dead_pid();
  ASSERT_GT(dead, 0);
  fs::create_directories(p("in"));
  write_circle(p("in/a.png"));
  write_circle(p("in/b.png"));
  // A killed synth's half-written slice: hidden, so not a slice of the stack.
  text("in/.c.png.tmp" + std::to_string(dead) + "-0.png", "\x89PNG\r\n\x1a\nhalf");
  const std::string stale = ".m.ply.run" + std::to_string(dead) + "-0.ply";
  const std::string stale_nested = "..m.ply.run" + std::to_string(dead) + "-0.ply.tmp" + std::to_string(dead) + "-1.ply";
  const std::string live = ".m.ply.run" + std::to_string(::getpid()) + "-0.ply";
  for (const auto& n : {stale, stale_nested, live}) text(n, "stale");
  const CliRun r = run("reconstruct " + p("in") + " -o " + p("m.ply"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(fs::exists(p(stale))) << "a dead run's staged file is swept";
  EXPECT_FALSE(fs::exists(p(stale_nested)));
  EXPECT_TRUE(fs::exists(p(live))) << "a live process's file is kept";
  EXPECT_GT(read_mesh(p("m.ply")).triangles.size(), 0u);
}

// Starts the CLI, sends `sig` once a staged output exists, and expects the
// process to die by it with no hidden or final output left.
void expect_signal_cleans_up(const fs::path& dir, const std::string& input, int sig) {
  const std::string out = (dir / "m.ply").string(), vol = (dir / "v.nrrd").string();
  // Levin's method and 250 px slice spacing: a staged volume after ~0.15 s
  // of a ~0.25 s Release run, after ~7 s of the -O0 sanitizer build's 28 s
  // (measured); what is tested is the cleanup, common to every method.
  const std::vector<std::string> args{ISOLOFT_CLI, "reconstruct", input,         "-o",     out,     "--volume",
                                      vol,         "--quiet",     "--z-spacing", "250",    "--method", "levin"};
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 2);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  auto staged = [&] {
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().filename().string().rfind(".v.nrrd.run", 0) == 0) return true;
    return false;
  };
  // Hang guard only (no timing assertion): the run lasts seconds; a staged
  // volume appears at its first plane.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  int status = 0;
  bool exited = false;
  while (!staged() && std::chrono::steady_clock::now() < give_up) {
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_FALSE(exited) << "the run ended before a staged output was seen";
  ASSERT_TRUE(staged());
  ::kill(pid, sig);
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << "status " << status;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    EXPECT_FALSE(n[0] == '.' || n == "m.ply" || n == "v.nrrd") << strsignal(sig) << " left " << n;
  }
}

TEST_F(BadInput, SigintSigtermAndSighupRemoveEveryTempFile) {
  const std::string s = sphere();
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    const fs::path d = dir_ / ("run" + std::to_string(sig));
    fs::create_directories(d);
    expect_signal_cleans_up(d, s, sig);
  }
}

// ---------------------------------------------------------------- issue 27

// Label 3 (a ball) and label 7 (a box) drawn on every 3rd axial slice of a
// 24 x 24 x 13 volume, 1 mm voxels.
Volume small_labels() {
  Volume v;
  v.nx = 24, v.ny = 24, v.nz = 13;
  v.integer = true;
  v.data.assign(std::size_t(v.nx) * v.ny * v.nz, 0.0f);
  for (int k = 0; k < v.nz; k += 3)
    for (int j = 0; j < v.ny; ++j)
      for (int i = 0; i < v.nx; ++i) {
        if (std::hypot(i - 8.0, j - 12.0) < 6.0 - std::abs(k - 6.0) / 2) v.data[v.index(i, j, k)] = 3;
        if (i > 16 && i < 22 && j > 6 && j < 18 && k > 0 && k < 12) v.data[v.index(i, j, k)] = 7;
      }
  return v;
}

std::string uchar_bytes(const Volume& v) {
  std::string out;
  for (const float x : v.data) out += char(std::uint8_t(x));
  return out;
}

std::string nrrd_header(int nx, int ny, int nz, const std::string& encoding, const std::string& extra = "") {
  return "NRRD0004\ntype: uchar\ndimension: 3\nsizes: " + std::to_string(nx) + " " + std::to_string(ny) + " " +
         std::to_string(nz) + "\nencoding: " + encoding + "\n" + extra;
}

std::string mhd_header(const Volume& v, const std::string& data_file, const std::string& extra = "") {
  return "ObjectType = Image\nNDims = 3\nDimSize = " + std::to_string(v.nx) + " " + std::to_string(v.ny) + " " +
         std::to_string(v.nz) + "\nElementType = MET_UCHAR\n" + extra + "ElementDataFile = " + data_file + "\n";
}

std::string gzip(const std::string& data) {
  z_stream z{};
  deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
  std::string out(deflateBound(&z, uLong(data.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = uInt(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Once hung: teem's ZRL reader (32-bit index, short data padded with 255)
// and a gzip member claiming more than it can hold; teem's reason is its
// last line; checksums and sizes checked.
TEST_F(BadInput, HostileVolumeHeadersFailFastNamingTheReason) {
  const std::string m = " -o " + p("m.ply");
  text("zrl.nrrd", nrrd_header(2100, 2100, 1000, "zrl") + "\n" + std::string("\x01\x02\x03\x04", 4));
  expect_error("reconstruct " + p("zrl.nrrd") + m, 1, "zrl.nrrd: 4 bytes of zrl data cannot hold the 4410000000 bytes");
  // 8 x 8 x 2 = 128 bytes declared; a run of 63 zeros and a 1 encode 64.
  text("short.nrrd", nrrd_header(8, 8, 2, "zrl") + "\n" + std::string("\x00\x3f\x01", 3));
  expect_error("reconstruct " + p("short.nrrd") + m, 1, "ZRL data run short: they decode to 64 of the 128 bytes");
  text("bomb.nrrd", nrrd_header(2000, 2000, 2000, "gzip") + "\n" + gzip(std::string(1000, '\0')));
  expect_error("reconstruct " + p("bomb.nrrd") + m + " --max-memory 100M", 1,
               "bytes of gzip data cannot hold the 8000000000 bytes the header declares");
  text("bad.nrrd", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 four 2\nencoding: raw\n\n");
  expect_error("reconstruct " + p("bad.nrrd") + m, 1, "not a readable NRRD: axis 1 size is zero");
  // One flipped byte of a .nii.gz: its checksum (the last 8 bytes hold CRC and length).
  write_volume(p("v.nii.gz"), small_labels());
  std::string gz = slurp(p("v.nii.gz"));
  gz[gz.size() - 6] ^= 0x10;
  text("v.nii.gz", gz);
  expect_error("reconstruct " + p("v.nii.gz") + m, 1, "v.nii.gz: corrupt gzip data (zlib: incorrect data check)");
  // NIfTI-2: dim[1] = 2^32 + 64 once read as 64 (a 540-byte header, voxels at 544).
  {
    std::string n2(544, '\0');
    auto put = [&](std::size_t at, auto value) { std::memcpy(&n2[at], &value, sizeof value); };
    put(0, std::int32_t(540));
    n2.replace(4, 8, std::string("n+2\0\r\n\x1a\n", 8));
    put(12, std::int16_t(DT_UINT8));
    put(14, std::int16_t(8));
    const std::int64_t dims[8] = {3, (std::int64_t(1) << 32) + 64, 4, 4, 1, 1, 1, 1};
    for (int d = 0; d < 8; ++d) put(16 + 8 * std::size_t(d), dims[d]);
    for (int d = 0; d < 8; ++d) put(104 + 8 * std::size_t(d), 1.0);  // pixdim
    put(168, std::int64_t(544));                                      // vox_offset
    text("n2.nii", n2 + std::string(64 * 16, '\3'));
    expect_error("reconstruct " + p("n2.nii") + m, 1, "n2.nii: dim[1] = 4294967360 is beyond the largest size read");
  }
  // A .hdr without its .img.
  write_volume(p("pair.nii"), small_labels());
  std::string hdr = slurp(p("pair.nii")).substr(0, 348);
  hdr.replace(344, 4, std::string("ni1\0", 4));
  text("pair.hdr", hdr);
  fs::remove(p("pair.nii"));
  expect_error("reconstruct " + p("pair.hdr") + m, 1, "pair.hdr: its data file pair.img is missing");
  // MetaImage: a folder as data file, a header line after LOCAL, more data than declared.
  const Volume v = small_labels();
  fs::create_directories(p("dir.raw"));
  text("d.mhd", mhd_header(v, "dir.raw"));
  expect_error("reconstruct " + p("d.mhd") + m, 1, "d.mhd: data file 'dir.raw' (" + p("dir.raw") + "): is a directory");
  text("late.mha", mhd_header(v, "LOCAL") + "ElementSpacing = 1 1 2\n" + uchar_bytes(v));
  expect_error("reconstruct " + p("late.mha") + m, 1,
               "header line 'ElementSpacing = 1 1 2' after ElementDataFile = LOCAL");
  text("long.mha", mhd_header(v, "LOCAL") + uchar_bytes(v) + std::string(576, '\0'));
  expect_error("reconstruct " + p("long.mha") + m, 1, "8064 bytes of voxel data, but DimSize 24 24 13 of MET_UCHAR declares 7488");
}

// A header names its data file: one outside the header's folder (a path up
// or absolute, or a link inside pointing out) is not read.
TEST_F(BadInput, DataFilesOutsideTheHeadersFolderAreNotRead) {
  const std::string m = " -o " + p("m.ply");
  const Volume v = small_labels();
  fs::create_directories(p("hdr"));
  fs::create_directories(p("secret"));
  text("secret/v.raw", uchar_bytes(v));
  const std::string secret = fs::canonical(p("secret/v.raw")).string();
  text("hdr/up.nhdr", nrrd_header(v.nx, v.ny, v.nz, "raw", "data file: ../secret/v.raw\n"));
  expect_error("reconstruct " + p("hdr/up.nhdr") + m, 1,
               "up.nhdr: data file '../secret/v.raw' (" + secret + ") lies outside the header's folder");
  text("hdr/abs.mhd", mhd_header(v, secret));
  expect_error("reconstruct " + p("hdr/abs.mhd") + m, 1, "abs.mhd: data file '" + secret + "' (" + secret + ") lies outside");
  fs::create_symlink(secret, p("hdr/link.raw"));
  text("hdr/link.mhd", mhd_header(v, "link.raw"));
  expect_error("reconstruct " + p("hdr/link.mhd") + m, 1, "lies outside the header's folder");
  text("hdr/stdin.nhdr", nrrd_header(v.nx, v.ny, v.nz, "raw", "data file: -\n"));
  expect_error("reconstruct " + p("hdr/stdin.nhdr") + m, 1, "data file '-' (standard input) is not read");
  text("hdr/fmt.nhdr", nrrd_header(v.nx, v.ny, v.nz, "raw", "data file: x%s%d.raw 1 2 1\n"));
  expect_error("reconstruct " + p("hdr/fmt.nhdr") + m, 1, "expected 'name%d.ext <min> <max> <step>' with one %d");
  // Inside the folder, a name with a space (MetaIO reads it) and a subfolder are fine.
  fs::create_directories(p("hdr/data"));
  text("hdr/data/my data.raw", uchar_bytes(v));
  text("hdr/in.mhd", mhd_header(v, "data/my data.raw"));
  const CliRun r = run("reconstruct " + p("hdr/in.mhd") + m + " --method levin");
  EXPECT_EQ(r.code, 0) << r.err;
}

// Opening a FIFO blocks until a writer comes; a device may never end.
TEST_F(BadInput, FifosAndDevicesAreRefusedBeforeTheyAreOpened) {
  const std::string m = " -o " + p("m.ply");
  write_circle(p("a.png"));
  ASSERT_EQ(::mkfifo(p("f.png").c_str(), 0600), 0);
  expect_error("reconstruct " + p("a.png") + " " + p("f.png") + m, 1, "f.png: is a FIFO (named pipe)");
  fs::create_directories(p("slices"));
  write_circle(p("slices/a.png"));
  write_circle(p("slices/c.png"));
  ASSERT_EQ(::mkfifo(p("slices/b.png").c_str(), 0600), 0);
  expect_error("reconstruct " + p("slices") + m, 1, "b.png: is a FIFO (named pipe)");
  ASSERT_EQ(::mkfifo(p("v.nii.gz").c_str(), 0600), 0);
  expect_error("reconstruct " + p("v.nii.gz") + m, 1, "v.nii.gz: is a FIFO (named pipe)");
  ASSERT_EQ(::mkfifo(p("fifo.raw").c_str(), 0600), 0);
  text("fifo.mhd", mhd_header(small_labels(), "fifo.raw"));
  expect_error("reconstruct " + p("fifo.mhd") + m, 1, "fifo.mhd: data file 'fifo.raw' (" + p("fifo.raw") + "): is a FIFO");
  expect_error("reconstruct /dev/zero" + m, 1, "/dev/zero: is a device");
}

// Once silently wrong (exit 0): int32 labels above 2^24 merged as float32.
TEST_F(BadInput, Int32LabelsAbove2To24StayApart) {
  Volume v = small_labels();
  for (float& x : v.data) x = x == 3 ? 1.0f : x == 7 ? 2.0f : 0.0f;
  v.value_table = {0, 16777216, 16777217};  // voxels hold indices into it
  write_volume(p("big.nii.gz"), v);
  const CliRun r = run("reconstruct " + p("big.nii.gz") + " -o " + p("m.ply") + " --method levin");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(p("m_label16777216.ply"))) << r.err;
  EXPECT_TRUE(fs::exists(p("m_label16777217.ply"))) << r.err;
}

// Legal but suspicious annotations: a warning naming the slice and labels.
TEST_F(BadInput, StrayVoxelsAndLabelsDrawnAlongAnotherAxisWarn) {
  Volume v = small_labels();
  v.data[v.index(19, 12, 4)] = 7;  // inside the box's range; slice k = 4 now counts as annotated
  write_volume(p("stray.nii.gz"), v);
  const CliRun r = run("reconstruct " + p("stray.nii.gz") + " -o " + p("m.ply") + " --method levin");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("annotated slice k = 4 holds 1 non-zero voxel(s), against 124 and 164 on the annotated slices "
                       "either side (stray voxels?): label(s) 3 crossing it are cut there"),
            std::string::npos)
      << r.err;
  const CliRun masks = run("reconstruct " + p("stray.nii.gz") + " -o " + p("mask.ply") + " --method levin --input masks");
  EXPECT_NE(masks.err.find("(stray voxels?): the object is pinched to them there"), std::string::npos) << masks.err;
  write_volume(p("clean.nii.gz"), small_labels());
  const CliRun j = run("reconstruct " + p("clean.nii.gz") + " -o " + p("j.ply") + " --method levin --axis j");
  EXPECT_NE(j.err.find("label(s) 3, 7: drawn on slices along k (5 of the 13 slices from k = 0 hold it), but the volume "
                       "is sliced along j"),
            std::string::npos)
      << j.err;
  const CliRun k = run("reconstruct " + p("clean.nii.gz") + " -o " + p("k.ply") + " --method levin");
  EXPECT_EQ(k.code, 0) << k.err;
  EXPECT_EQ(k.err.find("warning"), std::string::npos) << k.err;
}

// Errors that once did not say why, or failed for no reason.
TEST_F(BadInput, NanPointsBrokenLinksAndLongOutputNames) {
  text("nan.txt", "isoloft-polylines 1\nsize 64 64\nslice 0\ncontour\n10 10\nnan 3\n20 20\n");
  expect_error("reconstruct " + p("nan.txt") + " -o " + p("m.ply"), 1, "nan.txt:6: point (nan, 3) is not finite");
  fs::create_directories(p("s"));
  for (const char* n : {"b.png", "c.png"}) write_circle(p(std::string("s/") + n));
  fs::create_symlink(p("s/gone.png"), p("s/a.png"));  // sorts first: once skipped silently
  expect_error("reconstruct " + p("s") + " -o " + p("m.ply"), 1, "a.png: broken symbolic link");
  // 244 bytes is a valid name; its hidden staged name is shortened, not refused.
  fs::remove(p("s/a.png"));
  const std::string name = std::string(240, 'n') + ".ply";
  const CliRun r = run("reconstruct " + p("s") + " -o " + p(name) + " --method levin");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(p(name)));
}

// One file by two names is one output; a failed run takes back the folders it made.
TEST_F(BadInput, OneFileByTwoNamesAndNoFoldersLeftByAFailedRun) {
  write_volume(p("v.nii.gz"), small_labels());
  fs::create_directories(p("out"));
  expect_error("reconstruct " + p("v.nii.gz") + " -o " + p("out/m.ply") + " --method levin --input masks --volume " +
                   p("out/x.nrrd") + " --labelmap " + dir_.string() + "/./out/x.nrrd",
               1, "x.nrrd: --volume of the object and --labelmap would both be written to this file");
  fs::create_directories(p("m.ply"));  // the mesh's final path is a folder: the run fails at its end
  expect_error("reconstruct " + p("v.nii.gz") + " -o " + p("m.ply") + " --method levin --labels 3 --volume " + p("new/sub/v.nrrd"), 1,
               "m.ply: is a directory");
  EXPECT_FALSE(fs::exists(p("new")));
}

// The files a run will write are counted before the work (a label map of
// 65,535 labels once wrote 65,537 files over minutes): over --max-files is an
// error naming the count, and nothing is written.
TEST_F(BadInput, TooManyFilesStopTheRunBeforeTheWork) {
  write_volume(p("v.nii.gz"), small_labels());
  const CliRun all = run("reconstruct " + p("v.nii.gz") + " -o " + p("all/m.ply") + " --method levin");
  ASSERT_EQ(all.code, 0) << all.err;
  const auto meshes = std::distance(fs::directory_iterator(p("all")), fs::directory_iterator{});
  ASSERT_GT(meshes, 2) << "small_labels() should give several label meshes and the combined one";
  expect_error("reconstruct " + p("v.nii.gz") + " -o " + p("out/m.ply") + " --method levin --max-files " +
                   std::to_string(meshes - 1),
               1, "--max-files: the run would write " + std::to_string(meshes) + " files");
  EXPECT_FALSE(fs::exists(p("out")));
  const CliRun exact = run("reconstruct " + p("v.nii.gz") + " -o " + p("ok/m.ply") + " --method levin --max-files " +
                           std::to_string(meshes));
  EXPECT_EQ(exact.code, 0) << exact.err;
}

// A label partition streams every label's fields together, so the budget
// adds them up over the labels (per run), not only per label: 256 labels of
// 2x2 px fit 4 MiB one at a time but not together (about 18 KiB of fields
// each), while independent labels hold only their meshes together. (1,024
// labels and 16 MiB, the same per label, took 35 s under the sanitizers.)
TEST_F(BadInput, ThePartitionsFieldsAreCountedTogetherAgainstTheBudget) {
  Volume v;
  v.nx = v.ny = 64, v.nz = 3;
  v.integer = true;
  v.data.assign(std::size_t(v.nx) * v.ny * v.nz, 0.0f);
  for (int label = 1; label <= 256; ++label) {
    const int x = 4 * ((label - 1) % 16), y = 4 * ((label - 1) / 16);
    for (int k : {0, 2})
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) v.data[v.index(x + dx, y + dy, k)] = float(label);
  }
  write_volume(p("many.nii.gz"), v);
  expect_error("reconstruct " + p("many.nii.gz") + " -o " + p("out/m.ply") + " --method levin --max-memory 4M", 1,
               "--max-memory: the labels' fields and meshes held together up to label");
  EXPECT_FALSE(fs::exists(p("out")));
  const CliRun apart = run("reconstruct " + p("many.nii.gz") + " -o " + p("apart/m.ply") +
                           " --method levin --max-memory 4M --independent-labels");
  EXPECT_EQ(apart.code, 0) << apart.err;
}

}  // namespace

// ---------------------------------------------------------------- issue 39: output paths

namespace {

using isoloft::test::kRtss;

bool is_char_device(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISCHR(st.st_mode);
}

}  // namespace

// Once replaced with exit 0: an output naming the input (or a link to it),
// the --params file or another output. Refused before any work, naming the
// flag and the path; the input byte for byte unchanged.
TEST_F(BadInput, AnOutputNeverReplacesAFileTheRunReads) {
  fs::copy_file(kRtss, p("rt.dcm"));
  const std::string rt = slurp(p("rt.dcm"));
  const std::string in = "reconstruct " + p("rt.dcm") + " --roi Heart --method levin";
  expect_error(in + " -o " + p("rt.dcm"), 1, "-o " + p("rt.dcm") + ": is the input " + p("rt.dcm") + "; an output never replaces");
  expect_error(in + " -o " + p("m.ply") + " --rtstruct " + p("rt.dcm"), 1, "--rtstruct " + p("rt.dcm") + ": is the input");
  expect_error(in + " -o " + p("m.ply") + " --report " + p("rt.dcm"), 1, "--report " + p("rt.dcm") + ": is the input");
  fs::create_hard_link(p("rt.dcm"), p("hard.json"));  // the same inode by another name
  fs::create_symlink(p("rt.dcm"), p("soft.json"));
  for (const char* link : {"hard.json", "soft.json"})
    expect_error(in + " -o " + p("m.ply") + " --report " + p(link), 1, "--report " + p(link) + ": is the input");
  EXPECT_EQ(slurp(p("rt.dcm")), rt) << "the input changed";

  write_volume(p("v.nrrd"), small_labels());
  const std::string vol = slurp(p("v.nrrd"));
  const std::string v = "reconstruct " + p("v.nrrd") + " --method levin --input masks";
  expect_error(v + " -o " + p("m.ply") + " --volume " + p("v.nrrd"), 1, "--volume " + p("v.nrrd") + ": is the input");
  expect_error(v + " -o " + p("m.ply") + " --labelmap " + p("v.nrrd"), 1, "--labelmap " + p("v.nrrd") + ": is the input");
  text("params.json", "{\"method\": \"levin\"}\n");
  expect_error(v + " -o " + p("m.ply") + " --params " + p("params.json") + " --report " + p("params.json"), 1,
               "--report " + p("params.json") + ": is the --params file " + p("params.json"));
  // Two outputs on one file through a hard link.
  text("a.json", "{}");
  fs::create_hard_link(p("a.json"), p("b.json"));
  expect_error(v + " -o " + p("m.ply") + " --report " + p("a.json") + " --volumes " + p("b.json"), 1,
               "would both be written to this file");
  EXPECT_EQ(slurp(p("v.nrrd")), vol) << "the input changed";
  EXPECT_EQ(slurp(p("params.json")), "{\"method\": \"levin\"}\n");
  EXPECT_EQ(slurp(p("a.json")), "{}");
}

// The samples beside a header (a .mhd's ElementDataFile, a detached .nhdr's
// data file, a --reference's) are read with it: no output replaces them.
TEST_F(BadInput, AnOutputNeverReplacesTheDataFileOfAVolumeHeader) {
  const Volume v = small_labels();
  text("v.raw", uchar_bytes(v));
  text("v.mhd", mhd_header(v, "v.raw"));
  text("n.raw", uchar_bytes(v));
  text("n.nhdr", nrrd_header(v.nx, v.ny, v.nz, "raw", "data file: n.raw\n"));
  const std::string raw = slurp(p("v.raw"));
  const std::string m = " --method levin --input masks -o " + p("m.ply");
  expect_error("reconstruct " + p("v.mhd") + m + " --report " + p("v.raw"), 1,
               "--report " + p("v.raw") + ": is the input's data file " + p("v.raw") + "; an output never replaces");
  expect_error("reconstruct " + p("n.nhdr") + m + " --report " + p("n.raw"), 1,
               "--report " + p("n.raw") + ": is the input's data file " + p("n.raw"));
  fs::create_symlink(p("v.raw"), p("link.json"));  // the same file by another name
  expect_error("reconstruct " + p("v.mhd") + m + " --report " + p("link.json"), 1, "is the input's data file");
  // A reference grid's data file, whatever the input.
  write_volume(p("in.nrrd"), v);
  expect_error("reconstruct " + p("in.nrrd") + m + " --labelmap " + p("lm.nii.gz") + " --reference " + p("v.mhd") +
                   " --report " + p("v.raw"),
               1, "--report " + p("v.raw") + ": is the --reference file's data file " + p("v.raw"));
  EXPECT_EQ(slurp(p("v.raw")), raw) << "the data file changed";
  EXPECT_EQ(slurp(p("n.raw")), raw) << "the data file changed";
}

// A device or FIFO output is written in place: no temp file beside it, no
// rename over it (as root that once made /dev/null a regular file); a full
// device is an error naming the flag, the path and the errno text.
TEST_F(BadInput, DevicesAreWrittenInPlaceAndAFullDiskIsAnError) {
  write_volume(p("v.nrrd"), small_labels());
  const std::string v = "reconstruct " + p("v.nrrd") + " --method levin --input masks -o " + p("m.ply");
  const CliRun null = run(v + " --report /dev/null");
  EXPECT_EQ(null.code, 0) << null.err;
  EXPECT_TRUE(is_char_device("/dev/null"));
  const CliRun out = run(v + " --report /dev/stdout");
  EXPECT_EQ(out.code, 0) << out.err;
  EXPECT_NE(out.out.find("\"peak_memory_mib\""), std::string::npos) << out.out;
  EXPECT_TRUE(fs::is_symlink("/dev/stdout") || is_char_device("/dev/stdout"));  // the link itself kept
  fs::remove(p("m.ply"));
  expect_error(v + " --report /dev/full", 1, "--report /dev/full: cannot write file (No space left on device)");
  EXPECT_TRUE(is_char_device("/dev/full"));
  // A full disk under the label map (NIfTI, compressed and not): once exit 0 with a truncated file.
  for (const char* name : {"full.nii.gz", "full.nii"}) {
    fs::create_symlink("/dev/full", p(name));
    expect_error(v + " --labelmap " + p(name), 1, std::string("--labelmap ") + p(name) + ": cannot write file (No space left on device)");
    fs::remove(p(name));
  }
  // A FIFO is written in place too (read here by a child).
  ASSERT_EQ(::mkfifo(p("pipe.json").c_str(), 0600), 0);
  std::string piped;
  std::thread reader([&] { piped = slurp(p("pipe.json")); });
  const CliRun fifo = run(v + " --report " + p("pipe.json"));
  reader.join();
  EXPECT_EQ(fifo.code, 0) << fifo.err;
  EXPECT_NE(piped.find("\"peak_memory_mib\""), std::string::npos);
  fs::remove(p("m.ply"));
  // Not a regular file and not a stream: refused before any work.
  fs::create_directories(p("d.json"));
  expect_error(v + " --report " + p("d.json"), 1, "--report " + p("d.json") + ": is a directory, not a regular file");
  text("file", "x");
  expect_error("reconstruct " + p("v.nrrd") + " --input masks -o " + p("m.ply") + " --dump-stages " + p("file"), 1, "--dump-stages " + p("file") + ": is a regular file, not a folder");
  expect_error(v + " --report " + p("file/r.json"), 1, "--report " + p("file/r.json") + ": " + p("file") + " is not a folder");
}

// Once silent: labels at or above 2^24 stored as float32 (16777217 reads as
// 16777216, so labels there may have merged in the file) are refused; a
// MetaImage of ASCII samples (BinaryData = False) gives the meshes of its
// binary twin; a BinaryData that is neither True nor False is named.
TEST_F(BadInput, FloatLabelsFrom2To24AndAsciiMetaImages) {
  Volume f = small_labels();
  f.integer = false;
  for (float& x : f.data) x = x == 7 ? 16777216.0f : x;
  write_volume(p("float.nii"), f);
  expect_error("reconstruct " + p("float.nii") + " -o " + p("m.ply") + " --method levin", 1,
               "float.nii: float voxels hold label 16777216, at or above 2^24 where float32 cannot tell neighbouring "
               "integers apart");
  const CliRun masks = run("reconstruct " + p("float.nii") + " -o " + p("m.ply") + " --method levin --input masks");
  EXPECT_EQ(masks.code, 0) << masks.err;

  const Volume v = small_labels();
  std::string ascii;
  for (const float x : v.data) ascii += std::to_string(int(x)) + (ascii.size() % 64 ? " " : "\n");
  text("ascii.raw", ascii);
  text("ascii.mhd", mhd_header(v, "ascii.raw", "BinaryData = False\n"));
  text("binary.raw", uchar_bytes(v));
  text("binary.mhd", mhd_header(v, "binary.raw"));
  const CliRun a = run("reconstruct " + p("ascii.mhd") + " -o " + p("a.ply") + " --method levin");
  const CliRun b = run("reconstruct " + p("binary.mhd") + " -o " + p("b.ply") + " --method levin");
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  for (const char* label : {"_label3.ply", "_label7.ply"}) {
    const TriMesh ma = read_mesh(p(std::string("a") + label)), mb = read_mesh(p(std::string("b") + label));
    ASSERT_EQ(ma.vertices.size(), mb.vertices.size()) << label;
    for (std::size_t i = 0; i < ma.vertices.size(); ++i) ASSERT_EQ(ma.vertices[i], mb.vertices[i]) << label << " vertex " << i;
  }
  text("maybe.mhd", mhd_header(v, "binary.raw", "BinaryData = Maybe\n"));
  expect_error("reconstruct " + p("maybe.mhd") + " -o " + p("m.ply") + " --method levin", 1,
               "maybe.mhd: BinaryData = 'Maybe' is neither True nor False");
}

// A grid size once printed as -9223372036854775808 (a long cast of 1e302).
TEST_F(BadInput, HugeGridSizesAreNeverPrintedNegative) {
  expect_error("reconstruct " + kRtss + " --roi Heart --method levin -o " + p("m.ply") + " --voxel-size 1e-300", 1,
               "--voxel-size 1e-300 mm: ROI 'Heart' would need a 1.039e+302 x 8.582e+301 pixel grid");
}

// z slabs: the flag's form, the outputs a part cannot give, parts that do
// not join; slabs that do give the one-piece mesh, welded and closed.
TEST_F(BadInput, ZSlabsAndTheirJoinRefuseWhatCannotBeJoined) {
  const std::string s = sphere();
  for (const std::string bad : {"0/3", "4/3", "1", "a/2", "1/-2", "1/2x"})
    expect_error("reconstruct " + s + " -o " + p("m.ply") + " --z-slab " + bad, 1,
                 "--z-slab: '" + bad + "' is not I/S with 1 <= I <= S");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --z-slab 1/2 --volume " + p("v.nrrd"), 1,
               "--z-slab: a slab is part of a surface; --volume needs the whole");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --z-slab 1/2 --decimate-error 0.1", 1, "--z-slab: a slab is part");
  expect_error("reconstruct " + s + " -o " + p("m.ply") + " --z-slab 1/2 --method field3d", 1, "column methods only");

  ASSERT_EQ(run("reconstruct " + s + " -o " + p("whole.ply") + " -q").code, 0);
  for (const char* i : {"1", "2", "3"}) {
    const CliRun r = run("reconstruct " + s + " -o " + p(std::string("s") + i + ".ply") + " -q --z-slab " + i + "/3");
    ASSERT_EQ(r.code, 0) << r.err;
  }
  expect_error("join-slabs " + p("s2.ply") + " " + p("s1.ply") + " " + p("s3.ply") + " -o " + p("j.ply"), 1,
               "do not join into a closed oriented manifold");
  expect_error("join-slabs " + p("s1.ply") + " " + p("nothing.ply") + " -o " + p("j.ply"), 1, "nothing.ply");
  const CliRun r = run("join-slabs " + p("s1.ply") + " " + p("s2.ply") + " " + p("s3.ply") + " -o " + p("j.ply") +
                       " --report " + p("j.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  const TriMesh joined = read_mesh(p("j.ply")), whole = read_mesh(p("whole.ply"));
  EXPECT_EQ(joined.triangles.size(), whole.triangles.size());
  EXPECT_EQ(joined.vertices.size(), whole.vertices.size());
  EXPECT_NE(test::read_text(p("j.json")).find("\"closed\": true"), std::string::npos) << test::read_text(p("j.json"));
  // Decimated after the join (the parts cannot be: not local), still closed.
  ASSERT_EQ(run("join-slabs " + p("s1.ply") + " " + p("s2.ply") + " " + p("s3.ply") + " -o " + p("d.ply") +
                " --decimate-error 0.5 --report " + p("d.json"))
                .code,
            0);
  const TriMesh decimated = read_mesh(p("d.ply"));
  EXPECT_LT(decimated.triangles.size(), whole.triangles.size() / 2);
  EXPECT_NE(test::read_text(p("d.json")).find("\"closed\": true"), std::string::npos) << test::read_text(p("d.json"));
  expect_error("join-slabs " + p("s1.ply") + " -o " + p("x.ply") + " --decimate-error -1", 2, "--decimate-error");
  expect_error("join-slabs " + p("s1.ply") + " " + p("s2.ply") + " -o " + p("s2.ply"), 1, "would replace the part");
  expect_error("join-slabs " + p("s1.ply") + " -o " + p("x.ply") + " --report " + p("x.ply"), 1,
               "is the joined mesh's path");
}
