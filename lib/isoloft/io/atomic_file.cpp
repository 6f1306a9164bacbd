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

namespace {

// A hidden sibling "<dir>/.<name>.<tag><pid>-<n><ext>": pid + process-wide
// counter make it unique among concurrent writers in this and other
// processes; the extension is kept (tools choose the format by it), both
// parts of a compressed one (.nii.gz).
std::string hidden_sibling(const std::string& path, const char* tag) {
  static std::atomic<unsigned long> counter{0};
  const fs::path p(path);
  std::string ext = p.extension().string();
  if (ext == ".gz" || ext == ".bz2") ext = p.stem().extension().string() + ext;
  const std::string name = "." + p.filename().string() + "." + tag + std::to_string(::getpid()) + "-" +
                           std::to_string(counter.fetch_add(1)) + ext;
  return (p.parent_path() / name).string();
}

}  // namespace

AtomicFile::AtomicFile(std::string final_path) : final_(std::move(final_path)) {
  if (final_.empty()) throw Error("output path is empty");
  ensure_parent_dir(final_);
  temp_ = hidden_sibling(final_, "tmp");
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

OutputSet::~OutputSet() { discard(); }

std::string OutputSet::stage(const std::string& final_path) {
  if (final_path.empty()) throw Error("output path is empty");
  for (const auto& [f, s] : files_)
    if (f == final_path) throw Error(final_path + ": the run writes this file twice");
  ensure_parent_dir(final_path);
  files_.emplace_back(final_path, hidden_sibling(final_path, "run"));
  return files_.back().second;
}

void OutputSet::commit() {
  for (const auto& [final_path, staged] : files_) {
    std::error_code ec;
    if (!fs::exists(staged, ec)) continue;
    fs::rename(staged, final_path, ec);
    if (ec) throw Error(final_path + ": cannot move finished output into place (" + ec.message() + ")");
  }
  files_.clear();
}

void OutputSet::discard() noexcept {
  for (const auto& [f, staged] : files_) {
    std::error_code ec;
    fs::remove(staged, ec);
  }
  files_.clear();
}

std::vector<std::string> OutputSet::staged() const {
  std::vector<std::string> out;
  for (const auto& fs_pair : files_) out.push_back(fs_pair.second);
  return out;
}

}  // namespace isoloft
