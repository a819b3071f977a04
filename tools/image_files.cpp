#include "image_files.hpp"

#include <opencv2/imgcodecs.hpp>

#include "fishcam/core/error.hpp"
#include "fishcam/core/stderr_capture.hpp"
#include "fishcam/io/file_input.hpp"

namespace fishcam {

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
    // The codecs under OpenCV (libpng, libjpeg) print their own complaints about a
    // corrupt file: our one-line message says it instead.
    const detail::SilencedStderr quiet;
    image = cv::imread(path.string(), flags);
  }
  if (image.empty()) throw Error(path_for_message(path) + ": cannot read image (unsupported or corrupt file)");
  return image;
}

}  // namespace fishcam
