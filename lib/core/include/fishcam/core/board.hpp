// Chessboards as calibration sees them: the board's geometry and one image's
// detected corners. Plain data of the core layer; corners files are read and
// written by fishcam/io/corners.hpp (fishcam_io), calibrated by fishcam/fit/calibration.hpp.
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

#include "fishcam/core/camera.hpp"

namespace fishcam {

// A chessboard of cols x rows inner corners, `spacing` metres apart. Its points, in
// board order (row-major: x = i * spacing for i < cols, y = j * spacing, z = 0), are
// the order corner files list them in.
//
// A grid of tags (an AprilGrid: fishcam/augment/aprilgrid.hpp) has `gap` > 0: its
// corners come in pairs, a tag's two edges `spacing` apart, and the pairs `gap`
// apart (the space between tags), so coordinate(i) = (i / 2) (spacing + gap) +
// (i % 2) spacing along x and y; cols and rows are even.
struct BoardSpec {
  int cols = 0, rows = 0;
  double spacing = 0;
  double gap = 0;
  int corners() const { return cols * rows; }
  // The coordinate of corner column (or row) i along x (or y).
  double coordinate(int i) const { return gap > 0 ? (i / 2) * (spacing + gap) + (i % 2) * spacing : i * spacing; }
  double width() const { return coordinate(cols - 1); }
  double height() const { return coordinate(rows - 1); }
};
// Throws Error unless the board has 2..1000 corners per side and a finite spacing > 0
// (and a gap >= 0 within the same range, with an even number of corners per side).
void check_board(const BoardSpec& board);
std::vector<Eigen::Vector3d> board_points(const BoardSpec& board);

// A board that is not flat, as mrcal models it (calobject_warp): corner (i, j) moves
// along the board's z by x2 * 4u(1 - u) + y2 * 4v(1 - v), u = x / width() and
// v = y / height() (i / (cols - 1) and j / (rows - 1) on a chessboard), two parabolas whose deflections at the middle
// of the board's width and height are x2 and y2 (board units; z as board_points', so a board bowed towards a camera
// looking at its front has x2, y2 < 0).
struct BoardWarp {
  double x2 = 0, y2 = 0;
};
// The factors (4u(1 - u), 4v(1 - v)) of a point of board_points(board).
Eigen::Vector2d warp_factors(const BoardSpec& board, const Eigen::Vector3d& point);
std::vector<Eigen::Vector3d> board_points(const BoardSpec& board, const BoardWarp& warp);

// One image's corners; empty when the image shows no board. A board seen whole lists
// every corner in board order (ids empty); a partial board (a target that may leave
// the image, such as ChArUco, or corners a detector or mrcal-cull-corners dropped)
// lists the corners it has, ids[k] being corners[k]'s index in board order (strictly
// increasing).
struct BoardObservation {
  std::string filename;
  std::vector<Eigen::Vector2d> corners;
  std::vector<int> ids{};
  // corners[k]'s index in board order.
  int id(size_t k) const { return ids.empty() ? int(k) : ids[k]; }
};
// Throws Error naming the image unless `ids` is empty with every corner, or one id per
// corner, strictly increasing, within the board.
void check_observation(const BoardSpec& board, const BoardObservation& observation);
// The board points the observation's corners are, in its order.
std::vector<Eigen::Vector3d> observed_points(const std::vector<Eigen::Vector3d>& points,
                                             const BoardObservation& observation);
// The same view with its corners numbered from the board's other end (corner id m
// becomes corners() - 1 - m: a symmetric chessboard seen turned by 180 degrees).
BoardObservation renumbered_from_other_end(const BoardSpec& board, BoardObservation observation);

// Board poses: p_camera = rotation * p_board + translation.
using BoardPose = Pose;

}  // namespace fishcam
