#include "isoloft/core/scratch_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "isoloft/core/error.h"

namespace isoloft {

ScratchFile::ScratchFile(const std::string& dir, std::string what) : dir_(dir.empty() ? "." : dir), what_(std::move(what)) {
  std::string name = dir_ + "/.isoloft-scratch-XXXXXX";
  const int fd = ::mkstemp(name.data());
  if (fd < 0) throw Error(dir_ + ": cannot make a scratch file for " + what_ + " (" + std::strerror(errno) + ")");
  ::unlink(name.c_str());  // unnamed: nothing left behind, whatever ends the run
  fp_ = ::fdopen(fd, "w+b");
  if (!fp_) {
    ::close(fd);
    throw Error(dir_ + ": cannot open a scratch file for " + what_ + " (" + std::strerror(errno) + ")");
  }
}

ScratchFile::~ScratchFile() {
  if (fp_) std::fclose(fp_);
}

void ScratchFile::append(const void* data, std::size_t bytes) {
  if (bytes == 0) return;
  if (::fseeko(fp_, end_, SEEK_SET) != 0 || std::fwrite(data, 1, bytes, fp_) != bytes)
    throw Error(dir_ + ": cannot write the scratch file of " + what_ + " (" + std::strerror(errno) + ")");
  end_ += std::int64_t(bytes);
}

void ScratchFile::read(std::int64_t offset, void* data, std::size_t bytes) const {
  if (bytes == 0) return;
  if (::fseeko(fp_, offset, SEEK_SET) != 0 || std::fread(data, 1, bytes, fp_) != bytes)
    throw Error(dir_ + ": cannot read back the scratch file of " + what_ + " (" + std::strerror(errno) + ")");
}

}  // namespace isoloft
