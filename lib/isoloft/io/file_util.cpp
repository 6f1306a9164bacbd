#include "isoloft/io/file_util.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <limits>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"

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

namespace {

// What a non-regular file is, for the error.
std::string file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "is a directory, not a file";
  if (S_ISFIFO(mode)) return "is a FIFO (named pipe), not a regular file: reading it could wait for ever";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "is a device, not a regular file";
  if (S_ISSOCK(mode)) return "is a socket, not a regular file";
  return "is not a regular file";
}

}  // namespace

void check_regular_file(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    struct stat link {};
    if (err == ENOENT && ::lstat(path.c_str(), &link) == 0 && S_ISLNK(link.st_mode))
      throw InputError(path, "broken symbolic link (its target does not exist)");
    throw InputError(path, std::string("cannot open file (") + std::strerror(err) + ")");
  }
  if (!S_ISREG(st.st_mode)) throw InputError(path, file_kind(st.st_mode));
}

int open_regular_file(const std::string& path) {
  check_regular_file(path);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw InputError(path, std::string("cannot open file (") + std::strerror(errno) + ")");
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw InputError(path, file_kind(st.st_mode));
  }
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  return fd;
}

std::vector<unsigned char> read_file_bytes(const std::string& path, std::uint64_t offset) {
  const int fd = open_regular_file(path);
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw InputError(path, "cannot read file");
  const auto size = std::uint64_t(st.st_size);
  if (size < offset) throw InputError(path, "file is shorter than its header");
  std::vector<unsigned char> bytes;
  resize_large(bytes, std::size_t(size - offset));
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t got = ::pread(fd, bytes.data() + done, bytes.size() - done, off_t(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw InputError(path, std::string("read error (") + std::strerror(errno) + ")");
    if (got == 0) throw InputError(path, "read error (the file shrank while it was read)");
    done += std::size_t(got);
  }
  return bytes;
}

void check_data_file(const std::string& header, const std::string& name, const std::string& resolved,
                     bool allow_external) {
  namespace fs = std::filesystem;
  if (!allow_external) {
    const fs::path folder = fs::path(header).parent_path();
    std::error_code ec;
    const fs::path root = fs::weakly_canonical(folder.empty() ? fs::path(".") : folder, ec);
    const fs::path real = ec ? fs::path() : fs::weakly_canonical(resolved, ec);
    const bool inside = !ec && std::mismatch(root.begin(), root.end(), real.begin(), real.end()).first == root.end();
    if (!inside)
      throw InputError(header, "data file '" + name + "' (" + (ec ? resolved : real.string()) +
                                   ") lies outside the header's folder: only files in its folder or below are read "
                                   "unless " + option_given("--allow-external-data") + " is given");
  }
  try {
    check_regular_file(resolved);
  } catch (const InputError& e) {
    throw InputError(header, "data file '" + name + "' (" + resolved + "): " + e.problem);
  }
}

FileBytes::FileBytes(const std::string& path) {
  const int fd = open_regular_file(path);
  struct stat st {};
  if (::fstat(fd, &st) == 0 && st.st_size > 0) {
    void* p = ::mmap(nullptr, std::size_t(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
    if (p != MAP_FAILED) map_ = p, size_ = std::size_t(st.st_size);
  }
  ::close(fd);
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
