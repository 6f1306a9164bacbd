#include "isoloft/io/nifti.h"

#include <Eigen/Dense>
#include <nifti2_io.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/file_util.h"

namespace isoloft {

namespace {

namespace fs = std::filesystem;
using detail::kOrthogonalityTolerance;

bool has_suffix(const std::string& path, const std::string& suffix) {
  std::string name = fs::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0;
}

struct NiftiImageDeleter {
  void operator()(nifti_image* n) const { nifti_image_free(n); }
};
using NiftiImage = std::unique_ptr<nifti_image, NiftiImageDeleter>;

// RAS (NIfTI) to LPS (DICOM): x and y change sign.
const Eigen::Matrix3d kRasToLps = Eigen::Vector3d(-1, -1, 1).asDiagonal();

template <class T>
void decode(const unsigned char* src, std::size_t n, double slope, double inter, float* dst) {
  for (std::size_t i = 0; i < n; ++i) {
    T v;
    std::memcpy(&v, src + i * sizeof(T), sizeof(T));
    dst[i] = float(slope * double(v) + inter);
  }
}

// zlib's reason for a failed read of `f` (gzerror without the path it prefixes), or "".
std::string gz_reason(gzFile f, const std::string& path) {
  int zerr = Z_OK;
  const char* why = gzerror(f, &zerr);
  if (zerr == Z_OK || zerr == Z_BUF_ERROR || !why) return "";
  std::string s = why;
  if (s.rfind(path + ": ", 0) == 0) s.erase(0, path.size() + 2);
  return s;
}

// The header, checked before niftilib sees the file (it prints its own
// complaints): NIfTI-1 (348 bytes) or NIfTI-2 (540), either byte order, and
// the voxel sizes of the dimensions in use, as stored (niftilib turns a
// non-positive size into 1). .hdr/.img pairs are left to niftilib.
void check_header(const std::string& path) {
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) return;  // niftilib names the problem
  unsigned char h[540];
  const int got = gzread(f, h, sizeof h);
  const std::string zmsg = gz_reason(f, path);
  gzclose(f);
  if (!zmsg.empty()) throw InputError(path, "corrupt gzip data (zlib: " + zmsg + ")");  // a small .gz is read whole here
  auto get32 = [&](std::size_t off, bool swap) {
    std::uint32_t v;
    std::memcpy(&v, h + off, 4);
    return swap ? __builtin_bswap32(v) : v;
  };
  if (got < 4) throw InputError(path, "not a readable NIfTI file (" + std::to_string(std::max(got, 0)) + " bytes)");
  const bool v1 = get32(0, false) == 348 || get32(0, true) == 348, v2 = get32(0, false) == 540 || get32(0, true) == 540;
  if (!v1 && !v2) throw InputError(path, "not a readable NIfTI file (no NIfTI-1 or NIfTI-2 header)");
  const bool swap = v1 ? get32(0, false) != 348 : get32(0, false) != 540;
  if (got < (v1 ? 348 : 540)) throw InputError(path, "not a readable NIfTI file (truncated header)");
  // niftilib converts the header before it checks it: a dim[0] beyond 7
  // overruns its arrays (a NIfTI-2 one of 12885442562 overflowed the stack,
  // found by fuzzing). So dim[0], the magic and the sizes in use are checked here.
  auto get64 = [&](std::size_t off) {
    std::uint64_t v;
    std::memcpy(&v, h + off, 8);
    return swap ? __builtin_bswap64(v) : v;
  };
  std::uint16_t ndim1;
  std::memcpy(&ndim1, h + 40, 2);
  const std::int64_t ndim = v1 ? std::int16_t(swap ? __builtin_bswap16(ndim1) : ndim1) : std::int64_t(get64(16));
  if (ndim < 1 || ndim > 7)
    throw InputError(path, "not a readable NIfTI file (dim[0] = " + std::to_string(ndim) + ", must be 1 to 7)");
  if (v2 && std::memcmp(h + 4, "n+2\0\r\n\032\n", 8) != 0 && std::memcmp(h + 4, "ni2\0\r\n\032\n", 8) != 0)
    throw InputError(path, "not a readable NIfTI file (bad NIfTI-2 magic)");
  for (int d = 1; d <= std::min<int>(int(ndim), 3); ++d) {
    double dx;
    if (v1) {
      const std::uint32_t bits = get32(76 + 4 * std::size_t(d), swap);
      float f;
      std::memcpy(&f, &bits, 4);
      dx = f;
    } else {
      const std::uint64_t bits = get64(104 + 8 * std::size_t(d));
      std::memcpy(&dx, &bits, 8);
    }
    if (!(std::isfinite(dx) && dx > 0))
      throw InputError(path, "voxel size (pixdim[" + std::to_string(d) + "] = " + std::to_string(dx) + ") is not finite and > 0");
  }
}

}  // namespace

Volume read_nifti(const std::string& path, const VolumeReadOptions& options) {
  detail::check_regular_file(path);
  check_header(path);
  if (has_suffix(path, ".hdr") || has_suffix(path, ".hdr.gz")) {
    // An analyze-style pair: the voxels are in the .img beside it.
    char* img = nifti_findimgname(path.c_str(), NIFTI_FTYPE_NIFTI1_2);
    const std::string data = img ? img : "";
    std::free(img);
    if (data.empty())
      throw InputError(path, "its data file " + fs::path(path).stem().string() + ".img is missing (a .hdr needs the .img beside it)");
    detail::check_regular_file(data);
  }
  nifti_set_debug_level(0);  // its own stderr messages; we say what is wrong
  nifti_image* raw = nullptr;
  znzFile fp = nifti_image_open(path.c_str(), const_cast<char*>("rb"), &raw);
  const NiftiImage nim(raw);
  if (!nim || znz_isnull(fp)) {
    if (!znz_isnull(fp)) znzclose(fp);
    throw InputError(path, "not a readable NIfTI file (bad or truncated header)");
  }
  znzclose(fp);  // the header is all we take from niftilib; the voxels are read below

  // One 3D volume: dimensions beyond z must all be 1.
  for (int d = 4; d <= std::min<int>(int(nim->dim[0]), 7); ++d)
    if (nim->dim[d] > 1)
      throw InputError(path, std::to_string(nim->dim[0]) + "D image (dim[" + std::to_string(d) + "] = " +
                                 std::to_string(nim->dim[d]) + "): one 3D label volume is needed");
  if (nim->dim[0] < 2) throw InputError(path, "fewer than 2 dimensions");
  // NIfTI-2 sizes are 64-bit: one beyond int would wrap (2^32 + 64 read as 64).
  for (int d = 1; d <= std::min<int>(int(nim->dim[0]), 3); ++d)
    if (nim->dim[d] > std::numeric_limits<int>::max())
      throw InputError(path, "dim[" + std::to_string(d) + "] = " + std::to_string(nim->dim[d]) +
                                 " is beyond the largest size read (2^31 - 1)");
  Volume v;
  v.nx = int(nim->nx);
  v.ny = int(nim->ny);
  v.nz = nim->dim[0] >= 3 ? int(nim->nz) : 1;
  const std::size_t count = detail::checked_voxel_count(v.nx, v.ny, v.nz, path);
  for (const double d : {double(nim->dx), double(nim->dy), double(nim->dz)})
    if (!(std::isfinite(d) && d > 0) && v.nz > 1)
      throw InputError(path, "voxel size (pixdim) " + std::to_string(d) + " is not finite and > 0");

  // Geometry: sform, else qform, else NIfTI method 1.
  nifti_dmat44 m = nim->sform_code > 0 ? nim->sto_xyz : nim->qto_xyz;
  if (nim->sform_code <= 0 && nim->qform_code <= 0) {
    std::memset(&m, 0, sizeof m);
    m.m[0][0] = nim->dx, m.m[1][1] = nim->dy, m.m[2][2] = nim->dz, m.m[3][3] = 1;
    v.warnings.push_back(path + ": neither sform nor qform: voxel axes taken as RAS (NIfTI method 1)");
  }
  Eigen::Matrix3d axes;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) axes(r, c) = m.m[r][c];
  for (int a = 0; a < 3; ++a) {
    const double len = axes.col(a).norm();
    if (!(std::isfinite(len) && len > 0))
      throw InputError(path, "the voxel-to-patient matrix is singular (voxel axis " + std::to_string(a) + " has length " +
                                 std::to_string(len) + ")");
    v.spacing[std::size_t(a)] = len;
  }
  const Eigen::Matrix3d dir_ras = axes * Eigen::Vector3d(1 / v.spacing[0], 1 / v.spacing[1], 1 / v.spacing[2]).asDiagonal();
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      if (std::abs(dir_ras.col(a).dot(dir_ras.col(b))) > kOrthogonalityTolerance)
        throw InputError(path, "sheared voxel axes (the sform/qform is not a rotation times a scale): not supported");
  v.direction = kRasToLps * dir_ras;
  const Eigen::Vector3d origin = kRasToLps * Eigen::Vector3d(m.m[0][3], m.m[1][3], m.m[2][3]);
  for (int a = 0; a < 3; ++a) v.origin[std::size_t(a)] = origin[a];

  // Data, read raw (niftilib's own loader turns NaN into 0 silently).
  const int dt = nim->datatype;
  const bool integer = dt == DT_UINT8 || dt == DT_INT8 || dt == DT_UINT16 || dt == DT_INT16 || dt == DT_UINT32 ||
                       dt == DT_INT32;
  if (!integer && dt != DT_FLOAT32 && dt != DT_FLOAT64)
    throw InputError(path, std::string("unsupported NIfTI datatype ") + nifti_datatype_string(dt) +
                               " (need a scalar 8/16/32-bit integer or float32/64)");
  if (options.on_header) {
    std::vector<std::string> data_files;
    if (nim->iname && std::string(nim->iname) != path) data_files.emplace_back(nim->iname);
    options.on_header({v.nx, v.ny, v.nz, std::size_t(nim->nbyper), data_files});
  }
  if (options.geometry_only) {
    v.integer = integer;
    return v;
  }
  const std::size_t nbytes = count * std::size_t(nim->nbyper);
  // The voxels through zlib (plain files read as they are), so a .gz's
  // checksum can be checked and a failure named with zlib's reason.
  const std::string data_file = nim->iname ? nim->iname : path;
  detail::check_regular_file(data_file);
  const gzFile g = gzopen(data_file.c_str(), "rb");
  if (!g) throw InputError(data_file, "cannot open file");
  struct GzCloser {
    gzFile f;
    ~GzCloser() { gzclose(f); }
  } gz_closer{g};
  auto short_read = [&](std::size_t got) {
    if (const std::string why = gz_reason(g, data_file); !why.empty())
      return InputError(data_file, "corrupt gzip data (zlib: " + why + ")");
    return InputError(data_file, "voxel data truncated (" + std::to_string(got) + " of " + std::to_string(nbytes) + " bytes)");
  };
  const bool scaled = nim->scl_slope != 0 && std::isfinite(nim->scl_slope) && std::isfinite(nim->scl_inter) &&
                      (nim->scl_slope != 1 || nim->scl_inter != 0);
  using detail::ScalarType;
  const ScalarType type = dt == DT_UINT8 ? ScalarType::U8 : dt == DT_INT8 ? ScalarType::I8 : dt == DT_UINT16 ? ScalarType::U16
                          : dt == DT_INT16 ? ScalarType::I16 : dt == DT_UINT32 ? ScalarType::U32 : dt == DT_INT32 ? ScalarType::I32
                          : dt == DT_FLOAT32 ? ScalarType::F32 : ScalarType::F64;
  const bool swap = nim->byteorder != nifti_short_order() && nim->swapsize > 1;
  if (gzseek(g, z_off_t(nim->iname_offset), SEEK_SET) < 0) throw short_read(0);
  // Read in chunks, so memory follows the data the file really holds: a
  // header that claims 4 GB of a 350-byte file fails before allocating it.
  constexpr std::size_t kChunkBytes = std::size_t(16) << 20;
  // Samples a taker may slice as stored (8- and 16-bit integers, unscaled)
  // are read plane by plane along k, the planes all 0 kept as nothing: a
  // sparse label volume costs its annotated planes, not its box.
  const bool by_plane = options.take_samples && !scaled && detail::scalar_size(type) <= 2;
  std::vector<unsigned char> bytes;
  std::shared_ptr<std::vector<SamplePlane>> planes;
  if (by_plane) {
    const std::size_t plane_bytes = std::size_t(v.nx) * std::size_t(v.ny) * std::size_t(nim->nbyper);
    planes = std::make_shared<std::vector<SamplePlane>>(std::size_t(v.nz));
    std::vector<unsigned char> plane;  // grown as read, as the chunks below
    for (std::size_t k = 0; k < std::size_t(v.nz); ++k) {
      for (std::size_t at = 0; at < plane_bytes;) {
        const std::size_t want = std::min(plane_bytes - at, kChunkBytes);
        if (plane.size() < at + want) plane.resize(at + want);
        const int got = gzread(g, plane.data() + at, unsigned(want));
        if (got < 0 || std::size_t(got) != want) throw short_read(k * plane_bytes + at + std::size_t(std::max(got, 0)));
        at += want;
      }
      unsigned char any = 0;
      for (const unsigned char b : plane) any |= b;  // branch-free: vectorises
      if (!any) continue;
      if (swap) nifti_swap_Nbytes(int64_t(plane_bytes / std::size_t(nim->nbyper)), nim->swapsize, plane.data());
      (*planes)[k] = SamplePlane(plane.data(), v.nx, v.ny, std::size_t(nim->nbyper));
    }
  }
  // Else in chunks: memory follows the data the file really holds.
  while (!by_plane && bytes.size() < nbytes) {
    const std::size_t at = bytes.size(), want = std::min(kChunkBytes, nbytes - at);
    bytes.resize(at + want);
    const int got = gzread(g, bytes.data() + at, unsigned(want));
    if (got < 0 || std::size_t(got) != want) throw short_read(at + std::size_t(std::max(got, 0)));
  }
  if (gzdirect(g) == 0) {
    // gzip checks its CRC and length only at the end of the stream: read to
    // it, or one flipped byte gives another mesh without a word.
    std::vector<unsigned char> sink(std::size_t(1) << 16);
    int got;
    while ((got = gzread(g, sink.data(), unsigned(sink.size()))) > 0) {
    }
    if (got < 0) throw short_read(nbytes);
  }
  if (by_plane) {
    v.integer = integer;
    VolumeSamples samples{nullptr, type, std::endian::native == std::endian::big, planes};
    v.data.clear();
    if (options.take_samples(v, samples)) return v;
    bytes.assign(nbytes, 0);  // not taken: the planes in one buffer, decoded below
    const std::size_t row_bytes = std::size_t(v.nx) * std::size_t(nim->nbyper);
    for (std::size_t k = 0; k < planes->size(); ++k)
      for (int j = 0; !(*planes)[k].empty() && j < v.ny; ++j)
        (*planes)[k].row(j, bytes.data() + (k * std::size_t(v.ny) + std::size_t(j)) * row_bytes);
    planes.reset();
    detail::resize_large(v.data, count);
    detail::decode_volume(bytes.data(), type, samples.big_endian, v, path);
    return v;
  }
  if (swap) nifti_swap_Nbytes(int64_t(count), nim->swapsize, bytes.data());
  const double slope = scaled ? nim->scl_slope : 1.0, inter = scaled ? nim->scl_inter : 0.0;
  v.integer = integer && (!scaled || (slope == std::floor(slope) && inter == std::floor(inter)));
  if (!scaled) {
    detail::take_or_decode(bytes.data(), type, std::endian::native == std::endian::big, v, path, options);
    return v;
  }
  detail::resize_large(v.data, count);
  float* out = v.data.data();
  switch (dt) {
    case DT_UINT8: decode<std::uint8_t>(bytes.data(), count, slope, inter, out); break;
    case DT_INT8: decode<std::int8_t>(bytes.data(), count, slope, inter, out); break;
    case DT_UINT16: decode<std::uint16_t>(bytes.data(), count, slope, inter, out); break;
    case DT_INT16: decode<std::int16_t>(bytes.data(), count, slope, inter, out); break;
    case DT_UINT32: decode<std::uint32_t>(bytes.data(), count, slope, inter, out); break;
    case DT_INT32: decode<std::int32_t>(bytes.data(), count, slope, inter, out); break;
    case DT_FLOAT32: decode<float>(bytes.data(), count, slope, inter, out); break;
    default: decode<double>(bytes.data(), count, slope, inter, out); break;
  }
  return v;
}

void write_nifti(const std::string& path, const Volume& v) {
  detail::checked_voxel_count(v.nx, v.ny, v.nz, path);
  const detail::ScalarType type = detail::storage_type(v);
  const int dt = type == detail::ScalarType::U8 ? DT_UINT8 : type == detail::ScalarType::U16 ? DT_UINT16
                 : type == detail::ScalarType::I32 ? DT_INT32 : type == detail::ScalarType::U32 ? DT_UINT32 : DT_FLOAT32;
  const int64_t dims[8] = {3, v.nx, v.ny, v.nz, 1, 1, 1, 1};
  const NiftiImage nim(nifti_make_new_nim(dims, dt, 0));
  if (!nim) throw Error(path + ": cannot create a NIfTI image");
  nim->dx = nim->pixdim[1] = v.spacing[0];
  nim->dy = nim->pixdim[2] = v.spacing[1];
  nim->dz = nim->pixdim[3] = v.spacing[2];
  nim->xyz_units = NIFTI_UNITS_MM;
  // LPS geometry back to RAS.
  const Eigen::Matrix3d axes = kRasToLps * v.direction * Eigen::Vector3d(v.spacing[0], v.spacing[1], v.spacing[2]).asDiagonal();
  const Eigen::Vector3d origin = kRasToLps * Eigen::Vector3d(v.origin[0], v.origin[1], v.origin[2]);
  nifti_dmat44 m{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.m[r][c] = axes(r, c);
    m.m[r][3] = origin[r];
  }
  m.m[3][3] = 1;
  nim->sform_code = nim->qform_code = NIFTI_XFORM_SCANNER_ANAT;
  nim->sto_xyz = m;
  nim->sto_ijk = nifti_dmat44_inverse(m);
  nifti_dmat44_to_quatern(m, &nim->quatern_b, &nim->quatern_c, &nim->quatern_d, &nim->qoffset_x, &nim->qoffset_y,
                          &nim->qoffset_z, nullptr, nullptr, nullptr, &nim->qfac);
  nim->qto_xyz = nifti_quatern_to_dmat44(nim->quatern_b, nim->quatern_c, nim->quatern_d, nim->qoffset_x, nim->qoffset_y,
                                         nim->qoffset_z, nim->dx, nim->dy, nim->dz, nim->qfac);
  nim->qto_ijk = nifti_dmat44_inverse(nim->qto_xyz);
  std::vector<unsigned char> data = detail::encode_scalars(v, type);
  AtomicFile file(path);
  nim->nifti_type = NIFTI_FTYPE_NIFTI1_1;
  if (nifti_set_filenames(nim.get(), file.temp_path().c_str(), 0, 1) != 0) {
    nim->data = nullptr;
    throw Error(path + ": not a NIfTI file name (use .nii or .nii.gz)");
  }
  nim->nifti_type = NIFTI_FTYPE_NIFTI1_1;  // nifti_set_filenames resets it
  // The header by niftilib (write option 2: no data, the file left open), the
  // voxels by us: nifti_image_write() returns nothing, so a full disk would
  // leave a truncated file behind a run that exits 0.
  nim->data = nullptr;  // ours, not niftilib's to free
  errno = 0;
  znzFile fp = nifti_image_write_hdr_img(nim.get(), 2, "wb");
  if (znz_isnull(fp))
    throw InputError(path, std::string("cannot write the NIfTI header (") + std::strerror(errno ? errno : EIO) + ")");
  const std::size_t written = znzwrite(data.data(), 1, data.size(), fp);
  const int write_errno = errno;
  const int closed = znzclose(fp);
  const int close_errno = errno;
  if (written != data.size() || closed != 0) {
    const int err = written != data.size() ? write_errno : close_errno;
    throw InputError(path, std::string("cannot write file (") + std::strerror(err ? err : EIO) + ")");
  }
  file.commit();
}

}  // namespace isoloft
