// Reading the images the program is given, in any format OpenCV's codecs read (the
// library reads only the PNG files of dataset folders: fishcam/io/png_image.hpp).
#pragma once

#include <opencv2/core.hpp>

#include <filesystem>

namespace fishcam {

// cv::imread with `flags`, or Error "PATH: no such file" / "PATH: cannot read image
// (unsupported or corrupt file)"; the codecs' own complaints on standard error are
// kept off it (one line per problem).
cv::Mat read_image(const std::filesystem::path& path, int flags);

}  // namespace fishcam
