#include "isoloft/io/metaimage.h"

#include <Eigen/Dense>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <string_view>
#include <bit>
#include <sstream>
#include <vector>

#include <zlib.h>

#include <cerrno>
#include <cstdio>

#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/text.h"
#include "isoloft/io/file_util.h"

namespace isoloft {
namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

std::vector<double> numbers(const std::string& path, const std::string& key, const std::string& val) {
  std::vector<double> out;
  std::istringstream in(val);
  for (std::string w; in >> w;) {
    double d;
    const char* b = w.data() + (w[0] == '+' ? 1 : 0);
    const auto r = std::from_chars(b, w.data() + w.size(), d);
    if (r.ec != std::errc() || r.ptr != w.data() + w.size() || !std::isfinite(d))
      throw InputError(path, key + ": bad number '" + w + "'");
    out.push_back(d);
  }
  return out;
}

bool is_true(const std::string& v) {
  std::string l = v;
  std::transform(l.begin(), l.end(), l.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return l == "true" || l == "1";
}

bool is_false(const std::string& v) {
  std::string l = v;
  std::transform(l.begin(), l.end(), l.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return l == "false" || l == "0";
}

// ASCII samples (BinaryData = False): count whitespace-separated numbers,
// each checked against the element type, as native-endian elements of it.
std::vector<unsigned char> ascii_samples(const std::string& file, const unsigned char* p, std::size_t size,
                                         std::size_t count, detail::ScalarType type) {
  using detail::ScalarType;
  const std::size_t sample = detail::scalar_size(type);
  if (double(count) > double(size + 1) / 2)  // a digit and a separator each at least
    throw InputError(file, std::to_string(size) + " bytes of ASCII data cannot hold " + std::to_string(count) + " samples");
  std::vector<unsigned char> out;
  detail::resize_large(out, count * sample);
  const char* c = reinterpret_cast<const char*>(p);
  const char* const end = c + size;
  for (std::size_t i = 0; i < count; ++i) {
    while (c < end && detail::is_space(*c)) ++c;
    const char* b = c;
    while (c < end && !detail::is_space(*c)) ++c;
    const std::string_view tok(b, std::size_t(c - b));
    if (tok.empty())
      throw InputError(file, "ASCII data end after " + std::to_string(i) + " of " + std::to_string(count) + " samples");
    auto bad = [&] { return InputError(file, "ASCII sample " + std::to_string(i) + " '" + std::string(tok) + "' is not a valid value of the ElementType"); };
    unsigned char* dst = out.data() + i * sample;
    if (type == ScalarType::F32 || type == ScalarType::F64) {
      double d;
      if (!detail::parse_number(tok, d)) throw bad();
      if (type == ScalarType::F32) {
        const float f = float(d);
        std::memcpy(dst, &f, 4);
      } else {
        std::memcpy(dst, &d, 8);
      }
      continue;
    }
    long long x;
    if (!detail::parse_number(tok, x)) throw bad();
    auto put = [&](auto typed, long long lo, long long hi) {
      if (x < lo || x > hi) throw bad();
      typed = decltype(typed)(x);
      std::memcpy(dst, &typed, sizeof typed);
    };
    switch (type) {
      case ScalarType::U8: put(std::uint8_t{}, 0, 255); break;
      case ScalarType::I8: put(std::int8_t{}, -128, 127); break;
      case ScalarType::U16: put(std::uint16_t{}, 0, 65535); break;
      case ScalarType::I16: put(std::int16_t{}, -32768, 32767); break;
      case ScalarType::U32: put(std::uint32_t{}, 0, 4294967295LL); break;
      default: put(std::int32_t{}, -2147483648LL, 2147483647LL); break;
    }
  }
  while (c < end && detail::is_space(*c)) ++c;
  if (c != end) throw InputError(file, "ASCII data hold more than the " + std::to_string(count) + " samples DimSize declares");
  return out;
}

}  // namespace

Volume read_metaimage(const std::string& mhd, const VolumeReadOptions& options) {
  const detail::FileBytes header(mhd);  // a .mha's data too (LOCAL)
  std::map<std::string, std::string> kv;
  std::size_t pos = 0, local_offset = 0;
  bool local = false;
  while (pos < header.size()) {
    const auto* nl = static_cast<const unsigned char*>(std::memchr(header.data() + pos, '\n', header.size() - pos));
    const std::size_t e = nl ? std::size_t(nl - header.data()) : header.size();
    const std::string line(reinterpret_cast<const char*>(header.data()) + pos, e - pos);
    pos = e + 1;
    const std::size_t eq = line.find('=');
    if (trim(line).empty()) continue;
    if (eq == std::string::npos) throw InputError(mhd, "bad MetaImage header line '" + trim(line) + "'");
    const std::string key = trim(line.substr(0, eq));
    const std::string val = trim(line.substr(eq + 1));
    kv[key] = val;
    if (key == "ElementDataFile") {  // always the last header field
      local = val == "LOCAL";
      local_offset = std::min(pos, header.size());
      break;
    }
  }
  auto get = [&](const std::string& k) -> const std::string* {
    const auto it = kv.find(k);
    return it == kv.end() ? nullptr : &it->second;
  };
  if (!get("ElementDataFile")) throw InputError(mhd, "MetaImage header lacks ElementDataFile");
  if (!get("NDims") || !get("DimSize") || !get("ElementType"))
    throw InputError(mhd, "MetaImage header lacks NDims, DimSize or ElementType");

  const auto ndims_v = numbers(mhd, "NDims", *get("NDims"));
  if (ndims_v.size() != 1 || (ndims_v[0] != 2 && ndims_v[0] != 3))
    throw InputError(mhd, "NDims = " + *get("NDims") + " (need 2 or 3)");
  const int ndims = int(ndims_v[0]);
  const auto dims = numbers(mhd, "DimSize", *get("DimSize"));
  if (int(dims.size()) != ndims) throw InputError(mhd, "DimSize needs " + std::to_string(ndims) + " values");
  for (double d : dims)
    if (d < 1 || d != std::floor(d) || d > double(1 << 30))
      throw InputError(mhd, "bad DimSize '" + *get("DimSize") + "'");
  if (const auto* c = get("ElementNumberOfChannels"); c && trim(*c) != "1")
    throw InputError(mhd, "ElementNumberOfChannels = " + *c + " (only 1 is supported)");
  // TransformMatrix: the direction of each voxel axis in turn (ITK's MetaIO),
  // patient LPS as ITK writes it (AnatomicalOrientation is not used).
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  if (const auto* t = get("TransformMatrix")) {
    const auto m = numbers(mhd, "TransformMatrix", *t);
    const std::size_t n = std::size_t(ndims);
    if (m.size() != n * n) throw InputError(mhd, "TransformMatrix needs " + std::to_string(n * n) + " values");
    for (std::size_t c = 0; c < n; ++c)
      for (std::size_t r = 0; r < n; ++r) direction(Eigen::Index(r), Eigen::Index(c)) = m[c * n + r];
    if (n == 2) direction.col(2) = direction.col(0).cross(direction.col(1));
    for (int a = 0; a < 3; ++a) {
      const double len = direction.col(a).norm();
      if (!(len > 0)) throw InputError(mhd, "TransformMatrix: axis " + std::to_string(a) + " has no direction");
      direction.col(a) /= len;
    }
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b)
        if (std::abs(direction.col(a).dot(direction.col(b))) > detail::kOrthogonalityTolerance)
          throw InputError(mhd, "TransformMatrix: sheared voxel axes are not supported");
  }

  using detail::ScalarType;
  static const std::pair<const char*, ScalarType> types[] = {
      {"MET_UCHAR", ScalarType::U8},  {"MET_CHAR", ScalarType::I8},   {"MET_USHORT", ScalarType::U16},
      {"MET_SHORT", ScalarType::I16}, {"MET_UINT", ScalarType::U32},  {"MET_INT", ScalarType::I32},
      {"MET_FLOAT", ScalarType::F32}, {"MET_DOUBLE", ScalarType::F64}};
  const std::string& type_name = *get("ElementType");
  const auto ti = std::find_if(std::begin(types), std::end(types), [&](const auto& t) { return type_name == t.first; });
  if (ti == std::end(types)) throw InputError(mhd, "unsupported ElementType " + type_name);
  const ScalarType type = ti->second;

  Volume v;
  v.direction = direction;
  v.integer = type != ScalarType::F32 && type != ScalarType::F64;
  v.nx = int(dims[0]);
  v.ny = int(dims[1]);
  v.nz = ndims == 3 ? int(dims[2]) : 1;
  const std::string* sp = get("ElementSpacing") ? get("ElementSpacing") : get("ElementSize");
  if (sp) {
    const auto s = numbers(mhd, "ElementSpacing", *sp);
    if (int(s.size()) != ndims) throw InputError(mhd, "ElementSpacing needs " + std::to_string(ndims) + " values");
    for (int a = 0; a < ndims; ++a) {
      if (!(s[std::size_t(a)] > 0)) throw InputError(mhd, "ElementSpacing must be > 0");
      v.spacing[std::size_t(a)] = s[std::size_t(a)];
    }
  }
  const std::string* off = get("Offset") ? get("Offset") : get("Position") ? get("Position") : get("Origin");
  if (off) {
    const auto o = numbers(mhd, "Offset", *off);
    if (int(o.size()) != ndims) throw InputError(mhd, "Offset needs " + std::to_string(ndims) + " values");
    for (int a = 0; a < ndims; ++a) v.origin[std::size_t(a)] = o[std::size_t(a)];
  }
  bool big = false;
  if (const auto* b = get("BinaryDataByteOrderMSB")) big = is_true(*b);
  if (const auto* b = get("ElementByteOrderMSB")) big = is_true(*b);
  const bool compressed = get("CompressedData") && is_true(*get("CompressedData"));
  const bool binary = !get("BinaryData") || is_true(*get("BinaryData"));  // MetaIO's default: binary
  if (const auto* b = get("BinaryData"); b && !binary && !is_false(*b))
    throw InputError(mhd, "BinaryData = '" + *b + "' is neither True nor False");
  if (!binary && compressed) throw InputError(mhd, "ASCII data (BinaryData = False) cannot be compressed");

  const std::size_t count = detail::checked_voxel_count(v.nx, v.ny, v.nz, mhd);
  const std::size_t sample = detail::scalar_size(type), nbytes = count * sample;
  std::string data_name = mhd;
  std::unique_ptr<detail::FileBytes> file;  // the data file; LOCAL data stay in `header`
  const unsigned char* bytes = header.data() + local_offset;
  std::size_t size = header.size() - local_offset;
  if (local) {
    // MetaIO ends the header at ElementDataFile: a "Key = value" line after
    // it would be read as voxels, every voxel shifted.
    const std::string_view rest(reinterpret_cast<const char*>(bytes), std::min<std::size_t>(size, 256));
    const std::string_view first = rest.substr(0, rest.find('\n'));
    const std::size_t eq = first.find(" = ");
    if (eq != std::string_view::npos && eq > 0 &&
        std::all_of(first.begin(), first.begin() + std::ptrdiff_t(eq), [](char c) { return std::isalnum((unsigned char)c) || c == '_'; }))
      throw InputError(mhd, "header line '" + std::string(detail::trim(first)) +
                                "' after ElementDataFile = LOCAL: ElementDataFile must be the last header line (the "
                                "data start on the line after it)");
  } else {
    const std::string& df = *get("ElementDataFile");
    // MetaIO's multi-file forms: "LIST" (names on the lines after) and a
    // printf template ("slice%03d.raw 1 40 1"); any other name, spaces and
    // all, is one file.
    if (df.rfind("LIST", 0) == 0 || df.find('%') != std::string::npos)
      throw InputError(mhd, "multi-file MetaImage data '" + df + "' is not supported (one data file, or LOCAL)");
    std::filesystem::path dp(df);
    if (dp.is_relative()) dp = std::filesystem::path(mhd).parent_path() / dp;
    data_name = dp.string();
    detail::check_data_file(mhd, df, data_name, options.allow_external_data);
  }
  if (options.on_header)
    options.on_header({v.nx, v.ny, v.nz, sample, local ? std::vector<std::string>{} : std::vector<std::string>{data_name}});
  if (options.geometry_only) return v;
  if (!local) {
    file = std::make_unique<detail::FileBytes>(data_name);
    bytes = file->data();
    size = file->size();
  }
  const unsigned char* data = bytes;
  std::vector<unsigned char> decoded;
  if (!binary) {
    decoded = ascii_samples(data_name, bytes, size, count, type);
    detail::take_or_decode(decoded.data(), type, std::endian::native == std::endian::big, v, mhd, options);
    return v;
  }
  if (compressed) {
    decoded = detail::inflate_exact(bytes, size, nbytes, data_name);
    data = decoded.data();
  } else {
    long long skip = 0;
    const auto* hs = get("HeaderSize");
    if (hs) {
      const auto h = numbers(mhd, "HeaderSize", *hs);
      if (h.size() != 1 || h[0] < -1 || h[0] != std::floor(h[0])) throw InputError(mhd, "bad HeaderSize");
      skip = (long long)h[0];
    }
    if (skip == -1) skip = (long long)size - (long long)nbytes;  // data at the end of the file
    if (skip < 0 || std::size_t(skip) + nbytes > size)
      throw InputError(data_name, "data truncated: " + std::to_string(size) + " bytes, need " +
                                      std::to_string(nbytes + std::size_t(std::max(skip, 0LL))));
    // Without HeaderSize the data are the whole rest: more bytes than the
    // header declares means a wrong DimSize or ElementType, not padding.
    if (!hs && size != nbytes)
      throw InputError(data_name, std::to_string(size) + " bytes of voxel data, but DimSize " + *get("DimSize") + " of " +
                                      type_name + " declares " + std::to_string(nbytes) +
                                      " (a wrong DimSize or ElementType? HeaderSize skips a leading header)");
    const unsigned char* start = local ? header.data() : file->data();
    detail::take_or_decode_file(data_name, start, std::uint64_t(bytes + skip - start), type, big, v, options);
    return v;
  }
  detail::take_or_decode(data, type, big, v, mhd, options);
  return v;
}

void write_metaimage(const std::string& path, const Volume& v) {
  const std::size_t count = detail::checked_voxel_count(v.nx, v.ny, v.nz, path);
  if (v.data.size() != count) throw ParamError(path + ": volume data size does not match its sizes");
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext != ".mha") throw ParamError(path + ": MetaImage is written as one .mha file");
  const detail::ScalarType stored = detail::storage_type(v);
  const char* type = stored == detail::ScalarType::U8 ? "MET_UCHAR" : stored == detail::ScalarType::U16 ? "MET_USHORT"
                     : stored == detail::ScalarType::I32 ? "MET_INT" : stored == detail::ScalarType::U32 ? "MET_UINT"
                     : "MET_FLOAT";
  const std::vector<unsigned char> raw = detail::encode_scalars(v, stored);
  uLongf packed_size = compressBound(uLong(raw.size()));
  std::vector<unsigned char> packed(packed_size);
  if (compress2(packed.data(), &packed_size, raw.data(), uLong(raw.size()), 1) != Z_OK)
    throw Error(path + ": zlib compression failed");
  auto num = detail::shortest_text;
  std::string h = "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n";
  h += "CompressedData = True\nCompressedDataSize = " + std::to_string(packed_size) + "\nTransformMatrix =";
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) h += " " + num(v.direction(r, c));
  h += "\nOffset = " + num(v.origin[0]) + " " + num(v.origin[1]) + " " + num(v.origin[2]) + "\n";
  h += "AnatomicalOrientation = RAI\n";  // ITK's name for patient LPS
  h += "ElementSpacing = " + num(v.spacing[0]) + " " + num(v.spacing[1]) + " " + num(v.spacing[2]) + "\n";
  h += "DimSize = " + std::to_string(v.nx) + " " + std::to_string(v.ny) + " " + std::to_string(v.nz) + "\n";
  h += std::string("ElementType = ") + type + "\nElementDataFile = LOCAL\n";
  AtomicFile file(path);
  {
    std::FILE* fp = std::fopen(file.temp_path().c_str(), "wb");
    if (!fp) throw Error(path + ": cannot create file (" + std::strerror(errno) + ")");
    const bool ok = std::fwrite(h.data(), 1, h.size(), fp) == h.size() &&
                    std::fwrite(packed.data(), 1, packed_size, fp) == packed_size;
    const bool closed = std::fclose(fp) == 0;
    if (!ok || !closed) throw Error(path + ": write error (" + std::strerror(errno) + ")");
  }
  file.commit();
}

}  // namespace isoloft
