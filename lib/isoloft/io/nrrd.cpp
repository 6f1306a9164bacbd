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
#include <limits>
#include <memory>

#include "isoloft/core/error.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/text.h"

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
struct IoStateDeleter {
  void operator()(NrrdIoState* io) const { nrrdIoStateNix(io); }
};

// teem's biff message for NRRD: its last line, the innermost call's reason
// (the first only says "trouble reading FILE").
std::string teem_error() {
  char* e = biffGetDone(NRRD);
  std::string s = e ? e : "";
  std::free(e);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  s = s.substr(s.rfind('\n') == std::string::npos ? 0 : s.rfind('\n') + 1);
  const std::size_t colon = s.find(": ");  // "[nrrd] _nrrdReadNrrdParse_sizes: ..." -> the message
  s = colon != std::string::npos && colon + 2 < s.size() ? s.substr(colon + 2) : s;
  return s.empty() ? "unknown error" : s;
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

// What the header text says about where the data are, read before teem
// opens anything: teem opens every data file the header names (a FIFO blocks
// there, "-" is standard input) even when asked for the header only.
struct DataLayout {
  std::size_t attached_at = 0;          // attached data: its first byte in the file
  std::vector<std::string> files;       // detached data: every data file, resolved
};

// "%d", "%03d": the one integer directive of a data file template ("%%" aside).
bool one_int_directive(const std::string& f) {
  int directives = 0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f[i] != '%') continue;
    if (i + 1 < f.size() && f[i + 1] == '%') {
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    while (j < f.size() && f[j] >= '0' && f[j] <= '9') ++j;
    if (j >= f.size() || f[j] != 'd') return false;
    ++directives;
    i = j;
  }
  return directives == 1;
}

DataLayout data_layout(const std::string& path, const detail::FileBytes& file, const VolumeReadOptions& options) {
  const std::string_view text(reinterpret_cast<const char*>(file.data()), file.size());
  DataLayout out;
  std::vector<std::string> names;
  std::size_t pos = 0;
  // Lines as teem reads them: up to '\n', a trailing '\r' dropped.
  auto next_line = [&] {
    const std::size_t nl = text.find('\n', pos);
    const std::size_t end = nl == std::string_view::npos ? text.size() : nl;
    std::string_view line = text.substr(pos, end - pos);
    pos = end + (nl == std::string_view::npos ? 0 : 1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return line;
  };
  bool found = false;
  while (pos < text.size()) {
    const std::string_view line = next_line();
    if (line.empty()) break;  // the blank line: attached data follow
    // "<field>: <info>", the field named case-blind, as teem's airEnum does.
    const std::size_t colon = line.find(": ");
    if (line[0] == '#' || colon == std::string_view::npos) continue;
    std::string key(line.substr(0, colon));
    std::transform(key.begin(), key.end(), key.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (key != "data file" && key != "datafile") continue;
    found = true;
    const std::string info(detail::trim(line.substr(colon + 2)));
    if (info.find('%') != std::string::npos && info.find('d', info.find('%')) != std::string::npos) {
      // "name%03d.raw <min> <max> <step> [<dim>]"
      std::istringstream in(info);
      std::string format;
      int lo = 0, hi = 0, step = 0;
      if (!(in >> format >> lo >> hi >> step) || !one_int_directive(format) || step == 0 ||
          ((long long)hi - lo) * step < 0)
        throw InputError(path, "data file template '" + info + "': expected 'name%d.ext <min> <max> <step>' with one %d");
      constexpr long long kMaxFiles = 1 << 20;
      if (((long long)hi - lo) / step + 1 > kMaxFiles)
        throw InputError(path, "data file template '" + info + "' names more than " + std::to_string(kMaxFiles) + " files");
      for (long long i = lo; step > 0 ? i <= hi : i >= hi; i += step) {
        char name[4096];
        std::snprintf(name, sizeof name, format.c_str(), int(i));
        names.emplace_back(name);
      }
    } else if (info.rfind("LIST", 0) == 0) {
      while (pos < text.size()) names.emplace_back(next_line());  // every further line names a data file
    } else {
      names.push_back(info);
    }
  }
  if (!found) {
    out.attached_at = std::min(pos, text.size());
    return out;
  }
  const std::string folder = std::filesystem::path(path).parent_path().string();
  for (const std::string& name : names) {
    if (name == "-") throw InputError(path, "data file '-' (standard input) is not read");
    // As teem resolves it: names starting with '/' or "X:" as they are, the others from the header's folder.
    const bool as_is = !name.empty() && (name[0] == '/' || (name.size() > 1 && name[1] == ':'));
    const std::string resolved = as_is ? name : (folder.empty() ? "." : folder) + "/" + name;
    detail::check_data_file(path, name, resolved, options.allow_external_data);
    out.files.push_back(resolved);
  }
  return out;
}

// gzip checks its CRC and length at the end of the stream, which teem never
// reads (it stops once it has the bytes it needs), so a damaged member passes
// unnoticed; this inflates the member to its end.
void check_gzip_stream(const std::string& path, const unsigned char* data, std::size_t size) {
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 16) != Z_OK) return;
  zs.next_in = const_cast<unsigned char*>(data);
  zs.avail_in = uInt(std::min<std::size_t>(size, std::numeric_limits<uInt>::max()));
  std::vector<unsigned char> sink(1 << 16);
  int rc = Z_OK;
  while (rc == Z_OK) {
    zs.next_out = sink.data();
    zs.avail_out = uInt(sink.size());
    rc = inflate(&zs, Z_NO_FLUSH);
    if (rc == Z_BUF_ERROR && zs.avail_in == 0) break;
  }
  const std::string why = zs.msg ? zs.msg : rc == Z_STREAM_END ? "" : "the stream ends early";
  inflateEnd(&zs);
  if (rc != Z_STREAM_END) throw InputError(path, "corrupt or truncated gzip data (zlib: " + why + ")");
}

// Bytes the data can decode to at most, per encoding: deflate 1032:1, ZRL
// 16384:1 (a 4-byte run of up to 65535 zeros), raw 1:1, text about 2 bytes a
// sample (a digit and a separator), hex 2 characters a byte; bzip2 unbounded.
double max_decoded_bytes(const ::NrrdEncoding* e, double stored, std::size_t sample_bytes) {
  if (e == nrrdEncodingGzip) return 1032.0 * stored + 1024.0;
  if (e == nrrdEncodingZRL) return 16384.0 * stored + 65536.0;
  if (e == nrrdEncodingRaw) return stored;
  if (e == nrrdEncodingAscii) return (stored + 1) / 2 * double(sample_bytes);
  if (e == nrrdEncodingHex) return stored / 2;
  return std::numeric_limits<double>::infinity();
}

// teem's ZRL reader counts in 32 bits (a volume of 2^32 bytes or more loops
// for ever) and pads data that run short with 255: decoded here instead.
// Stream: a non-zero byte stands for itself; 0, n (n > 0) for n zeros;
// 0, 0, lo, hi for lo + 256 hi zeros.
std::vector<unsigned char> decode_zrl(const std::string& file, const unsigned char* p, const unsigned char* end,
                                      std::size_t need) {
  std::vector<unsigned char> out;
  detail::resize_large(out, need);
  std::size_t j = 0;
  auto next = [&]() -> int { return p < end ? *p++ : -1; };
  while (j < need) {
    const int c = next();
    if (c < 0) break;
    if (c != 0) {
      out[j++] = static_cast<unsigned char>(c);
      continue;
    }
    const int d = next();
    std::size_t run = 0;
    if (d > 0) {
      run = std::size_t(d);
    } else if (d == 0) {
      const int lo = next(), hi = next();
      if (lo < 0 || hi < 0) break;
      run = std::size_t(lo) + 256 * std::size_t(hi);
    } else {
      break;
    }
    if (run > need - j)
      throw InputError(file, "ZRL data run past the end: " + std::to_string(j + run) + " bytes, the header declares " +
                                 std::to_string(need));
    std::fill_n(out.begin() + std::ptrdiff_t(j), run, 0);
    j += run;
  }
  if (j < need)
    throw InputError(file, "ZRL data run short: they decode to " + std::to_string(j) + " of the " + std::to_string(need) +
                               " bytes the header declares");
  return out;
}

// `skip` lines, then `bytes` bytes, from p: where the data start.
const unsigned char* skip_to_data(const unsigned char* p, const unsigned char* end, unsigned lines, long bytes) {
  for (unsigned l = 0; l < lines && p < end; ++l) {
    const void* nl = std::memchr(p, '\n', std::size_t(end - p));
    p = nl ? static_cast<const unsigned char*>(nl) + 1 : end;
  }
  return bytes > 0 ? p + std::min<std::size_t>(std::size_t(bytes), std::size_t(end - p)) : p;
}

}  // namespace

Volume read_nrrd(const std::string& path, const VolumeReadOptions& options) {
  const detail::FileBytes file(path);  // a missing, unreadable or non-regular file named as such, not by teem
  const DataLayout layout = data_layout(path, file, options);

  // The header alone (data skipped), checked before any data is read.
  std::unique_ptr<Nrrd, NrrdDeleter> n(nrrdNew());
  const std::unique_ptr<NrrdIoState, IoStateDeleter> nio(nrrdIoStateNew());
  nio->skipData = 1;
  if (nrrdLoad(n.get(), path.c_str(), nio.get())) throw InputError(path, "not a readable NRRD: " + teem_error());
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
  for (unsigned a = 0; a < n->dim; ++a)
    if (n->axis[a].size > std::size_t(std::numeric_limits<int>::max()))
      throw InputError(path, "size of axis " + std::to_string(a) + " (" + std::to_string(n->axis[a].size) +
                                 ") is beyond the largest read (2^31 - 1)");
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
  const std::size_t sample = detail::scalar_size(type), need = count * sample;

  // What the data files can hold against what the header declares: a 1 KB
  // gzip member cannot hold 4 GB, so nothing is allocated for it.
  std::vector<std::unique_ptr<detail::FileBytes>> data_files;
  double stored = 0;
  if (layout.files.empty()) {
    stored = double(file.size() - std::min(layout.attached_at, file.size()));
  } else {
    for (const std::string& f : layout.files) {
      data_files.push_back(std::make_unique<detail::FileBytes>(f));
      stored += double(data_files.back()->size());
    }
  }
  const std::string data_name = layout.files.size() == 1 ? layout.files[0] : path;
  if (double(need) > max_decoded_bytes(nio->encoding, stored, sample))
    throw InputError(data_name, std::to_string(std::uint64_t(stored)) + " bytes of " + nio->encoding->name +
                                    " data cannot hold the " + std::to_string(need) + " bytes the header declares (" +
                                    std::to_string(v.nx) + "x" + std::to_string(v.ny) + "x" + std::to_string(v.nz) +
                                    " samples)");
  if (options.on_header) options.on_header({v.nx, v.ny, v.nz, sample, layout.files});  // the budget: for data that can exist
  if (options.geometry_only) return v;

  if (nio->encoding == nrrdEncodingZRL) {
    if (layout.files.size() > 1) throw InputError(path, "ZRL data in several data files is not supported");
    const unsigned char* begin = layout.files.empty() ? file.data() + layout.attached_at : data_files[0]->data();
    const unsigned char* end = layout.files.empty() ? file.data() + file.size() : begin + data_files[0]->size();
    if (nio->byteSkip < 0) throw InputError(path, "byte skip -1 with ZRL data is not supported");
    begin = skip_to_data(begin, end, nio->lineSkip, nio->byteSkip);
    const std::vector<unsigned char> bytes = decode_zrl(data_name, begin, end, need);
    detail::take_or_decode(bytes.data(), type, nio->endian == airEndianBig, v, path, options);
    return v;
  }
  if (nio->encoding == nrrdEncodingGzip && nio->lineSkip == 0) {
    if (layout.files.empty())
      check_gzip_stream(path, file.data() + layout.attached_at, file.size() - std::min(layout.attached_at, file.size()));
    for (std::size_t f = 0; f < data_files.size(); ++f)
      check_gzip_stream(layout.files[f], data_files[f]->data(), data_files[f]->size());
  }
  std::unique_ptr<Nrrd, NrrdDeleter> full(nrrdNew());
  if (nrrdLoad(full.get(), path.c_str(), nullptr)) throw InputError(path, "not a readable NRRD: " + teem_error());
  if (nrrdElementNumber(full.get()) != count || full->type != n->type)
    throw InputError(path, "the file changed while it was being read");
  detail::take_or_decode(static_cast<const unsigned char*>(full->data), type, std::endian::native == std::endian::big, v,
                         path, options);
  return v;
}

void write_nrrd_volume(const std::string& path, const Volume& v) {
  const std::size_t count = detail::checked_voxel_count(v.nx, v.ny, v.nz, path);
  if (v.data.size() != count) throw ParamError(path + ": volume data size does not match its sizes");
  const detail::ScalarType stored = detail::storage_type(v);
  const int type = stored == detail::ScalarType::U8 ? nrrdTypeUChar : stored == detail::ScalarType::U16 ? nrrdTypeUShort
                   : stored == detail::ScalarType::I32 ? nrrdTypeInt : stored == detail::ScalarType::U32 ? nrrdTypeUInt
                   : nrrdTypeFloat;
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
