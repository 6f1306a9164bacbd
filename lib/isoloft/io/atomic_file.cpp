#include "isoloft/io/atomic_file.h"

#include <signal.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
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

// The temp and staged paths a signal handler unlinks: malloc'ed copies in
// lock-free slots, so the handler only loads pointers and calls unlink().
// A run beyond kSlots files at once leaves the excess unregistered (only a
// signal could then leave them behind).
constexpr std::size_t kSlots = 1 << 16;
std::array<std::atomic<char*>, kSlots> g_slots{};
std::atomic<std::size_t> g_hint{0};

int register_temp(const std::string& path) {
  char* copy = ::strdup(path.c_str());
  if (!copy) return -1;
  const std::size_t start = g_hint.load(std::memory_order_relaxed);
  for (std::size_t n = 0; n < kSlots; ++n) {
    const std::size_t i = (start + n) % kSlots;
    char* expected = nullptr;
    if (g_slots[i].compare_exchange_strong(expected, copy, std::memory_order_acq_rel)) {
      g_hint.store(i + 1, std::memory_order_relaxed);
      return int(i);
    }
  }
  std::free(copy);
  return -1;
}

void unregister_temp(int& slot) noexcept {
  if (slot < 0) return;
  std::free(g_slots[std::size_t(slot)].exchange(nullptr, std::memory_order_acq_rel));
  slot = -1;
}

extern "C" void unlink_temps_and_reraise(int sig) {
  for (auto& s : g_slots)
    if (char* p = s.load(std::memory_order_acquire)) ::unlink(p);
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

// "<tag><pid>-<n>..." after "<name>.": the pid of a writer, or 0.
long writer_pid(const std::string& rest) {
  for (const char* tag : {"tmp", "run"}) {
    const std::size_t t = std::strlen(tag);
    if (rest.compare(0, t, tag) != 0) continue;
    std::size_t i = t;
    long pid = 0;
    while (i < rest.size() && i < t + 10 && rest[i] >= '0' && rest[i] <= '9') pid = pid * 10 + (rest[i++] - '0');
    if (i > t && i < rest.size() && rest[i] == '-') return pid;
  }
  return 0;
}

}  // namespace

void remove_temp_files_on_signals() {
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;  // e.g. nohup: keep ignoring
    struct sigaction sa {};
    sa.sa_handler = unlink_temps_and_reraise;
    sigemptyset(&sa.sa_mask);
    ::sigaction(sig, &sa, nullptr);
  }
}

std::size_t remove_stale_temp_files(const std::string& final_path) noexcept {
  std::size_t removed = 0;
  try {
    const fs::path p(final_path);
    const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
    const std::string name = p.filename().string();
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      std::string f = e.path().filename().string();
      // ".<name>.<tag><pid>-<n><ext>", or a temp of a staged file: one more '.'.
      std::size_t skip = f.rfind("..", 0) == 0 ? 2 : f.rfind('.', 0) == 0 ? 1 : 0;
      if (skip == 0 || f.compare(skip, name.size() + 1, name + ".") != 0) continue;
      const long pid = writer_pid(f.substr(skip + name.size() + 1));
      if (pid <= 0 || pid == ::getpid() || ::kill(pid_t(pid), 0) == 0 || errno != ESRCH) continue;
      std::error_code rm;
      if (fs::remove(e.path(), rm)) ++removed;
    }
  } catch (...) {  // best effort: a listing problem must not fail the run
  }
  return removed;
}

AtomicFile::AtomicFile(std::string final_path) : final_(std::move(final_path)) {
  if (final_.empty()) throw Error("output path is empty");
  ensure_parent_dir(final_);
  temp_ = hidden_sibling(final_, "tmp");
  slot_ = register_temp(temp_);
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;  // never throw from a destructor
    fs::remove(temp_, ec);
  }
  unregister_temp(slot_);
}

void AtomicFile::commit() {
  if (committed_) throw Error(final_ + ": output already committed");
  std::error_code ec;
  if (!fs::exists(temp_, ec)) throw Error(final_ + ": nothing was written (temp file " + temp_ + " missing)");
  fs::rename(temp_, final_, ec);
  if (ec) throw Error(final_ + ": cannot move finished output into place (" + ec.message() + ")");
  committed_ = true;
  unregister_temp(slot_);
}

OutputSet::~OutputSet() { discard(); }

std::string OutputSet::stage(const std::string& final_path) {
  if (final_path.empty()) throw Error("output path is empty");
  for (const auto& f : files_)
    if (f.final_path == final_path) throw Error(final_path + ": the run writes this file twice");
  ensure_parent_dir(final_path);
  {
    // Leftovers of killed runs, once per directory and process.
    static std::mutex m;
    static std::set<std::string> swept;
    const std::lock_guard lock(m);
    if (swept.insert(fs::path(final_path).parent_path().string()).second) remove_stale_temp_files(final_path);
  }
  File f{final_path, hidden_sibling(final_path, "run"), -1};
  f.slot = register_temp(f.staged);
  files_.push_back(std::move(f));
  return files_.back().staged;
}

void OutputSet::commit() {
  // A final path that is a directory is the rename failure to expect: found
  // before the first rename, so no output appears.
  for (const auto& f : files_) {
    std::error_code ec;
    if (fs::exists(f.staged, ec) && fs::is_directory(f.final_path, ec))
      throw Error(f.final_path + ": is a directory, cannot write the output there");
  }
  std::vector<std::string> placed;
  for (auto& f : files_) {
    std::error_code ec;
    if (!fs::exists(f.staged, ec)) continue;
    fs::rename(f.staged, f.final_path, ec);
    if (ec) {
      // Any other failure: take back the outputs already placed (their
      // previous versions are gone), so none of the run's outputs remain.
      const std::string why = ec.message();
      for (const auto& q : placed) fs::remove(q, ec);
      throw Error(f.final_path + ": cannot move finished output into place (" + why + ")");
    }
    placed.push_back(f.final_path);
    unregister_temp(f.slot);
  }
  files_.clear();
}

void OutputSet::discard() noexcept {
  for (auto& f : files_) {
    std::error_code ec;
    fs::remove(f.staged, ec);
    unregister_temp(f.slot);
  }
  files_.clear();
}

std::vector<std::string> OutputSet::staged() const {
  std::vector<std::string> out;
  for (const auto& f : files_) out.push_back(f.staged);
  return out;
}

void write_text_atomic(const std::string& path, const std::string& text) {
  AtomicFile f(path);
  {
    std::ofstream out(f.temp_path(), std::ios::binary);
    out << text;
    if (!out) throw InputError(path, "cannot write file");
  }
  f.commit();
}

}  // namespace isoloft
