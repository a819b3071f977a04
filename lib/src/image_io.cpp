#include "fishcam/image_io.hpp"

#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <fcntl.h>
#include <unistd.h>

#include "fishcam/error.hpp"
#include "fishcam/file_input.hpp"

namespace fishcam {
namespace {

// Standard error closed for a scope: the image codecs under OpenCV (libpng, libjpeg)
// print their own complaints about a corrupt file there, around our one-line message.
class SilencedStderr {
 public:
  SilencedStderr() : saved_(dup(STDERR_FILENO)) {
    std::fflush(stderr);
    const int null = open("/dev/null", O_WRONLY);
    if (saved_ >= 0 && null >= 0) dup2(null, STDERR_FILENO);
    if (null >= 0) close(null);
  }
  ~SilencedStderr() {
    if (saved_ < 0) return;
    std::fflush(stderr);
    dup2(saved_, STDERR_FILENO);
    close(saved_);
  }
  SilencedStderr(const SilencedStderr&) = delete;
  SilencedStderr& operator=(const SilencedStderr&) = delete;

 private:
  int saved_;
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
