#include "fishcam/augment/chessboard.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include "fishcam/core/error.hpp"

namespace fishcam {
namespace {

// cornerSubPix's half window for each corner: OpenCV's usual 5 px, narrowed to 45 %
// of the distance to its nearest grid neighbour where squares are small (a window
// wider than a square reaches the next corner and pulls the estimate), at least 2.
int half_window(const std::vector<cv::Point2f>& corners, int cols, int rows, int i, int j) {
  double nearest = std::numeric_limits<double>::infinity();
  const cv::Point2f& here = corners[size_t(j * cols + i)];
  for (const auto& [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
    const int ni = i + di, nj = j + dj;
    if (ni < 0 || nj < 0 || ni >= cols || nj >= rows) continue;
    nearest = std::min(nearest, double(cv::norm(corners[size_t(nj * cols + ni)] - here)));
  }
  return std::clamp(int(0.45 * nearest), 2, 5);
}

}  // namespace

std::optional<std::vector<Eigen::Vector2d>> detect_chessboard(const cv::Mat& gray, const BoardSpec& board) {
  if (board.cols < 3 || board.rows < 3) throw Error("chessboard detection needs at least 3x3 inner corners");
  if (gray.type() != CV_8UC1) throw Error("chessboard detection takes an 8-bit grayscale image");
  const cv::Size size(board.cols, board.rows);
  std::vector<cv::Point2f> corners;
  if (cv::findChessboardCorners(gray, size, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
    const cv::TermCriteria until(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 1e-3);
    std::vector<cv::Point2f> refined = corners;
    for (int j = 0; j < board.rows; ++j) {
      for (int i = 0; i < board.cols; ++i) {
        const int w = half_window(corners, board.cols, board.rows, i, j);
        std::vector<cv::Point2f> one = {corners[size_t(j * board.cols + i)]};
        cv::cornerSubPix(gray, one, {w, w}, {-1, -1}, until);
        refined[size_t(j * board.cols + i)] = one[0];
      }
    }
    corners = std::move(refined);
  } else if (!cv::findChessboardCornersSB(gray, size, corners, cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY)) {
    return std::nullopt;
  }
  std::vector<Eigen::Vector2d> out;
  out.reserve(corners.size());
  for (const auto& c : corners) out.emplace_back(c.x, c.y);
  return out;
}

}  // namespace fishcam
