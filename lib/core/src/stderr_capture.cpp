#include "fishcam/core/stderr_capture.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>

namespace fishcam::detail {
namespace {

struct Redirect {
  std::mutex mutex;
  int depth = 0;
  int saved = -1;  // the original fd 2 while redirected
  int file = -1;   // the temporary file fd 2 points at
};

Redirect& redirect() {
  static Redirect r;
  return r;
}

}  // namespace

off_t enter_stderr_redirect() {
  Redirect& r = redirect();
  const std::lock_guard<std::mutex> lock(r.mutex);
  if (r.depth++ == 0) {
    std::fflush(stderr);
    std::FILE* tmp = std::tmpfile();
    if (tmp) {
      r.file = dup(fileno(tmp));  // the descriptor outlives the FILE (closed below; the file is unlinked)
      std::fclose(tmp);
    }
    if (r.file >= 0) r.saved = dup(STDERR_FILENO);
    if (r.saved >= 0 && dup2(r.file, STDERR_FILENO) < 0) close(r.saved), r.saved = -1;
  }
  if (r.saved < 0) return -1;
  struct stat st;
  return fstat(r.file, &st) == 0 ? st.st_size : -1;
}

void leave_stderr_redirect() {
  Redirect& r = redirect();
  const std::lock_guard<std::mutex> lock(r.mutex);
  if (--r.depth > 0) return;
  std::fflush(stderr);
  if (r.saved >= 0) {
    dup2(r.saved, STDERR_FILENO);
    close(r.saved);
    r.saved = -1;
  }
  if (r.file >= 0) close(r.file);
  r.file = -1;
}

std::string stderr_written_since(off_t from, std::size_t max_bytes) {
  Redirect& r = redirect();
  const std::lock_guard<std::mutex> lock(r.mutex);
  std::fflush(stderr);
  std::string text;
  if (r.file < 0 || from < 0) return text;
  char buffer[65536];
  for (off_t at = from; text.size() < max_bytes;) {
    const ssize_t got = pread(r.file, buffer, std::min(sizeof buffer, max_bytes - text.size()), at);
    if (got <= 0) break;
    text.append(buffer, std::size_t(got));
    at += got;
  }
  return text;
}

}  // namespace fishcam::detail
