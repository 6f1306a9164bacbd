#include "entry_points.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "isoloft/core/error.h"
#include "isoloft/io/csl.h"
#include "isoloft/io/png.h"
#include "isoloft/io/polylines.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/rtstruct_sections.h"
#include "isoloft/io/volume.h"
#include "isoloft/io/volume_slices.h"
#include "isoloft/pipeline.h"

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

}  // namespace

const std::vector<Target>& targets() {
  static const std::vector<Target> t{{"png", png},   {"polylines", polylines}, {"params", params},    {"nifti", nifti},
                                     {"nrrd", nrrd}, {"metaimage", metaimage}, {"rtstruct", rtstruct},
                                     {"csl", csl}};
  return t;
}

const Target* find_target(const std::string& name) {
  for (const Target& t : targets())
    if (name == t.name) return &t;
  return nullptr;
}

}  // namespace isoloft::fuzz
