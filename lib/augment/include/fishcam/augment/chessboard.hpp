// Chessboard corner detection (OpenCV), for calibration: one grayscale image in,
// its inner corners in board order out.
#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <vector>

#include "fishcam/core/board.hpp"

namespace fishcam {

// The board's inner corners (cols x rows, row-major as OpenCV orders them), or
// nullopt when the image shows no such board. OpenCV's findChessboardCorners
// (adaptive threshold) refined by cornerSubPix with a window sized to the board's
// local square size first -- fast, and it finds most boards; where it finds none,
// findChessboardCornersSB (exhaustive, accurate), which also finds boards strongly
// bent at a fisheye's rim but takes ~10 times as long. Throws Error for a board
// smaller than 3x3 or an image that is not 8-bit grayscale.
std::optional<std::vector<Eigen::Vector2d>> detect_chessboard(const cv::Mat& gray, const BoardSpec& board);

}  // namespace fishcam
