// Helpers shared by tests/generator/cli_test.cpp and golden_test.cpp: run the
// real jrgen binary (fork/exec, stdout and stderr captured to files), scratch
// folders, and snapshots of a folder's contents.
#pragma once

#include <fcntl.h>
#include <sched.h>
#include <stdlib.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#ifndef JRGEN_EXECUTABLE
#error "JRGEN_EXECUTABLE must be defined (path of the jrgen binary)"
#endif
#ifndef JRGEN_SOURCE_DIR
#error "JRGEN_SOURCE_DIR must be defined (absolute path of the repository root)"
#endif

namespace jrgen::cli_testing {

namespace fs = std::filesystem;

inline const fs::path kJrgen = JRGEN_EXECUTABLE;
inline const fs::path kSourceDir = JRGEN_SOURCE_DIR;
inline const fs::path kModelsDir = kSourceDir / "models";
inline const fs::path kErrorsDir = kSourceDir / "tests" / "errors";
inline const fs::path kCliDir = kSourceDir / "tests" / "cli";
inline const fs::path kGoldenDir = kSourceDir / "tests" / "golden";
inline const fs::path kExternalModelsDir = kSourceDir / ".." / "shared" / "models-external";

inline std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_file(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

/// A fresh folder under the test temp dir, removed (with its contents) on
/// destruction.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& tag = "jrgen") {
    std::string pattern = (fs::path(::testing::TempDir()) / (tag + "_XXXXXX")).string();
    std::vector<char> buf(pattern.begin(), pattern.end());
    buf.push_back('\0');
    if (!::mkdtemp(buf.data())) throw std::runtime_error("mkdtemp failed: " + pattern);
    path_ = buf.data();
  }
  ~ScratchDir() {
    std::error_code ec;
    // A test may have made a folder read-only; give write access back first.
    for (auto it = fs::recursive_directory_iterator(path_, ec); !ec && it != fs::end(it);
         it.increment(ec))
      if (it->is_directory(ec)) fs::permissions(it->path(), fs::perms::owner_all, fs::perm_options::add, ec);
    fs::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

struct RunResult {
  int status = -1;     // exit status; 128 + signal number when killed by a signal
  bool exited = false; // true when the process called exit()
  std::string out;     // everything written to stdout
  std::string err;     // everything written to stderr
  std::string command; // for failure messages
};

/// Runs jrgen with `args` in folder `cwd`; stdout and stderr go to files in a
/// private scratch folder (never in `cwd`), so they cannot disturb snapshots.
/// With `read_only` set, jrgen runs in a mount namespace of its own where that
/// folder is a read-only bind mount of itself (needs root: CAP_SYS_ADMIN), so
/// that writes there fail for root too; the child exits 125, saying why on
/// stderr, when it cannot set that up.
inline RunResult run_jrgen(const std::vector<std::string>& args, const fs::path& cwd,
                           const fs::path& read_only = {}) {
  const std::string ro = read_only.string();
  ScratchDir capture("jrgen_capture");
  const std::string out_file = (capture / "stdout").string();
  const std::string err_file = (capture / "stderr").string();
  RunResult result;
  result.command = "cd " + cwd.string() + " && " + kJrgen.string();
  for (const std::string& a : args) result.command += " '" + a + "'";

  std::vector<std::string> storage;
  storage.push_back(kJrgen.string());
  storage.insert(storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& s : storage) argv.push_back(s.data());
  argv.push_back(nullptr);

  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  if (pid == 0) {
    // Child: only async-signal-safe calls from here on.
    if (::chdir(cwd.c_str()) != 0) ::_exit(126);
    const int fo = ::open(out_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int fe = ::open(err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int fi = ::open("/dev/null", O_RDONLY);
    if (fo < 0 || fe < 0 || fi < 0) ::_exit(126);
    ::dup2(fi, 0);
    ::dup2(fo, 1);
    ::dup2(fe, 2);
    if (!ro.empty() &&
        (::unshare(CLONE_NEWNS) != 0 || ::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
         ::mount(ro.c_str(), ro.c_str(), nullptr, MS_BIND, nullptr) != 0 ||
         ::mount(nullptr, ro.c_str(), nullptr, MS_REMOUNT | MS_BIND | MS_RDONLY, nullptr) != 0)) {
      static const char kWhy[] = "run_jrgen: cannot make a read-only bind mount in a private mount namespace\n";
      if (::write(2, kWhy, sizeof kWhy - 1) < 0) ::_exit(125);
      ::_exit(125);
    }
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  int wstatus = 0;
  while (::waitpid(pid, &wstatus, 0) < 0)
    if (errno != EINTR) throw std::runtime_error(std::string("waitpid failed: ") + std::strerror(errno));
  if (WIFEXITED(wstatus)) {
    result.exited = true;
    result.status = WEXITSTATUS(wstatus);
  } else if (WIFSIGNALED(wstatus)) {
    result.status = 128 + WTERMSIG(wstatus);
  }
  result.out = slurp(out_file);
  result.err = slurp(err_file);
  return result;
}

/// Every entry below `root`: relative path -> contents ("<dir>" for folders,
/// "<other>" for anything that is neither a file nor a folder).
using Snapshot = std::map<std::string, std::string>;

inline Snapshot snapshot(const fs::path& root) {
  Snapshot s;
  if (!fs::exists(root)) return s;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::end(it); ++it) {
    const std::string rel = fs::relative(it->path(), root).string();
    if (it->is_directory()) s[rel] = "<dir>";
    else if (it->is_regular_file()) s[rel] = slurp(it->path());
    else s[rel] = "<other>";
  }
  return s;
}

/// Human-readable difference of two snapshots (empty when equal).
inline std::string snapshot_diff(const Snapshot& before, const Snapshot& after) {
  std::string d;
  for (const auto& [name, text] : after) {
    const auto it = before.find(name);
    if (it == before.end()) d += "  created:  " + name + "\n";
    else if (it->second != text) d += "  modified: " + name + "\n";
  }
  for (const auto& [name, text] : before)
    if (!after.count(name)) d += "  removed:  " + name + "\n";
  return d;
}

inline std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) {
      lines.push_back(text.substr(pos));
      break;
    }
    lines.push_back(text.substr(pos, end - pos));
    pos = end + 1;
  }
  return lines;
}

/// "" when equal, else the first differing line of `actual` against `expected`.
inline std::string first_difference(const std::string& expected, const std::string& actual) {
  if (expected == actual) return "";
  const std::vector<std::string> e = split_lines(expected), a = split_lines(actual);
  const std::size_t n = std::max(e.size(), a.size());
  for (std::size_t i = 0; i < n; ++i) {
    const std::string* el = i < e.size() ? &e[i] : nullptr;
    const std::string* al = i < a.size() ? &a[i] : nullptr;
    if (el && al && *el == *al) continue;
    std::ostringstream s;
    s << "first difference at line " << i + 1 << ":\n  expected: "
      << (el ? *el : std::string("<end of file>")) << "\n  actual:   "
      << (al ? *al : std::string("<end of file>"));
    return s.str();
  }
  return "the files differ only in their final newline";
}

}  // namespace jrgen::cli_testing
