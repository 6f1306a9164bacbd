#include "isoloft/io/volume.h"

#include <fcntl.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <cerrno>

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>

#include <cmath>
#include <filesystem>

#include "isoloft/core/error.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/metaimage.h"
#include "isoloft/io/nifti.h"
#include "isoloft/io/nrrd.h"

namespace isoloft {

namespace {

enum class VolumeFormat { Nifti, Nrrd, MetaImage, None };

VolumeFormat volume_format(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  auto ends = [&](const char* e) {
    const std::size_t n = std::strlen(e);
    return name.size() > n && name.compare(name.size() - n, n, e) == 0;
  };
  if (ends(".nii") || ends(".nii.gz") || ends(".hdr") || ends(".hdr.gz")) return VolumeFormat::Nifti;
  if (ends(".nrrd") || ends(".nhdr")) return VolumeFormat::Nrrd;
  if (ends(".mha") || ends(".mhd")) return VolumeFormat::MetaImage;
  return VolumeFormat::None;
}

}  // namespace

bool is_volume_path(const std::string& path) { return volume_format(path) != VolumeFormat::None; }

Volume read_volume(const std::string& path, const VolumeReadOptions& options) {
  Volume v;
  switch (volume_format(path)) {
    case VolumeFormat::Nifti: v = read_nifti(path, options); break;
    case VolumeFormat::Nrrd: v = read_nrrd(path, options); break;
    case VolumeFormat::MetaImage: v = read_metaimage(path, options); break;
    case VolumeFormat::None: throw InputError(path, "not a volume file name (.nii, .nii.gz, .nrrd, .nhdr, .mha, .mhd)");
  }
  detail::check_geometry(v, path);
  return v;
}

void write_volume(const std::string& path, const Volume& v) {
  switch (volume_format(path)) {
    case VolumeFormat::Nifti: return write_nifti(path, v);
    case VolumeFormat::Nrrd: return write_nrrd_volume(path, v);
    case VolumeFormat::MetaImage: return write_metaimage(path, v);
    case VolumeFormat::None: break;
  }
  throw ParamError(path + ": not a volume file name (use .nii.gz, .nii, .nrrd or .mha)");
}

Grid2f Volume::plane(int z) const {
  Grid2f g(nx, ny);
  const std::size_t n = std::size_t(nx) * std::size_t(ny);
  std::copy_n(data.begin() + std::ptrdiff_t(std::size_t(z) * n), n, g.data.begin());
  return g;
}

namespace detail {

ScalarType storage_type(const Volume& v) {
  if (!v.integer) return ScalarType::F32;
  double lo = 0, hi = 0;
  if (v.value_table.empty()) {
    float flo = 0, fhi = 0;
    for (float x : v.data) flo = std::min(flo, x), fhi = std::max(fhi, x);
    lo = flo, hi = fhi;
  } else {
    for (const std::int64_t x : v.value_table) lo = std::min(lo, double(x)), hi = std::max(hi, double(x));
  }
  if (lo >= 0 && hi <= 255) return ScalarType::U8;
  if (lo >= 0 && hi <= 65535) return ScalarType::U16;
  if (lo >= 0 && hi > std::numeric_limits<std::int32_t>::max()) return ScalarType::U32;
  return ScalarType::I32;
}

std::vector<unsigned char> encode_scalars(const Volume& v, ScalarType t) {
  std::vector<unsigned char> out(v.data.size() * scalar_size(t));
  auto put = [&](std::size_t i, auto value) { std::memcpy(&out[i * sizeof value], &value, sizeof value); };
  for (std::size_t i = 0; i < v.data.size(); ++i) {
    const float x = v.data[i];
    const double exact = v.value_table.empty() ? double(x) : double(v.value_table[std::size_t(x)]);
    switch (t) {
      case ScalarType::U8: put(i, std::uint8_t(exact)); break;
      case ScalarType::U16: put(i, std::uint16_t(exact)); break;
      case ScalarType::I32: put(i, std::int32_t(exact)); break;
      case ScalarType::U32: put(i, std::uint32_t(exact)); break;
      default: put(i, x); break;
    }
  }
  return out;
}

void check_geometry(const Volume& v, const std::string& file) {
  const char* const axis = "ijk";
  for (int a = 0; a < 3; ++a) {
    const double s = v.spacing[std::size_t(a)];
    if (!(std::isfinite(s) && s > 0))
      throw InputError(file, std::string("the voxel-to-patient matrix is singular or not finite (voxel axis ") + axis[a] +
                                 " has length " + std::to_string(s) + ")");
    const Eigen::Vector3d d = v.direction.col(a);
    if (!d.allFinite() || std::abs(d.norm() - 1) > kOrthogonalityTolerance)
      throw InputError(file, std::string("the direction of voxel axis ") + axis[a] + " is not a finite unit vector");
  }
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      if (std::abs(v.direction.col(a).dot(v.direction.col(b))) > kOrthogonalityTolerance)
        throw InputError(file, std::string("voxel axes ") + axis[a] + " and " + axis[b] +
                                   " are not orthogonal (a singular or sheared voxel-to-patient matrix): not supported");
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(v.origin[std::size_t(a)]))
      throw InputError(file, "the origin is not finite (" + std::to_string(v.origin[std::size_t(a)]) + ")");
}

void check_finite_voxels(const Volume& v, const std::string& file) {
  // A branch-free scan first (it vectorises); the loop below names the voxel.
  int bad = 0;
  for (const float x : v.data) bad |= int(!(std::abs(x) <= std::numeric_limits<float>::max()));
  for (std::size_t i = 0; bad && i < v.data.size(); ++i)
    if (!std::isfinite(v.data[i])) {
      const std::size_t plane = std::size_t(v.nx) * std::size_t(v.ny);
      throw InputError(file, std::string(std::isnan(v.data[i]) ? "NaN" : "infinite") + " voxel at (" +
                                 std::to_string(i % std::size_t(v.nx)) + ", " +
                                 std::to_string(i / std::size_t(v.nx) % std::size_t(v.ny)) + ", " +
                                 std::to_string(i / plane) + ")");
    }
}

std::size_t scalar_size(ScalarType t) {
  switch (t) {
    case ScalarType::U8:
    case ScalarType::I8:
      return 1;
    case ScalarType::U16:
    case ScalarType::I16:
      return 2;
    case ScalarType::U32:
    case ScalarType::I32:
    case ScalarType::F32:
      return 4;
    case ScalarType::F64:
      return 8;
  }
  return 1;
}

namespace {
template <class T>
void decode_as(const unsigned char* src, std::size_t count, bool swap, float* dst) {
  constexpr std::size_t S = sizeof(T);
  unsigned char b[S];
  for (std::size_t i = 0; i < count; ++i) {
    std::memcpy(b, src + i * S, S);
    if (swap) std::reverse(b, b + S);
    T v;
    std::memcpy(&v, b, S);
    dst[i] = static_cast<float>(v);
  }
}
}  // namespace

namespace {
void decode_serial(const unsigned char* src, std::size_t count, ScalarType t, bool swap, float* dst) {
  switch (t) {
    case ScalarType::U8:
      decode_as<std::uint8_t>(src, count, false, dst);
      break;
    case ScalarType::I8:
      decode_as<std::int8_t>(src, count, false, dst);
      break;
    case ScalarType::U16:
      decode_as<std::uint16_t>(src, count, swap, dst);
      break;
    case ScalarType::I16:
      decode_as<std::int16_t>(src, count, swap, dst);
      break;
    case ScalarType::U32:
      decode_as<std::uint32_t>(src, count, swap, dst);
      break;
    case ScalarType::I32:
      decode_as<std::int32_t>(src, count, swap, dst);
      break;
    case ScalarType::F32:
      decode_as<float>(src, count, swap, dst);
      break;
    case ScalarType::F64:
      decode_as<double>(src, count, swap, dst);
      break;
  }
}
}  // namespace

void decode_scalars(const unsigned char* src, std::size_t count, ScalarType t, bool big_endian, float* dst) {
  const bool swap = big_endian != (std::endian::native == std::endian::big);
  const std::size_t size = scalar_size(t);
  constexpr std::size_t kBlock = std::size_t(1) << 20;  // samples per task
  if (count <= kBlock) return decode_serial(src, count, t, swap, dst);  // a row: no task's overhead
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, kBlock), [&](const tbb::blocked_range<std::size_t>& r) {
    decode_serial(src + r.begin() * size, r.size(), t, swap, dst + r.begin());
  });
}

namespace {

// The 32-bit integers of src as int64 (either byte order).
template <class T>
std::vector<std::int64_t> integers(const unsigned char* src, std::size_t count, bool swap) {
  std::vector<std::int64_t> out(count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, std::size_t(1) << 20), [&](const auto& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      unsigned char b[sizeof(T)];
      std::memcpy(b, src + i * sizeof(T), sizeof(T));
      if (swap) std::reverse(b, b + sizeof(T));
      T x;
      std::memcpy(&x, b, sizeof(T));
      out[i] = std::int64_t(x);
    }
  });
  return out;
}

}  // namespace

void decode_volume(const unsigned char* src, ScalarType t, bool big_endian, Volume& v, const std::string& file) {
  const std::size_t count = v.data.size();
  decode_scalars(src, count, t, big_endian, v.data.data());
  v.value_table.clear();
  if (t != ScalarType::I32 && t != ScalarType::U32) return;
  // Beyond 2^24 a float no longer holds every integer: the exact values go
  // to a table. Decoded floats at or beyond 2^24 in magnitude mark the case.
  constexpr float kExact = float(1 << 24);
  int beyond = 0;
  for (const float x : v.data) beyond |= int(std::abs(x) >= kExact);  // branch-free: vectorises
  if (!beyond) return;
  const bool swap = big_endian != (std::endian::native == std::endian::big);
  std::vector<std::int64_t> exact =
      t == ScalarType::I32 ? integers<std::int32_t>(src, count, swap) : integers<std::uint32_t>(src, count, swap);
  // 0 first, then the other distinct values ascending.
  std::vector<std::int64_t> table = exact;
  table.push_back(0);
  std::sort(table.begin(), table.end());
  table.erase(std::unique(table.begin(), table.end()), table.end());
  table.erase(std::find(table.begin(), table.end(), 0));
  table.insert(table.begin(), 0);
  if (table.size() > std::size_t(1 << 24))
    throw InputError(file, std::to_string(table.size()) + " distinct integer values, some beyond 2^24: more than the " +
                               std::to_string(1 << 24) + " that can be told apart exactly");
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, std::size_t(1) << 20), [&](const auto& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i)
      v.data[i] = exact[i] == 0 ? 0.0f
                                : float(std::lower_bound(table.begin() + 1, table.end(), exact[i]) - table.begin());
  });
  v.value_table = std::move(table);
}

void take_or_decode(const unsigned char* src, ScalarType t, bool big_endian, Volume& v, const std::string& file,
                    const VolumeReadOptions& options) {
  v.data.clear();
  if (options.take_samples && options.take_samples(v, VolumeSamples{src, t, big_endian})) return;
  resize_large(v.data, std::size_t(v.nx) * std::size_t(v.ny) * std::size_t(v.nz));
  decode_volume(src, t, big_endian, v, file);
}

void take_or_decode_file(const std::string& path, const unsigned char* mapped, std::uint64_t offset, ScalarType t,
                         bool big_endian, Volume& v, const VolumeReadOptions& options) {
  const std::size_t sample = scalar_size(t);
  if (options.take_samples && sample <= 2) {
    const std::size_t plane_bytes = std::size_t(v.nx) * std::size_t(v.ny) * sample;
    const int fd = open_regular_file(path);
    struct Closer {
      int fd;
      ~Closer() { ::close(fd); }
    } closer{fd};
    auto planes = std::make_shared<std::vector<SamplePlane>>(std::size_t(v.nz));
    tbb::parallel_for(tbb::blocked_range<int>(0, v.nz), [&](const tbb::blocked_range<int>& r) {
      std::vector<unsigned char> plane(plane_bytes);
      for (int k = r.begin(); k != r.end(); ++k) {
        const std::uint64_t at = offset + std::uint64_t(k) * plane_bytes;
        for (std::size_t done = 0; done < plane_bytes;) {
          const ssize_t got = ::pread(fd, plane.data() + done, plane_bytes - done, off_t(at + done));
          if (got < 0 && errno == EINTR) continue;
          if (got <= 0)
            throw InputError(path, "cannot read plane " + std::to_string(k) + " of the samples" +
                                       (got < 0 ? std::string(" (") + std::strerror(errno) + ")" : " (file shortened)"));
          done += std::size_t(got);
        }
        unsigned char any = 0;
        for (const unsigned char b : plane) any |= b;  // branch-free: vectorises
        if (any) (*planes)[std::size_t(k)] = SamplePlane(plane.data(), v.nx, v.ny, sample);
      }
    });
    v.data.clear();
    if (options.take_samples(v, VolumeSamples{nullptr, t, big_endian, std::move(planes)})) return;
    resize_large(v.data, std::size_t(v.nx) * std::size_t(v.ny) * std::size_t(v.nz));  // declined: offered once
    decode_volume(mapped + offset, t, big_endian, v, path);
    return;
  }
  take_or_decode(mapped + offset, t, big_endian, v, path, options);
}

}  // namespace detail

SamplePlane::SamplePlane(const unsigned char* samples, int nx, int ny, std::size_t sample_bytes)
    : nx_(nx), ny_(ny), size_(sample_bytes) {
  if (sample_bytes != 1 && sample_bytes != 2)
    throw ParamError("SamplePlane: samples of " + std::to_string(sample_bytes) + " bytes (1 or 2 are held as runs)");
  bool any = false;
  // Typed by the sample size, and equal samples skipped 8 bytes at a time:
  // a label plane is mostly long runs of 0.
  const auto encode = [&](auto typed) {
    using T = decltype(typed);
    constexpr int kPerWord = int(8 / sizeof(T));
    const auto value = [&](std::size_t i) {
      T v;
      std::memcpy(&v, samples + i * sizeof(T), sizeof(T));
      return std::uint16_t(v);
    };
    row_first_.reserve(std::size_t(ny) + 1);
    for (int j = 0; j < ny; ++j) {
      row_first_.push_back(std::uint32_t(run_end_.size()));
      const std::size_t row = std::size_t(j) * std::size_t(nx);
      for (int i = 0; i < nx;) {
        const std::uint16_t v = value(row + std::size_t(i));
        const std::uint64_t word = std::uint64_t(v) * (sizeof(T) == 1 ? 0x0101010101010101ULL : 0x0001000100010001ULL);
        int e = i + 1;
        for (std::uint64_t w; e + kPerWord <= nx; e += kPerWord) {
          std::memcpy(&w, samples + (row + std::size_t(e)) * sizeof(T), 8);
          if (w != word) break;
        }
        while (e < nx && value(row + std::size_t(e)) == v) ++e;
        run_end_.push_back(std::uint32_t(e));
        value_.push_back(v);
        any |= v != 0;
        i = e;
      }
    }
  };
  if (sample_bytes == 1) encode(std::uint8_t{});
  else encode(std::uint16_t{});
  row_first_.push_back(std::uint32_t(run_end_.size()));
  if (!any) {  // all 0: nothing held but the size
    row_first_ = {};
    run_end_ = {};
    value_ = {};
    return;
  }
  runs_ = run_end_.size();
  run_end_.shrink_to_fit();
  value_.shrink_to_fit();
}

bool SamplePlane::row_zero(int j) const {
  if (empty()) return true;
  for (std::uint32_t r = row_first_[std::size_t(j)]; r < row_first_[std::size_t(j) + 1]; ++r)
    if (value_[r] != 0) return false;
  return true;
}

void SamplePlane::row(int j, unsigned char* out) const {
  if (empty()) {
    std::memset(out, 0, std::size_t(nx_) * size_);
    return;
  }
  std::uint32_t x = 0;
  for (std::uint32_t r = row_first_[std::size_t(j)]; r < row_first_[std::size_t(j) + 1]; ++r)
    for (; x < run_end_[r]; ++x) std::memcpy(out + std::size_t(x) * size_, &value_[r], size_);
}

void SamplePlane::row_floats(int j, detail::ScalarType type, bool big_endian, float* out) const {
  if (empty()) {
    std::fill(out, out + nx_, 0.0f);
    return;
  }
  std::uint32_t x = 0;
  for (std::uint32_t r = row_first_[std::size_t(j)]; r < row_first_[std::size_t(j) + 1]; ++r) {
    float f;
    detail::decode_scalars(reinterpret_cast<const unsigned char*>(&value_[r]), 1, type, big_endian, &f);
    std::fill(out + x, out + run_end_[r], f);
    x = run_end_[r];
  }
}

float SamplePlane::at(int i, int j, detail::ScalarType type, bool big_endian) const {
  if (empty()) return 0.0f;
  const std::uint32_t* first = run_end_.data() + row_first_[std::size_t(j)];
  const std::uint32_t* last = run_end_.data() + row_first_[std::size_t(j) + 1];
  const std::size_t r = std::size_t(std::upper_bound(first, last, std::uint32_t(i)) - run_end_.data());
  float f;
  detail::decode_scalars(reinterpret_cast<const unsigned char*>(&value_[r]), 1, type, big_endian, &f);
  return f;
}

std::size_t SamplePlane::bytes() const {
  return row_first_.capacity() * sizeof(std::uint32_t) + run_end_.capacity() * sizeof(std::uint32_t) +
         value_.capacity() * sizeof(std::uint16_t);
}

}  // namespace isoloft
