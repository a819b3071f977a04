// Standard error taken from third-party code for a scope: libraries that print their
// own diagnostics (libmrcal; OpenCV's image decoders) write into one temporary file
// instead of the terminal. File descriptor 2 is the process's, so there is one
// redirection, counted: the first scope to enter points fd 2 at the file, the last to
// leave points it back, whatever the order in which scopes on different threads end
// (two independent redirections could leave fd 2 on the other's file).
#pragma once

#include <sys/types.h>

#include <cstdio>
#include <mutex>
#include <string>

namespace fishcam::detail {

// The shared redirection (stderr_capture.cpp): enter returns the file's size at entry
// (-1 if standard error could not be redirected), leave undoes one enter.
off_t enter_stderr_redirect();
void leave_stderr_redirect();
// What was written to the redirection from `from` on (at most max_bytes of it).
std::string stderr_written_since(off_t from, std::size_t max_bytes);

// Standard error discarded for the scope (a decoder's complaints about a corrupt file,
// reported in our own one-line message instead).
class SilencedStderr {
 public:
  SilencedStderr() { enter_stderr_redirect(); }
  ~SilencedStderr() { leave_stderr_redirect(); }
  SilencedStderr(const SilencedStderr&) = delete;
  SilencedStderr& operator=(const SilencedStderr&) = delete;
};

// Standard error captured for the scope, and what was said summarised in one line for
// the caller's message. Captures are serialised among themselves (one library's
// complaint is never taken for another capture's); other threads' output during the
// scope is captured too.
class StderrCapture {
 public:
  StderrCapture() : lock_(mutex()), start_(enter_stderr_redirect()) {}
  ~StderrCapture() { release(); }
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;

  // "FIRST LINE (N lines)" of what was written, at most kShown characters of its
  // first line; "" when nothing was. Standard error is back from here on.
  std::string summary() {
    const std::string said = start_ >= 0 ? stderr_written_since(start_, kRead) : std::string();
    release();
    if (said.empty()) return "";
    std::string first;
    long lines = 0;
    for (char c : said) {
      if (c == '\n') {
        ++lines;
      } else if (lines == 0 && first.size() < kShown) {
        first.push_back(c);
      }
    }
    // Past kRead bytes the count is a lower bound.
    return first + " (" + std::to_string(lines) + (said.size() == kRead ? "+" : "") + " line" +
           (lines == 1 ? "" : "s") + ")";
  }

 private:
  static constexpr std::size_t kShown = 160;
  static constexpr std::size_t kRead = std::size_t(1) << 20;
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  void release() {
    if (released_) return;
    released_ = true;
    leave_stderr_redirect();
  }
  std::lock_guard<std::mutex> lock_;
  off_t start_;
  bool released_ = false;
};

}  // namespace fishcam::detail
