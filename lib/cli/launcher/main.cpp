// isoloft: starts isoloft-cli (the command-line tool, beside this file) with
// the heap's glibc tunables set (cli/heap_tunables.h), so that it starts
// once: started without them it runs itself again, and each start loads its
// ~20 shared libraries (DCMTK, teem, TBB, ...), ~20 ms on the 2-core VMs
// measured (docs/decisions.md: the CLI's heap). Links libc alone.
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <string>

#include "cli/heap_tunables.h"

int main(int, char** argv) {
  char self[PATH_MAX];
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof self - 1);
  std::string dir = n > 0 ? std::string(self, std::size_t(n)) : std::string(argv[0]);
  const std::size_t slash = dir.rfind('/');
  dir = slash == std::string::npos ? "." : dir.substr(0, slash);
  const std::string cli = dir + "/" + isoloft::cli::kCliName;
  const bool set = isoloft::cli::set_heap_tunables();
  ::execv(cli.c_str(), argv);
  const int err = errno;
  if (set) isoloft::cli::unset_heap_tunables();
  std::fprintf(stderr, "isoloft: error: cannot run %s (%s)\n", cli.c_str(), std::strerror(err));
  return 1;
}
