#include "isoloft/io/nrrd.h"

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
    : nx_(nx), ny_(ny), nz_(nz) {
  if (nx < 1 || ny < 1 || nz < 1)
    throw ParamError(path + ": NRRD sizes must be >= 1, got " + std::to_string(nx) + "x" + std::to_string(ny) + "x" +
                     std::to_string(nz));
  for (int a = 0; a < 3; ++a) {
    if (!(std::isfinite(spacing[std::size_t(a)]) && spacing[std::size_t(a)] > 0.0))
      throw ParamError(path + ": NRRD spacing must be finite and > 0");
    if (!std::isfinite(origin[std::size_t(a)])) throw ParamError(path + ": NRRD origin must be finite");
  }
  if (std::uint64_t(nx) * std::uint64_t(ny) * 4 > std::uint64_t(1) << 31)
    throw ParamError(path + ": NRRD plane too large");
  impl_ = std::make_unique<Impl>(path);
  impl_->gzip = encoding == NrrdEncoding::Gzip;
  impl_->fp = std::fopen(impl_->file.temp_path().c_str(), "wb");
  if (!impl_->fp) throw Error(path + ": cannot create file (" + std::strerror(errno) + ")");
  std::ostringstream h;
  h << "NRRD0004\n"
    << "# Complete NRRD file format specification at:\n"
    << "# http://teem.sourceforge.net/nrrd/format.html\n"
    << "# written by isoloft\n"
    << "type: float\n"
    << "dimension: 3\n"
    << "space dimension: 3\n"
    << "sizes: " << nx << ' ' << ny << ' ' << nz << '\n'
    << "space directions: (" << fmt(spacing[0]) << ",0,0) (0," << fmt(spacing[1]) << ",0) (0,0," << fmt(spacing[2])
    << ")\n"
    << "kinds: domain domain domain\n"
    << "endian: little\n"
    << "encoding: " << (impl_->gzip ? "gzip" : "raw") << '\n'
    << "space origin: (" << fmt(origin[0]) << ',' << fmt(origin[1]) << ',' << fmt(origin[2]) << ")\n\n";
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

// ------------------------------------------------------------------ reader

namespace {

std::string trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return std::string(s);
}

std::vector<std::string> words(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

bool to_double(const std::string& s, double& v) {
  const char* b = s.data();
  if (!s.empty() && s[0] == '+') ++b;
  const auto r = std::from_chars(b, s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

/// "(a,b,c) (d,e,f) none" -> vectors (empty for "none").
std::vector<std::vector<double>> parse_vectors(const std::string& s, const std::string& path) {
  std::vector<std::vector<double>> out;
  std::size_t i = 0;
  while (i < s.size()) {
    if (std::isspace(static_cast<unsigned char>(s[i]))) {
      ++i;
    } else if (s.compare(i, 4, "none") == 0) {
      out.emplace_back();
      i += 4;
    } else if (s[i] == '(') {
      const std::size_t e = s.find(')', i);
      if (e == std::string::npos) throw InputError(path, "bad vector '" + s + "'");
      std::vector<double> v;
      std::string item;
      std::istringstream parts(s.substr(i + 1, e - i - 1));
      while (std::getline(parts, item, ',')) {
        double d;
        if (!to_double(trim(item), d)) throw InputError(path, "bad number in vector '" + s + "'");
        v.push_back(d);
      }
      out.push_back(v);
      i = e + 1;
    } else {
      throw InputError(path, "bad vector list '" + s + "'");
    }
  }
  return out;
}

bool nrrd_type(const std::string& t, detail::ScalarType& out) {
  using detail::ScalarType;
  static const std::pair<const char*, ScalarType> names[] = {{"signed char", ScalarType::I8},
                                                             {"int8", ScalarType::I8},
                                                             {"int8_t", ScalarType::I8},
                                                             {"uchar", ScalarType::U8},
                                                             {"unsigned char", ScalarType::U8},
                                                             {"uint8", ScalarType::U8},
                                                             {"uint8_t", ScalarType::U8},
                                                             {"short", ScalarType::I16},
                                                             {"short int", ScalarType::I16},
                                                             {"signed short", ScalarType::I16},
                                                             {"signed short int", ScalarType::I16},
                                                             {"int16", ScalarType::I16},
                                                             {"int16_t", ScalarType::I16},
                                                             {"ushort", ScalarType::U16},
                                                             {"unsigned short", ScalarType::U16},
                                                             {"unsigned short int", ScalarType::U16},
                                                             {"uint16", ScalarType::U16},
                                                             {"uint16_t", ScalarType::U16},
                                                             {"int", ScalarType::I32},
                                                             {"signed int", ScalarType::I32},
                                                             {"int32", ScalarType::I32},
                                                             {"int32_t", ScalarType::I32},
                                                             {"uint", ScalarType::U32},
                                                             {"unsigned int", ScalarType::U32},
                                                             {"uint32", ScalarType::U32},
                                                             {"uint32_t", ScalarType::U32},
                                                             {"float", ScalarType::F32},
                                                             {"double", ScalarType::F64}};
  for (const auto& [n, v] : names)
    if (t == n) {
      out = v;
      return true;
    }
  return false;
}

}  // namespace

Volume read_nrrd(const std::string& path) {
  const std::vector<unsigned char> bytes = detail::read_file_bytes(path);
  const char* p = reinterpret_cast<const char*>(bytes.data());
  const char* end = p + bytes.size();
  auto next_line = [&](std::string& line) {
    if (p >= end) return false;
    const char* e = static_cast<const char*>(std::memchr(p, '\n', std::size_t(end - p)));
    if (!e) e = end;
    line.assign(p, e);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    p = e < end ? e + 1 : end;
    return true;
  };
  std::string line;
  if (!next_line(line) || line.rfind("NRRD000", 0) != 0) throw InputError(path, "not a NRRD file");

  int dimension = 0;
  std::vector<long long> sizes;
  detail::ScalarType type = detail::ScalarType::F32;
  bool have_type = false, gzip = false, big = false;
  std::array<double, 3> spacing{1.0, 1.0, 1.0}, origin{0.0, 0.0, 0.0};
  std::string data_file;
  bool blank_seen = false;
  while (next_line(line)) {
    if (line.empty()) {
      blank_seen = true;
      break;
    }
    if (line[0] == '#') continue;
    if (line.find(":=") != std::string::npos) continue;  // key/value pairs: not needed
    const std::size_t colon = line.find(": ");
    if (colon == std::string::npos) throw InputError(path, "bad header line '" + line + "'");
    const std::string key = line.substr(0, colon);
    const std::string val = trim(std::string_view(line).substr(colon + 2));
    if (key == "type") {
      if (!nrrd_type(val, type)) throw InputError(path, "unsupported NRRD type '" + val + "'");
      have_type = true;
    } else if (key == "dimension") {
      if (val != "2" && val != "3") throw InputError(path, "NRRD dimension " + val + " (need 2 or 3)");
      dimension = std::stoi(val);
    } else if (key == "sizes") {
      for (const auto& w : words(val)) {
        long long n = 0;
        const auto r = std::from_chars(w.data(), w.data() + w.size(), n);
        if (r.ec != std::errc() || r.ptr != w.data() + w.size()) throw InputError(path, "bad sizes '" + val + "'");
        sizes.push_back(n);
      }
    } else if (key == "encoding") {
      if (val == "raw") {
        gzip = false;
      } else if (val == "gzip" || val == "gz") {
        gzip = true;
      } else {
        throw InputError(path, "unsupported NRRD encoding '" + val + "' (raw or gzip)");
      }
    } else if (key == "endian") {
      big = val == "big";
    } else if (key == "space directions") {
      const auto dirs = parse_vectors(val, path);
      for (std::size_t a = 0; a < dirs.size() && a < 3; ++a) {
        const auto& d = dirs[a];
        if (d.empty()) continue;
        for (std::size_t b = 0; b < d.size(); ++b)
          if (b != a && d[b] != 0.0) throw InputError(path, "space directions are not axis-aligned (unsupported)");
        if (a < d.size()) spacing[a] = d[a];
      }
    } else if (key == "spacings") {
      const auto w = words(val);
      for (std::size_t a = 0; a < w.size() && a < 3; ++a) {
        double d;
        if (to_double(w[a], d) && std::isfinite(d)) spacing[a] = d;  // "nan" = unknown
      }
    } else if (key == "space origin") {
      const auto o = parse_vectors(val, path);
      if (o.size() != 1) throw InputError(path, "bad space origin '" + val + "'");
      for (std::size_t a = 0; a < o[0].size() && a < 3; ++a) origin[a] = o[0][a];
    } else if (key == "data file" || key == "datafile") {
      data_file = val;
    } else if (key == "byte skip" || key == "byteskip" || key == "line skip" || key == "lineskip") {
      if (val != "0") throw InputError(path, "'" + key + ": " + val + "' is not supported");
    }
    // kinds, centers, space, space dimension, units, content, ...: not needed
  }
  if (!have_type) throw InputError(path, "NRRD header lacks 'type'");
  if (dimension == 0) throw InputError(path, "NRRD header lacks 'dimension'");
  if (int(sizes.size()) != dimension)
    throw InputError(path, "NRRD 'sizes' has " + std::to_string(sizes.size()) + " entries for dimension " +
                               std::to_string(dimension));
  for (long long s : sizes)
    if (s < 1 || s > (1 << 30)) throw InputError(path, "bad NRRD size " + std::to_string(s));
  Volume v;
  v.nx = int(sizes[0]);
  v.ny = int(sizes[1]);
  v.nz = dimension == 3 ? int(sizes[2]) : 1;
  v.spacing = spacing;
  v.origin = origin;
  const std::size_t count = detail::checked_voxel_count(v.nx, v.ny, v.nz, path);
  const std::size_t nbytes = count * detail::scalar_size(type);

  std::vector<unsigned char> detached;
  const unsigned char* data = nullptr;
  std::size_t available = 0;
  std::string data_name = path;
  if (!data_file.empty()) {
    if (data_file.rfind("LIST", 0) == 0 || data_file.find('%') != std::string::npos)
      throw InputError(path, "multi-file NRRD data is not supported");
    std::filesystem::path dp(data_file);
    if (dp.is_relative()) dp = std::filesystem::path(path).parent_path() / dp;
    data_name = dp.string();
    detached = detail::read_file_bytes(data_name);
    data = detached.data();
    available = detached.size();
  } else {
    if (!blank_seen) throw InputError(path, "NRRD header not followed by data");
    data = reinterpret_cast<const unsigned char*>(p);
    available = std::size_t(end - p);
  }
  std::vector<unsigned char> inflated;
  if (gzip) {
    inflated = detail::inflate_exact(data, available, nbytes, data_name);
    data = inflated.data();
  } else if (available < nbytes) {
    throw InputError(data_name,
                     "NRRD data truncated: " + std::to_string(available) + " of " + std::to_string(nbytes) + " bytes");
  }
  v.data.resize(count);
  detail::decode_scalars(data, count, type, big, v.data.data());
  return v;
}

}  // namespace isoloft
