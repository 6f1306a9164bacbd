#include "isoloft/io/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <mutex>
#include <set>
#include <system_error>

#include "isoloft/core/error.h"

namespace isoloft {

namespace fs = std::filesystem;

namespace {

// /dev/stdout, /dev/fd/3, /proc/self/fd/1: links to what the process has
// open (a terminal, a pipe, the file the shell redirected to). Written in
// place: a temp file and rename would replace the link in /dev (or fail in
// /proc), and renaming onto the link's target would leave the open file unlinked.
bool under_dev_or_proc(const std::string& path) {
  std::error_code ec;
  const std::string a = fs::absolute(path, ec).lexically_normal().string();
  return a.rfind("/dev/", 0) == 0 || a.rfind("/proc/", 0) == 0;
}

}  // namespace

OutputNode output_node(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return OutputNode::Missing;
  if (S_ISREG(st.st_mode)) return under_dev_or_proc(path) ? OutputNode::Stream : OutputNode::Regular;
  if (S_ISDIR(st.st_mode)) return OutputNode::Directory;
  if (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode)) return OutputNode::Stream;
  return OutputNode::Other;
}

std::string node_kind(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return "missing";
  if (S_ISREG(st.st_mode)) return "a regular file";
  if (S_ISDIR(st.st_mode)) return "a directory";
  if (S_ISCHR(st.st_mode)) return "a character device";
  if (S_ISFIFO(st.st_mode)) return "a FIFO";
  if (S_ISBLK(st.st_mode)) return "a block device";
  if (S_ISSOCK(st.st_mode)) return "a socket";
  return "not a regular file";
}

void write_file_bytes(const std::string& file, const std::string& path, const void* data, std::size_t size) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw InputError(path, std::string("cannot create file (") + std::strerror(errno) + ")");
  const char* p = static_cast<const char*>(data);
  for (std::size_t left = size; left > 0;) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : ENOSPC;  // 0 bytes written: the device is full
      ::close(fd);
      throw InputError(path, std::string("cannot write file (") + std::strerror(err) + ")");
    }
    p += n, left -= std::size_t(n);
  }
  if (::close(fd) != 0) throw InputError(path, std::string("cannot write file (") + std::strerror(errno) + ")");
}

namespace {

// A block device or socket cannot take a file output; the rename would replace the node.
void refuse_other_node(const std::string& path) {
  if (output_node(path) == OutputNode::Other)
    throw Error(path + ": is " + node_kind(path) + ", not a regular file; give a file path");
}

}  // namespace

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
std::string extension_of(const fs::path& p) {
  std::string ext = p.extension().string();
  if (ext == ".gz" || ext == ".bz2") ext = p.stem().extension().string() + ext;
  return ext;
}

// The <name> part: the file name, or, where the hidden name would pass the
// 255-byte limit of a file name (NAME_MAX), its start plus a hash of the
// whole name. Deterministic, so the sweep of stale temps finds it again.
std::string hidden_stem(const fs::path& p) {
  constexpr std::size_t kNameMax = 255;
  // ".", then ".<tag:3><pid:10>-<counter:20>" and the extension.
  constexpr std::size_t kSuffix = 1 + 1 + 3 + 10 + 1 + 20;
  const std::string name = p.filename().string(), ext = extension_of(p);
  const std::size_t room = kNameMax > kSuffix + ext.size() + 16 ? kNameMax - kSuffix - ext.size() : 16;
  if (name.size() <= room) return name;
  char hash[17];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(std::hash<std::string>{}(name)));
  return name.substr(0, room - 17) + "~" + hash;
}

std::string hidden_sibling(const std::string& path, const char* tag) {
  static std::atomic<unsigned long> counter{0};
  const fs::path p(path);
  const std::string name = "." + hidden_stem(p) + "." + tag + std::to_string(::getpid()) + "-" +
                           std::to_string(counter.fetch_add(1)) + extension_of(p);
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
    const std::string name = hidden_stem(p);
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
  refuse_other_node(final_);
  if (output_node(final_) == OutputNode::Stream) {
    temp_ = final_;
    in_place_ = true;
    return;
  }
  ensure_parent_dir(final_);
  temp_ = hidden_sibling(final_, "tmp");
  slot_ = register_temp(temp_);
}

AtomicFile::~AtomicFile() {
  if (!committed_ && !in_place_) {
    std::error_code ec;  // never throw from a destructor
    fs::remove(temp_, ec);
  }
  unregister_temp(slot_);
}

void AtomicFile::commit() {
  if (committed_) throw Error(final_ + ": output already committed");
  if (in_place_) {
    committed_ = true;
    return;
  }
  std::error_code ec;
  if (!fs::exists(temp_, ec)) throw Error(final_ + ": nothing was written (temp file " + temp_ + " missing)");
  fs::rename(temp_, final_, ec);
  if (ec) throw Error(final_ + ": cannot move finished output into place (" + ec.message() + ")");
  committed_ = true;
  unregister_temp(slot_);
}

OutputSet::~OutputSet() { discard(); }

std::string output_key(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  return ec ? fs::absolute(path).lexically_normal().string() : p.string();
}

void OutputSet::create_directories(const std::string& dir) {
  if (dir.empty()) return;
  // The missing ancestors, outermost first: what this run creates.
  std::vector<fs::path> missing;
  std::error_code ec;
  for (fs::path d = fs::path(dir); !d.empty() && !fs::exists(d, ec); d = d.parent_path()) {
    missing.insert(missing.begin(), d);
    if (d == d.parent_path()) break;
  }
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw Error(dir + ": cannot create output directory" + (ec ? " (" + ec.message() + ")" : ""));
  for (const auto& d : missing) created_dirs_.push_back(d.string());
}

std::string OutputSet::stage(const std::string& final_path) {
  if (final_path.empty()) throw Error("output path is empty");
  refuse_other_node(final_path);
  const bool in_place = output_node(final_path) == OutputNode::Stream;
  if (!in_place) create_directories(fs::path(final_path).parent_path().string());
  const std::string key = output_key(final_path);
  for (const auto& f : files_)
    if (f.key == key)
      throw Error(final_path + ": the run writes this file twice" +
                  (f.final_path == final_path ? "" : " (also as " + f.final_path + ")"));
  if (in_place) {
    files_.push_back({final_path, final_path, key, -1, true});
    return final_path;
  }
  {
    // Leftovers of killed runs, once per directory and process.
    static std::mutex m;
    static std::set<std::string> swept;
    const std::lock_guard lock(m);
    if (swept.insert(fs::path(final_path).parent_path().string()).second) remove_stale_temp_files(final_path);
  }
  File f{final_path, hidden_sibling(final_path, "run"), key, -1, false};
  f.slot = register_temp(f.staged);
  files_.push_back(std::move(f));
  return files_.back().staged;
}

void OutputSet::lock(const std::string& output) {
  if (lock_fd_ >= 0) return;
  const fs::path p(output);
  create_directories(p.parent_path().string());
  const std::string path = (p.parent_path() / ("." + hidden_stem(p) + ".lock")).string();
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0) throw Error(path + ": cannot create the lock file of " + output + " (" + std::strerror(errno) + ")");
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      if (err == EWOULDBLOCK) {
        char pid[32] = {};
        const ssize_t n = ::pread(fd, pid, sizeof pid - 1, 0);
        ::close(fd);
        const std::string who = n > 0 ? " (pid " + std::string(pid, std::size_t(n)) + ")" : "";
        throw Error(output + ": another isoloft run" + who + " is writing this output (it holds " + path +
                    "): wait for it to end, or give another output name");
      }
      ::close(fd);
      if (err == ENOLCK || err == EOPNOTSUPP || err == ENOSYS) return;  // no locks here: unlocked, as before
      throw Error(path + ": cannot lock (" + std::strerror(err) + ")");
    }
    // The holder before us may have removed the file after we opened it:
    // ours must still be the file at `path`, or we lock a ghost.
    struct stat mine {}, there {};
    if (::fstat(fd, &mine) != 0 || ::stat(path.c_str(), &there) != 0 || mine.st_ino != there.st_ino ||
        mine.st_dev != there.st_dev) {
      ::close(fd);
      continue;
    }
    const std::string pid = std::to_string(::getpid());
    if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) != ssize_t(pid.size())) {
    }  // the pid is for the message only
    lock_fd_ = fd;
    lock_path_ = path;
    lock_slot_ = register_temp(path);
    return;
  }
  throw Error(path + ": cannot lock (the file keeps changing)");
}

void OutputSet::unlock() noexcept {
  if (lock_fd_ < 0) return;
  ::unlink(lock_path_.c_str());  // while still held: the next run makes a new one
  ::close(lock_fd_);
  lock_fd_ = -1;
  unregister_temp(lock_slot_);
}

void OutputSet::commit() {
  // A final path that is a directory is the rename failure to expect: found
  // before the first rename, so no output appears.
  for (const auto& f : files_) {
    std::error_code ec;
    if (!f.in_place && fs::exists(f.staged, ec) && fs::is_directory(f.final_path, ec))
      throw Error(f.final_path + ": is a directory, cannot write the output there");
  }
  std::vector<std::string> placed;
  for (auto& f : files_) {
    std::error_code ec;
    if (f.in_place || !fs::exists(f.staged, ec)) continue;
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
  created_dirs_.clear();
  unlock();
}

void OutputSet::discard() noexcept {
  for (auto& f : files_) {
    std::error_code ec;
    if (!f.in_place) fs::remove(f.staged, ec);
    unregister_temp(f.slot);
  }
  files_.clear();
  unlock();
  // Deepest first; fs::remove leaves a directory that is not empty.
  for (auto d = created_dirs_.rbegin(); d != created_dirs_.rend(); ++d) {
    std::error_code ec;
    fs::remove(*d, ec);
  }
  created_dirs_.clear();
}

std::string OutputSet::final_names(std::string text) const {
  for (const auto& f : files_) {
    if (f.in_place) continue;
    for (std::size_t at = 0; (at = text.find(f.staged, at)) != std::string::npos; at += f.final_path.size())
      text.replace(at, f.staged.size(), f.final_path);
  }
  return text;
}

std::vector<std::string> OutputSet::staged() const {
  std::vector<std::string> out;
  for (const auto& f : files_)
    if (!f.in_place) out.push_back(f.staged);
  return out;
}

void write_text_atomic(const std::string& path, const std::string& text) {
  AtomicFile f(path);
  write_file_bytes(f.temp_path(), path, text.data(), text.size());
  f.commit();
}

}  // namespace isoloft
