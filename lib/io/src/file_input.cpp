#include "fishcam/io/file_input.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "file_descriptor.hpp"
#include "fishcam/core/error.hpp"

namespace fishcam {
namespace {

using detail::FileDescriptor;

// Opens path without blocking (a FIFO's open waits for a writer otherwise) and
// checks it is a regular file within max_bytes; returns the descriptor and size.
FileDescriptor open_bounded(const std::filesystem::path& path, std::size_t max_bytes, std::string_view what,
                            std::size_t* size) {
  const std::string name = path_for_message(path);
  FileDescriptor file{open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
  if (file.fd < 0) throw Error(name + ": cannot open (" + std::strerror(errno) + ")");
  struct stat info {};
  if (fstat(file.fd, &info) != 0) throw Error(name + ": cannot open (" + std::strerror(errno) + ")");
  if (S_ISDIR(info.st_mode)) throw Error(name + ": is a directory, not " + std::string(what));
  if (!S_ISREG(info.st_mode)) throw Error(name + ": not a regular file (devices, FIFOs and sockets are not read)");
  if (std::uintmax_t(info.st_size) > max_bytes) {
    throw Error(name + ": larger than " + byte_size_for_message(max_bytes) + ", not " + std::string(what));
  }
  *size = std::size_t(info.st_size);
  return file;
}

}  // namespace

std::string byte_size_for_message(std::size_t bytes) {
  if (bytes >= (std::size_t(1) << 20) && bytes % (std::size_t(1) << 20) == 0)
    return std::to_string(bytes >> 20) + " MiB";
  if (bytes >= 1024 && bytes % 1024 == 0) return std::to_string(bytes >> 10) + " kB";
  return std::to_string(bytes) + " bytes";
}

void check_bounded_file(const std::filesystem::path& path, std::size_t max_bytes, std::string_view what) {
  std::size_t size = 0;
  open_bounded(path, max_bytes, what, &size);
}

std::string read_bounded_file(const std::filesystem::path& path, std::size_t max_bytes, std::string_view what) {
  std::size_t size = 0;
  const FileDescriptor file = open_bounded(path, max_bytes, what, &size);
  const std::string name = path_for_message(path);
  std::string content(size, '\0');
  std::size_t done = 0;
  while (true) {  // the file may have grown since fstat: read to its end, up to the limit
    if (done == content.size()) {
      if (content.size() > max_bytes) {
        throw Error(name + ": larger than " + byte_size_for_message(max_bytes) + ", not " + std::string(what));
      }
      content.resize(std::min<std::size_t>(content.size() * 2 + 4096, max_bytes + 1));
    }
    const ssize_t n = read(file.fd, content.data() + done, content.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw Error(name + ": read error (" + std::strerror(errno) + ")");
    if (n == 0) break;
    done += std::size_t(n);
  }
  content.resize(done);
  return content;
}

}  // namespace fishcam
