// Chessboards as calibration sees them: the board's geometry and one image's
// detected corners. Plain data of the core layer; corners files are read and
// written by fishcam/io/corners.hpp (fishcam_io), calibrated by fishcam/fit/calibration.hpp.
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

#include "fishcam/core/camera.hpp"

namespace fishcam {

// A chessboard of cols x rows inner corners, `spacing` metres apart. Its points, in
// board order (row-major: x = i * spacing for i < cols, y = j * spacing, z = 0), are
// the order corner files list them in.
struct BoardSpec {
  int cols = 0, rows = 0;
  double spacing = 0;
  int corners() const { return cols * rows; }
};
// Throws Error unless the board has 2..1000 corners per side and a finite spacing > 0.
void check_board(const BoardSpec& board);
std::vector<Eigen::Vector3d> board_points(const BoardSpec& board);

// One image's corners, in board order; empty when the image shows no board.
struct BoardObservation {
  std::string filename;
  std::vector<Eigen::Vector2d> corners;
};

// Board poses: p_camera = rotation * p_board + translation.
using BoardPose = Pose;

}  // namespace fishcam
