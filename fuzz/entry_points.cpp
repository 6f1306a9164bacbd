#include "entry_points.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "isoloft/core/error.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/io/label_names.h"
#include "isoloft/io/csl.h"
#include "isoloft/io/png.h"
#include "isoloft/io/polylines.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/rtstruct_sections.h"
#include "isoloft/io/volume.h"
#include "isoloft/io/volume_slices.h"
#include "isoloft/pipeline.h"
#include "isoloft/run/manifest.h"
#include "isoloft/run/outputs.h"

namespace isoloft::fuzz {

namespace {

namespace fs = std::filesystem;

// The readers take paths: the bytes go to a per-process scratch file (in
// /dev/shm when there is one, so an iteration costs no disk I/O).
std::string scratch(const std::string& ext, const std::uint8_t* data, std::size_t size) {
  static const fs::path dir = fs::exists("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
  const std::string path = (dir / ("isoloft_fuzz_" + std::to_string(::getpid()) + ext)).string();
  std::FILE* fp = std::fopen(path.c_str(), "wb");
  if (!fp) std::abort();
  if (size && std::fwrite(data, 1, size, fp) != size) std::abort();
  std::fclose(fp);
  return path;
}

bool gzip(const std::uint8_t* data, std::size_t size) { return size >= 2 && data[0] == 0x1f && data[1] == 0x8b; }

// Runs the reader on the scratch file; a rejection (isoloft::Error) is fine.
template <class F>
void guarded(const std::string& path, F&& f) {
  try {
    f(path);
  } catch (const Error&) {
  }
  std::remove(path.c_str());
}

// A read volume goes on as the CLI takes it: checked, then sliced as masks
// and as labels (the label checks and warnings).
void slice_volume(const Volume& v, const std::string& path) {
  detail::check_finite_voxels(v, path);
  VolumeSlicing s;
  s.kind = InputKind::Masks;
  (void)volume_stack(v, s, path);
  s.kind = InputKind::Labels;
  try {
    (void)volume_stack(v, s, path);
  } catch (const Error&) {  // not a label map: the masks above were the test
  }
}

void png(const std::uint8_t* d, std::size_t n) {
  guarded(scratch(".png", d, n), [](const std::string& p) { (void)read_png(p); });
}

void polylines(const std::uint8_t* d, std::size_t n) {
  guarded(scratch(".txt", d, n), [](const std::string& p) { (void)read_polylines(p); });
}

void params(const std::uint8_t* d, std::size_t n) {
  try {
    const auto j = nlohmann::json::parse(d, d + n, nullptr, true, /*ignore_comments=*/true);
    (void)params_from_json(j);
  } catch (const nlohmann::json::exception&) {  // the CLI's "not valid JSON"
  } catch (const Error&) {
  }
}

void nifti(const std::uint8_t* d, std::size_t n) {
  guarded(scratch(gzip(d, n) ? ".nii.gz" : ".nii", d, n), [](const std::string& p) { slice_volume(read_volume(p), p); });
}

void nrrd(const std::uint8_t* d, std::size_t n) {
  guarded(scratch(".nrrd", d, n), [](const std::string& p) { slice_volume(read_volume(p), p); });
}

void metaimage(const std::uint8_t* d, std::size_t n) {
  guarded(scratch(".mha", d, n), [](const std::string& p) { slice_volume(read_volume(p), p); });
}

// The RT writers on what was read: every ROI's closed contours written back,
// derived from the file's own bytes and as a standalone set, then read again.
// A refusal (isoloft::Error) is fine; the sanitizers watch the rest.
void write_back(const RtStructureSet& set, const std::string& source) {
  std::vector<RtRoiContours> rois;
  for (const RtRoi& roi : set.rois) {
    RtRoiContours out{&roi, {}};
    for (const RtContour& c : roi.contours) {
      if (c.type != "CLOSED_PLANAR" || c.points.empty()) continue;
      RtRoiContours::Plane plane{c.points.front().z(), {{}}};
      for (const Vec3d& q : c.points) plane.loops.front().emplace_back(q.x(), q.y());
      out.planes.push_back(std::move(plane));
    }
    rois.push_back(std::move(out));
  }
  const std::string derived = source + ".derived.dcm", fresh = source + ".new.dcm";
  try {
    write_rtstruct(derived, source, rois, "fuzz", &set.bytes);
    (void)read_rtstruct(derived);
  } catch (const Error&) {
  }
  try {
    (void)write_rtstruct_new(fresh, rois, "fuzz");
    (void)read_rtstruct(fresh);
  } catch (const Error&) {
  }
  std::remove(derived.c_str());
  std::remove(fresh.c_str());
}

void rtstruct(const std::uint8_t* d, std::size_t n) {
  guarded(scratch(".dcm", d, n), [](const std::string& p) {
    const RtStructureSet set = read_rtstruct(p);
    for (const RtRoi& roi : set.rois) {
      std::vector<std::string> warnings;
      try {
        (void)roi_stack(roi, RoiGrid{}, p, warnings);
      } catch (const Error&) {  // one ROI rejected, as the CLI skips it
      }
      try {  // the same ROI on planes of any orientation
        (void)roi_sections(roi, p, warnings);
      } catch (const Error&) {
      }
    }
    write_back(set, p);
  });
}

// ROI names: the first byte picks a Specific Character Set, the rest is the
// ROIName's bytes. A name that is read must be UTF-8 without NUL, shown on
// a terminal without a control byte, never a formula cell, and JSON-safe.
void roi_names(const std::uint8_t* d, std::size_t n) {
  static const char* const kCharsets[] = {"",           "ISO_IR 100",        "ISO_IR 192", "\\ISO 2022 IR 87",
                                          "ISO_IR 144", "ISO 2022 IR 6\\ISO 2022 IR 149", "GB18030", "ISO_IR 13\\ISO 2022 IR 87"};
  if (n == 0) return;
  const std::string charset = kCharsets[d[0] % (sizeof kCharsets / sizeof *kCharsets)];
  std::string name;
  try {
    name = detail::decode_roi_name(std::string(reinterpret_cast<const char*>(d + 1), n - 1), charset, 1, "fuzz.dcm");
  } catch (const Error&) {
    return;
  }
  if (!is_utf8(name) || name.find('\0') != std::string::npos) std::abort();
  for (const char c : terminal_text(name))
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) std::abort();
  const std::string cell = csv_cell(name);
  if (!cell.empty() && std::string("=+-@\t\r").find(cell.front()) != std::string::npos) std::abort();
  (void)nlohmann::json(name).dump();  // throws (a finding) on bytes that are not UTF-8
}

// Label tables: every name read is UTF-8 (JSON-safe) and its file name part
// holds only [A-Za-z0-9_-].
void label_names(const std::uint8_t* d, std::size_t n) {
  guarded(scratch(".txt", d, n), [](const std::string& p) {
    for (const auto& [label, name] : read_label_names(p).names) {
      for (const char c : file_safe(name))
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) std::abort();
      (void)nlohmann::json(name).dump();  // throws (a finding) on bytes that are not UTF-8
    }
  });
}

// The text as it is (no scratch file: read_csl maps the file and parses the
// same bytes), once as refused by default and once with self-intersecting
// contours let through, so the sections are built for those too.
void csl(const std::uint8_t* d, std::size_t n) {
  const std::string_view text(reinterpret_cast<const char*>(d), n);
  for (const bool refuse : {true, false}) {
    CslParams params;
    params.refuse_self_intersections = refuse;
    try {
      (void)parse_csl(text, "fuzz.csl", params);
    } catch (const Error&) {
    }
  }
}

// A batch manifest's text: every case that runs has a plain folder name and
// outputs inside it; every message is terminal-safe UTF-8.
void manifest(const std::uint8_t* d, std::size_t n) {
  std::vector<ManifestCase> cases;
  try {
    std::vector<ManifestRow> rows;
    for (const ManifestRecord& r : parse_manifest_csv(std::string_view(reinterpret_cast<const char*>(d), n), "fuzz.csv"))
      rows.push_back(manifest_row(r));
    cases = check_manifest_rows(rows, "/base", "fuzz.csv");
  } catch (const Error& e) {
    for (const char c : std::string(e.what()))
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) std::abort();
    return;
  }
  for (const ManifestCase& c : cases) {
    if (c.input.empty() || c.input.front() != '/') std::abort();
    if (!c.error.empty()) {
      for (const char ch : c.error)
        if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7F) std::abort();
      (void)nlohmann::json(c.error).dump();  // throws (a finding) on bytes that are not UTF-8
      continue;
    }
    if (c.name.empty() || c.name.size() > kMaxCaseNameBytes || c.name.front() == '.' ||
        c.name.find_first_of(std::string("/\0", 2)) != std::string::npos || c.name == "summary.csv")
      std::abort();
    for (std::size_t i = 0; i < c.options.size(); ++i) {
      const std::string& o = c.options[i];
      if (o == "-o" || o == "--output" || o == "--report" || o.rfind("-o", 0) == 0 || o.rfind("--report=", 0) == 0)
        std::abort();
      if (o == "--volume" || o == "--labelmap" || o == "--rtstruct" || o == "--volumes" || o == "--rt-contours" ||
          o == "--dump-stages") {
        const std::string v = i + 1 < c.options.size() ? c.options[i + 1] : "";
        if (!v.empty() && (v.front() == '/' || detail::pure_path(v) == ".." || detail::pure_path(v).rfind("../", 0) == 0))
          std::abort();
      }
    }
  }
}

}  // namespace

const std::vector<Target>& targets() {
  static const std::vector<Target> t{{"png", png},   {"polylines", polylines}, {"params", params},    {"nifti", nifti},
                                     {"nrrd", nrrd}, {"metaimage", metaimage}, {"rtstruct", rtstruct},
                                     {"roi_names", roi_names}, {"label_names", label_names}, {"csl", csl},
                                     {"manifest", manifest}};
  return t;
}

const Target* find_target(const std::string& name) {
  for (const Target& t : targets())
    if (name == t.name) return &t;
  return nullptr;
}

}  // namespace isoloft::fuzz
