#include "isoloft/io/nrrd.h"

#include <Eigen/Dense>
#include <teem/nrrd.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string_view>
#include <vector>
#include <cstdlib>
#include <memory>

#include "isoloft/core/error.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/atomic_file.h"

namespace isoloft {

// ------------------------------------------------------------------ writer

struct NrrdWriter::Impl {
  std::string path;
  AtomicFile file;
  std::FILE* fp = nullptr;
  bool gzip = false;
  z_stream zs{};
  bool zs_open = false;
  std::vector<unsigned char> bytes;  // one plane, little-endian
  std::vector<unsigned char> zbuf;

  explicit Impl(const std::string& p) : path(p), file(p) {}
  ~Impl() {
    if (zs_open) deflateEnd(&zs);
    if (fp) std::fclose(fp);
  }
  void put(const unsigned char* data, std::size_t n) {
    if (n && std::fwrite(data, 1, n, fp) != n) throw Error(path + ": write error (" + std::strerror(errno) + ")");
  }
  void deflate_all(const unsigned char* data, std::size_t n, int flush) {
    zs.next_in = const_cast<unsigned char*>(data);
    zs.avail_in = uInt(n);
    int rc;
    do {
      zs.next_out = zbuf.data();
      zs.avail_out = uInt(zbuf.size());
      rc = deflate(&zs, flush);
      if (rc == Z_STREAM_ERROR) throw Error(path + ": zlib deflate failed");
      put(zbuf.data(), zbuf.size() - zs.avail_out);
    } while (zs.avail_out == 0 || (flush == Z_FINISH && rc != Z_STREAM_END));
  }
};

namespace {
std::string fmt(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest round-trip form
  return std::string(buf, r.ptr);
}
}  // namespace

NrrdWriter::NrrdWriter(const std::string& path, int nx, int ny, int nz, std::array<double, 3> spacing,
                       std::array<double, 3> origin, NrrdEncoding encoding)
    : NrrdWriter(path, nx, ny, nz, [&] {
        for (double s : spacing)
          if (!(std::isfinite(s) && s > 0.0)) throw ParamError(path + ": NRRD spacing must be finite and > 0");
        return NrrdGeometry{Eigen::Vector3d(spacing[0], spacing[1], spacing[2]).asDiagonal(), origin, false};
      }(), encoding) {}

NrrdWriter::NrrdWriter(const std::string& path, int nx, int ny, int nz, const NrrdGeometry& g, NrrdEncoding encoding)
    : nx_(nx), ny_(ny), nz_(nz) {
  if (nx < 1 || ny < 1 || nz < 1)
    throw ParamError(path + ": NRRD sizes must be >= 1, got " + std::to_string(nx) + "x" + std::to_string(ny) + "x" +
                     std::to_string(nz));
  if (!g.axes.allFinite() || !(std::abs(g.axes.determinant()) > 0)) throw ParamError(path + ": NRRD axes must be finite and independent");
  for (double o : g.origin)
    if (!std::isfinite(o)) throw ParamError(path + ": NRRD origin must be finite");
  if (std::uint64_t(nx) * std::uint64_t(ny) * 4 > std::uint64_t(1) << 31)
    throw ParamError(path + ": NRRD plane too large");
  impl_ = std::make_unique<Impl>(path);
  impl_->gzip = encoding == NrrdEncoding::Gzip;
  impl_->fp = std::fopen(impl_->file.temp_path().c_str(), "wb");
  if (!impl_->fp) throw Error(path + ": cannot create file (" + std::strerror(errno) + ")");
  auto vec = [](double x, double y, double z) { return "(" + fmt(x) + "," + fmt(y) + "," + fmt(z) + ")"; };
  std::ostringstream h;
  h << "NRRD0004\n"
    << "# Complete NRRD file format specification at:\n"
    << "# http://teem.sourceforge.net/nrrd/format.html\n"
    << "# written by isoloft\n"
    << "type: float\n"
    << "dimension: 3\n"
    << (g.patient ? "space: left-posterior-superior\n" : "space dimension: 3\n")
    << "sizes: " << nx << ' ' << ny << ' ' << nz << '\n'
    << "space directions: " << vec(g.axes(0, 0), g.axes(1, 0), g.axes(2, 0)) << ' '
    << vec(g.axes(0, 1), g.axes(1, 1), g.axes(2, 1)) << ' ' << vec(g.axes(0, 2), g.axes(1, 2), g.axes(2, 2)) << '\n'
    << "kinds: domain domain domain\n"
    << "endian: little\n"
    << "encoding: " << (impl_->gzip ? "gzip" : "raw") << '\n'
    << "space origin: " << vec(g.origin[0], g.origin[1], g.origin[2]) << "\n\n";
  const std::string header = h.str();
  impl_->put(reinterpret_cast<const unsigned char*>(header.data()), header.size());
  if (impl_->gzip) {
    // Level 1: distance fields barely compress better at higher levels, and
    // the writer sits on the pipeline's critical path. 15 + 16: gzip wrapper.
    if (deflateInit2(&impl_->zs, 1, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
      throw Error(path + ": zlib initialisation failed");
    impl_->zs_open = true;
    impl_->zbuf.resize(std::size_t(1) << 18);
  }
}

NrrdWriter::~NrrdWriter() = default;

void NrrdWriter::write_plane(const Grid2f& plane) {
  Impl& im = *impl_;
  if (im.fp == nullptr) throw ParamError(im.path + ": NRRD already finished");
  if (plane.width != nx_ || plane.height != ny_)
    throw ParamError(im.path + ": plane " + std::to_string(written_) + " is " + std::to_string(plane.width) + "x" +
                     std::to_string(plane.height) + ", expected " + std::to_string(nx_) + "x" + std::to_string(ny_));
  if (written_ >= nz_) throw ParamError(im.path + ": more than the declared " + std::to_string(nz_) + " planes");
  const std::size_t n = plane.data.size();
  im.bytes.resize(n * 4);
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(im.bytes.data(), plane.data.data(), n * 4);
  } else {
    for (std::size_t i = 0; i < n; ++i) {
      const auto u = std::bit_cast<std::uint32_t>(plane.data[i]);
      for (int b = 0; b < 4; ++b) im.bytes[4 * i + std::size_t(b)] = (u >> (8 * b)) & 0xFF;
    }
  }
  if (im.gzip)
    im.deflate_all(im.bytes.data(), im.bytes.size(), Z_NO_FLUSH);
  else
    im.put(im.bytes.data(), im.bytes.size());
  ++written_;
}

void NrrdWriter::finish() {
  Impl& im = *impl_;
  if (im.fp == nullptr) throw Error(im.path + ": NRRD already finished");
  if (written_ != nz_)
    throw Error(im.path + ": only " + std::to_string(written_) + " of " + std::to_string(nz_) + " planes written");
  if (im.gzip) {
    im.deflate_all(nullptr, 0, Z_FINISH);
    deflateEnd(&im.zs);
    im.zs_open = false;
  }
  const bool bad = std::ferror(im.fp) != 0;
  const bool close_bad = std::fclose(im.fp) != 0;
  im.fp = nullptr;
  if (bad || close_bad) throw Error(im.path + ": write error (" + std::strerror(errno) + ")");
  im.file.commit();
}

void write_nrrd(const std::string& path, const Volume& v, NrrdEncoding encoding) {
  if (v.data.size() != std::size_t(v.nx) * std::size_t(v.ny) * std::size_t(v.nz))
    throw ParamError(path + ": volume data size does not match its sizes");
  NrrdWriter w(path, v.nx, v.ny, v.nz, v.spacing, v.origin, encoding);
  for (int z = 0; z < v.nz; ++z) w.write_plane(v.plane(z));
  w.finish();
}

// ------------------------------------------------------------------ reader (teem)

namespace {

struct NrrdDeleter {
  void operator()(Nrrd* n) const { nrrdNuke(n); }
};

// teem's biff message for NRRD, first line only (the rest is the call stack).
std::string teem_error() {
  char* e = biffGetDone(NRRD);
  std::string s = e ? e : "unknown error";
  std::free(e);
  const std::size_t nl = s.find('\n');
  if (nl != std::string::npos) s.resize(nl);
  const std::size_t colon = s.find(": ");  // "[nrrd] _nrrdRead: ..." -> the message
  return colon != std::string::npos && colon + 2 < s.size() ? s.substr(colon + 2) : s;
}

using detail::kOrthogonalityTolerance;

// Patient LPS from the NRRD's space: diagonal sign flips.
bool lps_flip(int space, Eigen::Vector3d& flip) {
  switch (space) {
    case nrrdSpaceLeftPosteriorSuperior: flip = {1, 1, 1}; return true;
    case nrrdSpaceRightAnteriorSuperior: flip = {-1, -1, 1}; return true;
    case nrrdSpaceLeftAnteriorSuperior: flip = {1, -1, 1}; return true;
    case nrrdSpaceUnknown:  // "space dimension: 3": an unnamed space, taken as LPS
    case nrrdSpaceScannerXYZ:
    case nrrdSpace3DRightHanded:
    case nrrdSpace3DLeftHanded: flip = {1, 1, 1}; return true;  // taken as LPS (no anatomical naming)
    default: return false;
  }
}


// teem stops reading gzip data once it has the bytes it needs, so a damaged
// member passes unnoticed; this inflates the attached member to its end,
// which checks the gzip CRC and length.
void check_attached_gzip(const std::string& path, const std::vector<unsigned char>& bytes) {
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  const std::size_t end = text.find("\n\n");
  if (end == std::string_view::npos || text.substr(0, end).find("\ndata file:") != std::string_view::npos ||
      text.substr(0, end).find("\ndatafile:") != std::string_view::npos)
    return;  // detached data: teem's own checks only
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 16) != Z_OK) return;
  zs.next_in = const_cast<unsigned char*>(bytes.data() + end + 2);
  zs.avail_in = uInt(bytes.size() - end - 2);
  std::vector<unsigned char> sink(1 << 16);
  int rc = Z_OK;
  while (rc == Z_OK) {
    zs.next_out = sink.data();
    zs.avail_out = uInt(sink.size());
    rc = inflate(&zs, Z_NO_FLUSH);
    if (rc == Z_BUF_ERROR && zs.avail_in == 0) break;
  }
  inflateEnd(&zs);
  if (rc != Z_STREAM_END) throw InputError(path, "corrupt or truncated gzip data (its checksum does not match)");
}

}  // namespace

Volume read_nrrd(const std::string& path) {
  // A missing or unreadable file named as such, not by teem.
  const std::vector<unsigned char> bytes = detail::read_file_bytes(path, 0);
  std::unique_ptr<Nrrd, NrrdDeleter> n(nrrdNew());
  if (nrrdLoad(n.get(), path.c_str(), nullptr)) throw InputError(path, "not a readable NRRD: " + teem_error());
  if (n->dim >= 1 && nrrdEncodingGzip->available() && std::string_view(reinterpret_cast<const char*>(bytes.data()),
                                                                         std::min<std::size_t>(bytes.size(), 4096))
                                                            .find("encoding: gz") != std::string_view::npos)
    check_attached_gzip(path, bytes);
  if (n->dim != 2 && n->dim != 3)
    throw InputError(path, "NRRD of dimension " + std::to_string(n->dim) + " (need one 2D or 3D scalar volume)");
  for (unsigned a = 0; a < n->dim; ++a)
    if (n->axis[a].kind != nrrdKindUnknown && !nrrdKindIsDomain(n->axis[a].kind))
      throw InputError(path, std::string("axis ") + std::to_string(a) + " is of kind " +
                                 airEnumStr(nrrdKind, n->axis[a].kind) + " (need scalar samples on a spatial grid)");
  using detail::ScalarType;
  ScalarType type;
  switch (n->type) {
    case nrrdTypeChar: type = ScalarType::I8; break;
    case nrrdTypeUChar: type = ScalarType::U8; break;
    case nrrdTypeShort: type = ScalarType::I16; break;
    case nrrdTypeUShort: type = ScalarType::U16; break;
    case nrrdTypeInt: type = ScalarType::I32; break;
    case nrrdTypeUInt: type = ScalarType::U32; break;
    case nrrdTypeFloat: type = ScalarType::F32; break;
    case nrrdTypeDouble: type = ScalarType::F64; break;
    default: throw InputError(path, std::string("unsupported NRRD type ") + airEnumStr(nrrdType, n->type));
  }
  Volume v;
  v.nx = int(n->axis[0].size);
  v.ny = int(n->axis[1].size);
  v.nz = n->dim == 3 ? int(n->axis[2].size) : 1;
  const std::size_t count = detail::checked_voxel_count(v.nx, v.ny, v.nz, path);
  if (n->spaceDim == 3) {
    Eigen::Vector3d flip;
    if (!lps_flip(n->space, flip))
      throw InputError(path, std::string("unsupported NRRD space ") + airEnumStr(nrrdSpace, n->space));
    auto dir = [&](unsigned a) {
      return Eigen::Vector3d(n->axis[a].spaceDirection[0], n->axis[a].spaceDirection[1], n->axis[a].spaceDirection[2]);
    };
    for (unsigned a = 0; a < 3; ++a) {
      // A 2D image: its third axis is its normal, unit spacing.
      const Eigen::Vector3d d = a < n->dim ? dir(a) : Eigen::Vector3d(dir(0).cross(dir(1)).normalized());
      const double len = d.norm();
      if (!(std::isfinite(len) && len > 0))
        throw InputError(path, "space direction of axis " + std::to_string(a) + " is missing or zero");
      v.spacing[a] = len;
      v.direction.col(a) = flip.asDiagonal() * (d / len);
    }
    for (unsigned s = 0; s < 3; ++s) v.origin[s] = std::isfinite(n->spaceOrigin[s]) ? flip[s] * n->spaceOrigin[s] : 0.0;
  } else if (n->spaceDim == 0) {
    for (unsigned a = 0; a < n->dim; ++a) {
      const double s = n->axis[a].spacing;
      if (std::isfinite(s) && s <= 0) throw InputError(path, "spacing of axis " + std::to_string(a) + " must be > 0");
      v.spacing[a] = std::isfinite(s) ? s : 1.0;
      const double lo = n->axis[a].min;
      v.origin[a] = std::isfinite(lo) ? lo : 0.0;
    }
  } else {
    throw InputError(path, "NRRD space of dimension " + std::to_string(n->spaceDim) + " (need 3)");
  }
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      if (std::abs(v.direction.col(a).dot(v.direction.col(b))) > kOrthogonalityTolerance)
        throw InputError(path, "sheared voxel axes (space directions not orthogonal): not supported");
  v.integer = type != ScalarType::F32 && type != ScalarType::F64;
  detail::resize_large(v.data, count);
  detail::decode_scalars(static_cast<const unsigned char*>(n->data), count, type,
                         std::endian::native == std::endian::big, v.data.data());
  return v;
}

void write_nrrd_volume(const std::string& path, const Volume& v) {
  const std::size_t count = detail::checked_voxel_count(v.nx, v.ny, v.nz, path);
  if (v.data.size() != count) throw ParamError(path + ": volume data size does not match its sizes");
  const detail::ScalarType stored = detail::storage_type(v);
  const int type = stored == detail::ScalarType::U8 ? nrrdTypeUChar : stored == detail::ScalarType::U16 ? nrrdTypeUShort
                   : stored == detail::ScalarType::I32 ? nrrdTypeInt : nrrdTypeFloat;
  std::vector<unsigned char> bytes = detail::encode_scalars(v, stored);
  std::unique_ptr<Nrrd, NrrdDeleter> n(nrrdNew());
  if (nrrdWrap_va(n.get(), bytes.data(), type, 3, std::size_t(v.nx), std::size_t(v.ny), std::size_t(v.nz)))
    throw Error(path + ": " + teem_error());
  nrrdSpaceSet(n.get(), nrrdSpaceLeftPosteriorSuperior);
  double d[3][NRRD_SPACE_DIM_MAX];
  for (int a = 0; a < 3; ++a)
    for (int r = 0; r < 3; ++r) d[a][r] = v.direction(r, a) * v.spacing[std::size_t(a)];
  nrrdAxisInfoSet_va(n.get(), nrrdAxisInfoSpaceDirection, d[0], d[1], d[2]);
  const int kinds[3] = {nrrdKindDomain, nrrdKindDomain, nrrdKindDomain};
  nrrdAxisInfoSet_nva(n.get(), nrrdAxisInfoKind, kinds);
  double origin[NRRD_SPACE_DIM_MAX] = {v.origin[0], v.origin[1], v.origin[2]};
  nrrdSpaceOriginSet(n.get(), origin);
  NrrdIoState* io = nrrdIoStateNew();
  nrrdIoStateEncodingSet(io, nrrdEncodingGzip);
  AtomicFile file(path);
  const int rc = nrrdSave(file.temp_path().c_str(), n.get(), io);
  nrrdIoStateNix(io);
  n->data = nullptr;  // ours
  if (rc) throw Error(path + ": " + teem_error());
  file.commit();
}

}  // namespace isoloft
