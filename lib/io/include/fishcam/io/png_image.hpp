// Reading the PNG files of a dataset folder (the WoodScape layout: colour images and
// 8-bit label images) with libpng: what the library's own dataset walks (fidelity)
// read. Decoded as OpenCV's cv::imread decodes them, so that the library needs no
// image codecs beyond libpng (OpenCV's imgcodecs pulls in ~140 shared libraries,
// GDAL among them, which the Python wheel would have to carry). The program reads
// any image format through OpenCV (tools/image_files.hpp).
#pragma once

#include <opencv2/core.hpp>

#include <filesystem>
#include <string>

namespace fishcam {

enum class PngPixels {
  bgr8,   // 8-bit, 3 channels, B G R: as cv::imread(path, cv::IMREAD_COLOR) (16-bit
          // samples keep their high byte, alpha dropped, grey and palette expanded)
  gray8,  // 8-bit, 1 channel, as stored: files of any other kind are refused
};

// The PNG file at path, or Error "PATH: ..." naming the problem (no such file, not a
// PNG file, corrupt, larger than 32768 pixels a side, not 8-bit grey for gray8).
cv::Mat read_png(const std::filesystem::path& path, PngPixels pixels);

// The bytes of a PNG file holding an 8-bit image (1 channel: grey; 3: B G R, as
// cv::imwrite takes them), for reports and figures written by the library. Throws
// Error for any other kind of image.
std::string encode_png(const cv::Mat& image);

}  // namespace fishcam
