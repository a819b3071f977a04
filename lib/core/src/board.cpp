#include "fishcam/core/board.hpp"

#include <algorithm>
#include <cmath>

#include "fishcam/core/error.hpp"

namespace fishcam {

void check_board(const BoardSpec& board) {
  if (board.cols < 2 || board.rows < 2 || board.cols > 1000 || board.rows > 1000) {
    throw Error("board: needs 2 to 1000 corners per side, got " + std::to_string(board.cols) + "x" +
                std::to_string(board.rows));
  }
  // In any unit (metres, millimetres): a spacing outside [1e-6, 1e4] is a typo, and
  // its solve under- or overflows (Ceres then logs pages of warnings).
  if (!(board.spacing >= 1e-6 && board.spacing <= 1e4)) {
    throw Error("board: the corner spacing must lie within [1e-06, 10000] (any unit), got " +
                number_for_message(board.spacing));
  }
  if (!(board.gap == 0 || (board.gap >= 1e-6 && board.gap <= 1e4))) {
    throw Error("board: the gap between tags must be 0 or lie within [1e-06, 10000] (any unit), got " +
                number_for_message(board.gap));
  }
  if (board.gap > 0 && (board.cols % 2 || board.rows % 2)) {
    throw Error("board: a grid of tags has an even number of corners per side, got " + std::to_string(board.cols) +
                "x" + std::to_string(board.rows));
  }
}

std::vector<Eigen::Vector3d> board_points(const BoardSpec& board) {
  std::vector<Eigen::Vector3d> points;
  for (int j = 0; j < board.rows; ++j) {
    for (int i = 0; i < board.cols; ++i) points.emplace_back(board.coordinate(i), board.coordinate(j), 0.0);
  }
  return points;
}

void check_observation(const BoardSpec& board, const BoardObservation& o) {
  const std::string where = "image " + text_for_message(o.filename) + ": ";
  if (o.ids.empty()) {
    if (!o.corners.empty() && int(o.corners.size()) != board.corners()) {
      throw Error(where + std::to_string(o.corners.size()) + " corners without ids; a whole " +
                  std::to_string(board.cols) + "x" + std::to_string(board.rows) + " board has " +
                  std::to_string(board.corners()));
    }
    return;
  }
  if (o.ids.size() != o.corners.size()) {
    throw Error(where + std::to_string(o.ids.size()) + " corner ids for " + std::to_string(o.corners.size()) +
                " corners");
  }
  for (size_t k = 0; k < o.ids.size(); ++k) {
    if (o.ids[k] < 0 || o.ids[k] >= board.corners() || (k > 0 && o.ids[k] <= o.ids[k - 1])) {
      throw Error(where + "corner id " + std::to_string(o.ids[k]) + " at position " + std::to_string(k) +
                  " is not within 0.." + std::to_string(board.corners() - 1) + " in increasing order");
    }
  }
}

std::vector<Eigen::Vector3d> observed_points(const std::vector<Eigen::Vector3d>& points, const BoardObservation& o) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(o.corners.size());
  for (size_t k = 0; k < o.corners.size(); ++k) out.push_back(points.at(size_t(o.id(k))));
  return out;
}

BoardObservation renumbered_from_other_end(const BoardSpec& board, BoardObservation o) {
  std::reverse(o.corners.begin(), o.corners.end());
  std::reverse(o.ids.begin(), o.ids.end());
  for (int& id : o.ids) id = board.corners() - 1 - id;
  return o;
}

Eigen::Vector2d warp_factors(const BoardSpec& board, const Eigen::Vector3d& point) {
  const double u = point.x() / board.width(), v = point.y() / board.height();
  return {4 * u * (1 - u), 4 * v * (1 - v)};
}

std::vector<Eigen::Vector3d> board_points(const BoardSpec& board, const BoardWarp& warp) {
  std::vector<Eigen::Vector3d> points = board_points(board);
  for (auto& p : points) p.z() += Eigen::Vector2d(warp.x2, warp.y2).dot(warp_factors(board, p));
  return points;
}

}  // namespace fishcam
