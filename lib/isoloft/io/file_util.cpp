#include "isoloft/io/file_util.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <fstream>
#include <limits>

#include "isoloft/core/error.h"

namespace isoloft::detail {

void advise_huge_pages(void* p, std::size_t bytes) {
  constexpr std::size_t kHuge = std::size_t(2) << 20;
  if (bytes < 4 * kHuge) return;
  const std::uintptr_t b = (reinterpret_cast<std::uintptr_t>(p) + kHuge - 1) / kHuge * kHuge;
  const std::uintptr_t e = (reinterpret_cast<std::uintptr_t>(p) + bytes) / kHuge * kHuge;
#ifdef MADV_HUGEPAGE
  if (e > b) madvise(reinterpret_cast<void*>(b), e - b, MADV_HUGEPAGE);  // a hint: failure is harmless
#endif
}

std::vector<unsigned char> read_file_bytes(const std::string& path, std::uint64_t offset) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open file");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(path, "cannot read file");
  if (std::uint64_t(size) < offset) throw InputError(path, "file is shorter than its header");
  std::vector<unsigned char> bytes;
  resize_large(bytes, std::size_t(std::uint64_t(size) - offset));
  in.seekg(std::streamoff(offset));
  if (!bytes.empty() && !in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size())))
    throw InputError(path, "read error");
  return bytes;
}

FileBytes::FileBytes(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  struct stat st {};
  if (fd >= 0 && ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0) {
    void* p = ::mmap(nullptr, std::size_t(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
    if (p != MAP_FAILED) map_ = p, size_ = std::size_t(st.st_size);
  }
  if (fd >= 0) ::close(fd);
  if (map_) return;
  copy_ = read_file_bytes(path);  // its errors, for files that cannot be mapped (or are empty)
  size_ = copy_.size();
}

FileBytes::~FileBytes() {
  if (map_) ::munmap(map_, size_);
}

std::vector<unsigned char> inflate_exact(const unsigned char* src, std::size_t n, std::size_t expected,
                                         const std::string& file) {
  // Deflate cannot compress better than 1032:1, so a header declaring more
  // than that is corrupt; checking first avoids a huge allocation.
  if (double(expected) > 1032.0 * double(n) + 1024.0)
    throw InputError(
        file, std::to_string(n) + " compressed bytes cannot hold the declared " + std::to_string(expected) + " bytes");
  std::vector<unsigned char> out(expected);
  z_stream zs{};
  // 15 + 32: maximum window, accept both zlib and gzip headers.
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw InputError(file, "zlib initialisation failed");
  // zlib counts in 32-bit uInt, so large buffers are fed in chunks.
  constexpr std::size_t chunk = std::size_t(1) << 30;
  const unsigned char* const in_end = src + n;
  unsigned char* const out_end = out.data() + expected;
  unsigned char overflow = 0;  // one spare byte: detects data beyond `expected`
  bool overflowing = false;
  std::size_t out_done = 0;
  zs.next_in = const_cast<unsigned char*>(src);
  zs.next_out = out.data();
  std::string problem;
  for (;;) {
    if (zs.avail_in == 0) zs.avail_in = uInt(std::min<std::size_t>(chunk, std::size_t(in_end - zs.next_in)));
    if (zs.avail_out == 0) {
      if (overflowing) {
        problem = "compressed data holds more than the expected " + std::to_string(expected) + " bytes";
        break;
      }
      out_done = std::size_t(zs.next_out - out.data());
      if (zs.next_out == out_end) {
        zs.next_out = &overflow;
        zs.avail_out = 1;
        overflowing = true;
      } else {
        zs.avail_out = uInt(std::min<std::size_t>(chunk, std::size_t(out_end - zs.next_out)));
      }
    }
    const int rc = inflate(&zs, Z_NO_FLUSH);
    if (!overflowing) out_done = std::size_t(zs.next_out - out.data());
    if (rc == Z_STREAM_END) {
      if (overflowing && zs.avail_out == 0)
        problem = "compressed data holds more than the expected " + std::to_string(expected) + " bytes";
      break;
    }
    if (rc == Z_OK) continue;
    if (rc == Z_BUF_ERROR && !(zs.avail_in == 0 && zs.next_in == in_end)) continue;  // refill and retry
    if (rc == Z_BUF_ERROR) {
      problem =
          "compressed data is truncated (" + std::to_string(out_done) + " of " + std::to_string(expected) + " bytes)";
    } else {
      problem = std::string("corrupt compressed data (zlib: ") + (zs.msg ? zs.msg : "error") + ")";
    }
    break;
  }
  inflateEnd(&zs);
  if (!problem.empty()) throw InputError(file, problem);
  if (out_done != expected)
    throw InputError(
        file, "compressed data holds " + std::to_string(out_done) + " bytes, expected " + std::to_string(expected));
  return out;
}

std::size_t checked_voxel_count(int nx, int ny, int nz, const std::string& file) {
  if (nx < 1 || ny < 1 || nz < 1)
    throw InputError(file, "invalid sizes " + std::to_string(nx) + "x" + std::to_string(ny) + "x" + std::to_string(nz));
  const std::uint64_t n = std::uint64_t(nx) * std::uint64_t(ny) * std::uint64_t(nz);
  constexpr std::uint64_t max_voxels = std::uint64_t(1) << 34;  // 64 GiB of floats: surely a corrupt header
  if (n >= max_voxels) throw InputError(file, "volume too large (" + std::to_string(n) + " voxels)");
  return std::size_t(n);
}

}  // namespace isoloft::detail
