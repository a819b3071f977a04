#include "fishcam/io/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <random>
#include <set>

#include "file_descriptor.hpp"
#include "fishcam/core/error.hpp"

namespace fishcam {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kTemporaryExtension = ".fishcam-tmp";

[[noreturn]] void fail_io(const fs::path& path, const char* what, int error) {
  throw Error(path_for_message(path) + ": " + what + " (" + std::strerror(error) + ")");
}

// This host's name as one field of a temporary's name (no dots or slashes).
std::string host_field() {
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) != 0 || name[0] == '\0') return "host";
  std::string host(name);
  for (char& c : host) {
    if (c == '.' || c == '/' || static_cast<unsigned char>(c) < 0x21 || static_cast<unsigned char>(c) >= 0x7f) c = '-';
  }
  return host;
}

using detail::FileDescriptor;

// Creates the temporary for path exclusively (O_EXCL: never an existing file, never
// through a symlink), writes bytes, closes it; returns its path. The random part
// makes a collision with another run (or a leftover) a retry, not an overwrite.
fs::path write_temporary(const fs::path& path, const std::string& bytes) {
  static thread_local std::mt19937_64 random{std::random_device{}() ^ (std::uint64_t(getpid()) << 32)};
  fs::path tmp;
  FileDescriptor file;
  for (int attempt = 0; file.fd < 0; ++attempt) {
    tmp = temporary_path(path, getpid(), random());
    file.fd = open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (file.fd < 0 && (errno != EEXIST || attempt == 100)) fail_io(path, "cannot write", errno);
  }
  std::size_t done = 0;
  int error = 0;
  while (done < bytes.size()) {
    const ssize_t n = write(file.fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error = n < 0 ? errno : EIO;
      break;
    }
    done += std::size_t(n);
  }
  const int fd = file.fd;
  file.fd = -1;
  if (close(fd) != 0 && error == 0) error = errno;
  if (error != 0) {
    unlink(tmp.c_str());
    fail_io(path, "write failed", error);
  }
  return tmp;
}

// Moves tmp to path; without overwrite, atomically refuses an existing path
// (renameat2's RENAME_NOREPLACE, or link + unlink where the filesystem lacks it).
// Returns 0 or the errno of the failure.
int commit(const fs::path& tmp, const fs::path& path, bool overwrite) {
  if (overwrite) return std::rename(tmp.c_str(), path.c_str()) == 0 ? 0 : errno;
  if (renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, path.c_str(), RENAME_NOREPLACE) == 0) return 0;
  if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP) return errno;
  if (link(tmp.c_str(), path.c_str()) != 0) return errno;
  unlink(tmp.c_str());
  return 0;
}

void check_absent(const fs::path& path, bool overwrite) {
  struct stat info {};
  if (!overwrite && lstat(path.c_str(), &info) == 0) {
    throw Error(path_for_message(path) + ": already exists (refusing to overwrite)");
  }
}

// The real path of p as far as it exists (symlinks resolved), lexically completed.
fs::path resolved(const fs::path& p) {
  std::error_code ec;
  fs::path r = fs::weakly_canonical(fs::absolute(p, ec), ec);
  return ec ? fs::absolute(p).lexically_normal() : r;
}

// Whether inner lies inside (or is) outer, comparing resolved paths, then the
// folders above inner one by one against outer as files (bind mounts, hard-linked
// folders cannot exist, but the same folder under two names through a mount can).
bool lies_inside(const fs::path& inner, const fs::path& outer) {
  std::error_code ec;
  if (!fs::is_directory(outer, ec)) return is_same_file(inner, outer);
  const fs::path r_outer = resolved(outer);
  for (fs::path p = resolved(inner);; p = p.parent_path()) {
    if (p == r_outer || is_same_file(p, r_outer)) return true;
    if (p == p.parent_path()) return false;
  }
}

}  // namespace

bool is_same_file(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (resolved(a) == resolved(b)) return true;
  const bool same = fs::equivalent(a, b, ec);
  return !ec && same;
}

void write_file_atomically(const fs::path& path, const std::string& bytes, bool overwrite) {
  write_files_atomically({{path, bytes}}, overwrite);
}

void write_files_atomically(const std::vector<std::pair<fs::path, std::string>>& files, bool overwrite) {
  std::set<fs::path> seen;
  for (const auto& [path, bytes] : files) {
    check_absent(path, overwrite);
    if (!seen.insert(resolved(path)).second) throw Error(path_for_message(path) + ": given as more than one output");
  }
  std::vector<fs::path> temporaries;
  const auto remove_temporaries = [&temporaries](std::size_t from) {
    for (std::size_t k = from; k < temporaries.size(); ++k) unlink(temporaries[k].c_str());
  };
  for (const auto& [path, bytes] : files) {
    try {
      temporaries.push_back(write_temporary(path, bytes));
    } catch (const Error&) {
      remove_temporaries(0);
      throw;
    }
  }
  for (std::size_t i = 0; i < files.size(); ++i) {
    const int error = commit(temporaries[i], files[i].first, overwrite);
    if (error != 0) {
      remove_temporaries(i);
      if (error == EEXIST) throw Error(path_for_message(files[i].first) + ": already exists (refusing to overwrite)");
      fail_io(files[i].first, "cannot move the written file into place", error);
    }
  }
}

fs::path temporary_path(const fs::path& path, long process_id, std::uint64_t token) {
  char random_part[17];
  std::snprintf(random_part, sizeof random_part, "%016llx", static_cast<unsigned long long>(token));
  return path.native() + "." + host_field() + "." + std::to_string(process_id) + "." + random_part +
         std::string(kTemporaryExtension);
}

bool is_temporary_name(const std::string& name) { return name.ends_with(kTemporaryExtension); }

std::size_t remove_stale_temporaries(const fs::path& folder) {
  const std::string host = host_field();
  std::size_t removed = 0;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().native();
    if (!is_temporary_name(name)) continue;
    // NAME.HOST.PID.RANDOM.fishcam-tmp, read from the right.
    const std::string fields = name.substr(0, name.size() - kTemporaryExtension.size());
    const size_t random_at = fields.rfind('.');
    const size_t pid_at =
        random_at == std::string::npos || random_at == 0 ? std::string::npos : fields.rfind('.', random_at - 1);
    const size_t host_at =
        pid_at == std::string::npos || pid_at == 0 ? std::string::npos : fields.rfind('.', pid_at - 1);
    if (host_at == std::string::npos || fields.substr(host_at + 1, pid_at - host_at - 1) != host) continue;
    const std::string pid_text = fields.substr(pid_at + 1, random_at - pid_at - 1);
    if (pid_text.empty() || pid_text.size() > 9 ||
        !std::all_of(pid_text.begin(), pid_text.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      continue;
    }
    // The random part exactly as temporary_path writes it: 16 lowercase hex digits.
    const std::string random_text = fields.substr(random_at + 1);
    if (random_text.size() != 16 || !std::all_of(random_text.begin(), random_text.end(), [](char c) {
          return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
        })) {
      continue;
    }
    const pid_t pid = pid_t(std::stol(pid_text));
    if (pid == getpid() || pid <= 0 || kill(pid, 0) == 0 || errno != ESRCH) continue;  // running (or not ours to judge)
    if (unlink(it->path().c_str()) == 0) ++removed;
  }
  return removed;
}

void check_output_not_input(const fs::path& output, const std::vector<fs::path>& inputs, bool output_is_folder) {
  for (const fs::path& input : inputs) {
    if (input.empty()) continue;
    const char* problem = nullptr;
    if (is_same_file(output, input)) {
      problem = "is also an input";
    } else if (lies_inside(output, input)) {
      problem = "lies inside the input";
    } else if (output_is_folder && lies_inside(input, output)) {
      problem = "contains the input";
    }
    if (problem) {
      throw Error(path_for_message(output) + ": " + problem + " " + path_for_message(input) +
                  " (inputs are never written)");
    }
  }
}

}  // namespace fishcam
