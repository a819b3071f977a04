#include "fishcam/board.hpp"

#include <cmath>

#include "fishcam/error.hpp"

namespace fishcam {

void check_board(const BoardSpec& board) {
  if (board.cols < 2 || board.rows < 2 || board.cols > 1000 || board.rows > 1000) {
    throw Error("board: needs 2 to 1000 corners per side, got " + std::to_string(board.cols) + "x" +
                std::to_string(board.rows));
  }
  if (!(board.spacing > 0) || !std::isfinite(board.spacing)) throw Error("board: the corner spacing must be finite and > 0");
}

std::vector<Eigen::Vector3d> board_points(const BoardSpec& board) {
  std::vector<Eigen::Vector3d> points;
  for (int j = 0; j < board.rows; ++j) {
    for (int i = 0; i < board.cols; ++i) points.emplace_back(i * board.spacing, j * board.spacing, 0.0);
  }
  return points;
}

}  // namespace fishcam
