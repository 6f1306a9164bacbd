#include "isoloft/io/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <system_error>

#include "isoloft/core/error.h"

namespace isoloft {

namespace fs = std::filesystem;

void ensure_parent_dir(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent))
    throw Error(parent.string() + ": cannot create output directory" + (ec ? " (" + ec.message() + ")" : ""));
}

AtomicFile::AtomicFile(std::string final_path) : final_(std::move(final_path)) {
  if (final_.empty()) throw Error("output path is empty");
  ensure_parent_dir(final_);
  // pid + process-wide counter: unique among concurrent writers in this and
  // other processes writing to the same directory.
  static std::atomic<unsigned long> counter{0};
  const fs::path p(final_);
  const std::string name = p.filename().string();
  const std::string tmp_name = "." + name + ".tmp" + std::to_string(::getpid()) + "-" +
                               std::to_string(counter.fetch_add(1)) + p.extension().string();
  temp_ = (p.parent_path() / tmp_name).string();
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;  // never throw from a destructor
    fs::remove(temp_, ec);
  }
}

void AtomicFile::commit() {
  if (committed_) throw Error(final_ + ": output already committed");
  std::error_code ec;
  if (!fs::exists(temp_, ec)) throw Error(final_ + ": nothing was written (temp file " + temp_ + " missing)");
  fs::rename(temp_, final_, ec);
  if (ec) throw Error(final_ + ": cannot move finished output into place (" + ec.message() + ")");
  committed_ = true;
}

}  // namespace isoloft
