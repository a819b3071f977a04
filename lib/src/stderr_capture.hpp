// Standard error taken from third-party code for a scope: a library that prints its
// own diagnostics (libmrcal) writes into a temporary file instead of the terminal,
// and the caller summarises what it said in its own one-line message. File
// descriptor 2 is process-wide: captures are serialised (one at a time), and meant
// for scopes that call such a library, not for long runs.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <mutex>
#include <string>

namespace fishcam::detail {

class StderrCapture {
 public:
  StderrCapture() : lock_(mutex()), file_(std::tmpfile()) {
    std::fflush(stderr);
    if (file_) saved_ = dup(STDERR_FILENO);
    if (saved_ >= 0) dup2(fileno(file_), STDERR_FILENO);
  }
  ~StderrCapture() {
    restore();
    if (file_) std::fclose(file_);
  }
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;

  // "FIRST LINE (N lines)" of what was written, at most kShown characters of its
  // first line; "" when nothing was. Standard error is back from here on.
  std::string summary() {
    restore();
    if (!file_) return "";
    const long size = std::ftell(file_);
    if (size <= 0) return "";
    std::rewind(file_);
    std::string first;
    long lines = 0;
    for (int c; (c = std::fgetc(file_)) != EOF;) {
      if (c == '\n') {
        ++lines;
      } else if (lines == 0 && first.size() < kShown) {
        first.push_back(char(c));
      }
    }
    return first + " (" + std::to_string(lines) + " line" + (lines == 1 ? "" : "s") + ")";
  }

 private:
  static constexpr std::size_t kShown = 160;
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  void restore() {
    if (saved_ < 0) return;
    std::fflush(stderr);
    dup2(saved_, STDERR_FILENO);
    close(saved_);
    saved_ = -1;
  }
  std::lock_guard<std::mutex> lock_;
  std::FILE* file_ = nullptr;
  int saved_ = -1;
};

}  // namespace fishcam::detail
