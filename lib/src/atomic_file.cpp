#include "fishcam/atomic_file.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <set>

#include "fishcam/error.hpp"

namespace fishcam {
namespace {

[[noreturn]] void fail_io(const std::filesystem::path& path, const char* what, int error) {
  throw Error(path.string() + ": " + what + " (" + std::strerror(error) + ")");
}

void write_temporary(const std::filesystem::path& path, const std::string& bytes) {
  const std::filesystem::path tmp = temporary_path(path);
  std::FILE* file = std::fopen(tmp.c_str(), "wb");
  if (!file) fail_io(path, "cannot write", errno);
  errno = 0;
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size() && std::fflush(file) == 0;
  const int write_error = errno;
  const bool closed = std::fclose(file) == 0;
  const int close_error = errno;
  if (!written || !closed) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    fail_io(path, "write failed", written ? close_error : write_error);
  }
}

void check_absent(const std::filesystem::path& path, bool overwrite) {
  std::error_code ec;
  if (!overwrite && std::filesystem::exists(path, ec)) {
    throw Error(path.string() + ": already exists (refusing to overwrite)");
  }
}

}  // namespace

std::filesystem::path temporary_path(const std::filesystem::path& path) { return path.string() + ".fishcam-tmp"; }

void write_file_atomically(const std::filesystem::path& path, const std::string& bytes, bool overwrite) {
  write_files_atomically({{path, bytes}}, overwrite);
}

void write_files_atomically(const std::vector<std::pair<std::filesystem::path, std::string>>& files, bool overwrite) {
  std::set<std::filesystem::path> seen;
  for (const auto& [path, bytes] : files) {
    check_absent(path, overwrite);
    if (!seen.insert(std::filesystem::weakly_canonical(path)).second) {
      throw Error(path.string() + ": given as more than one output");
    }
  }
  std::error_code ec;
  for (size_t i = 0; i < files.size(); ++i) {
    try {
      write_temporary(files[i].first, files[i].second);
    } catch (const Error&) {
      for (size_t k = 0; k < i; ++k) std::filesystem::remove(temporary_path(files[k].first), ec);
      throw;
    }
  }
  for (const auto& [path, bytes] : files) {
    std::filesystem::rename(temporary_path(path), path, ec);
    if (ec) {
      std::filesystem::remove(temporary_path(path), ec);
      throw Error(path.string() + ": cannot move the written file into place (" + ec.message() + ")");
    }
  }
}

}  // namespace fishcam
