#include "fishcam/image_io.hpp"

#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <mutex>
#include <fcntl.h>
#include <unistd.h>

#include "fishcam/error.hpp"
#include "fishcam/file_input.hpp"

namespace fishcam {
namespace {

// Standard error closed for a scope: the image codecs under OpenCV (libpng, libjpeg)
// print their own complaints about a corrupt file there, around our one-line message.
// File descriptor 2 is the process's: images read in parallel (detect-corners) share
// one silencing, the first to come closes it and the last to leave opens it again.
class SilencedStderr {
 public:
  SilencedStderr() {
    const std::lock_guard<std::mutex> lock(mutex());
    if (depth()++ > 0) return;
    std::fflush(stderr);
    saved() = dup(STDERR_FILENO);
    const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (saved() >= 0 && null >= 0) dup2(null, STDERR_FILENO);
    if (null >= 0) close(null);
  }
  ~SilencedStderr() {
    const std::lock_guard<std::mutex> lock(mutex());
    if (--depth() > 0 || saved() < 0) return;
    std::fflush(stderr);
    dup2(saved(), STDERR_FILENO);
    close(saved());
    saved() = -1;
  }
  SilencedStderr(const SilencedStderr&) = delete;
  SilencedStderr& operator=(const SilencedStderr&) = delete;

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static int& depth() {
    static int d = 0;
    return d;
  }
  static int& saved() {
    static int fd = -1;
    return fd;
  }
};

}  // namespace

cv::Mat read_image(const std::filesystem::path& path, int flags) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec && ec != std::errc::no_such_file_or_directory) throw Error(path_for_message(path) + ": " + ec.message());
  if (!std::filesystem::exists(status)) throw Error(path_for_message(path) + ": no such file");
  if (!std::filesystem::is_regular_file(status)) throw Error(path_for_message(path) + ": not a regular file");
  // OpenCV's decoders read the file themselves: checked here for its kind and size
  // (a 16384 x 16384 RGBA PNG stays well below the limit).
  check_bounded_file(path, std::size_t(2) << 30, "an image file");
  cv::Mat image;
  {
    const SilencedStderr quiet;
    image = cv::imread(path.string(), flags);
  }
  if (image.empty()) throw Error(path_for_message(path) + ": cannot read image (unsupported or corrupt file)");
  return image;
}

}  // namespace fishcam
