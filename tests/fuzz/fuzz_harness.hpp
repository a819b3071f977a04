// What every fuzz harness shares: the input as text or as a file, and the rule
// that only fishcam::Error may come out of a reader (anything else, or a crash,
// is a finding).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <string_view>

#include "fishcam/core/error.hpp"

namespace fishcam::fuzz {

template <class Read>
void expect_only_errors(const Read& read) {
  try {
    read();
  } catch (const Error& e) {
    const std::string what = e.what();
    if (what.find('\n') != std::string::npos || what.find('\r') != std::string::npos) {
      std::fprintf(stderr, "multi-line error message: %s\n", what.c_str());
      std::abort();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "a reader let a non-fishcam exception out: %s\n", e.what());
    std::abort();
  }
}

// The input as a file (for readers that take paths), one per process, removed
// when the process exits (a replay of the corpus must not leave files behind).
inline std::filesystem::path as_file(const std::uint8_t* data, std::size_t size, const char* extension) {
  struct ProcessFile {
    std::filesystem::path path;
    ~ProcessFile() {
      std::error_code ignored;
      std::filesystem::remove(path, ignored);
    }
  };
  static const ProcessFile file{std::filesystem::temp_directory_path() /
                                ("fishcam-fuzz-" + std::to_string(::getpid()) + extension)};
  const std::filesystem::path& path = file.path;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

}  // namespace fishcam::fuzz
