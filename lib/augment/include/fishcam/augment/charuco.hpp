// ChArUco targets (OpenCV's aruco module): a chessboard whose white squares hold ArUco
// markers, so every corner is known by its id and a board partly outside the image
// still calibrates -- what lets corners reach a fisheye's rim. Detection and the
// board's printed look, for calibration and synthetic renders.
#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fishcam/core/board.hpp"

namespace fishcam {

// cols x rows squares of side `square`, markers of side `marker` (< square, the same
// unit) from an ArUco dictionary (OpenCV's names without DICT_: "4X4_50", "6X6_250",
// "APRILTAG_36h11", ...). Its chessboard corners are a (cols - 1) x (rows - 1) board
// of spacing `square` (board()), numbered row by row as OpenCV numbers them: the
// corner ids of the corners file.
struct CharucoSpec {
  int cols = 0, rows = 0;
  double square = 0, marker = 0;
  std::string dictionary = "4X4_50";
  BoardSpec board() const { return {cols - 1, rows - 1, square}; }
};

// "charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY]" (what --target takes), e.g.
// "charuco:8x6:0.04:0.03:5X5_100"; throws Error naming the problem.
CharucoSpec parse_charuco(std::string_view text);
// Throws Error unless the board has 3..1000 squares per side, 0 < marker < square,
// a known dictionary with a marker for every white square.
void check_charuco(const CharucoSpec& spec);
// The dictionaries parse_charuco accepts, in OpenCV's order.
std::vector<std::string> charuco_dictionaries();

// The corners found in an 8-bit grayscale image (markers found, the corners between
// them interpolated by local homographies and refined with cornerSubPix: OpenCV's
// interpolateCornersCharuco without a camera model, which holds at a fisheye's rim),
// as a partial observation (ids in board order), or nullopt when fewer than 6 corners
// spanning 2 rows and 2 columns are found. Throws Error for an image that is not
// 8-bit grayscale.
std::optional<BoardObservation> detect_charuco(const cv::Mat& gray, const CharucoSpec& spec);

// The board as OpenCV draws it for printing (pixels_per_square per square, the
// markers' bits in their squares), looked up in the board frame of spec.board()
// (inner corner 0 at the origin, x along a row, y down the rows): the grey level
// (0..255) at (x, y), a white margin of one square around the squares, NaN beyond.
class CharucoTexture {
 public:
  explicit CharucoTexture(const CharucoSpec& spec, int pixels_per_square = 64);
  double operator()(double x, double y) const;

 private:
  cv::Mat image_;
  double square_ = 0;
  int pixels_per_square_ = 0;
};

}  // namespace fishcam
