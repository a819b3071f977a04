// Chessboard calibration: mrcal's corners file, synthetic observations, and a
// joint Ceres solve of the intrinsics (any model) and one board pose per image.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fishcam/camera.hpp"
#include "fishcam/fit.hpp"

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

// mrcal's corners format (vnlog): "# filename x y level", one row per corner in
// board order, "filename - - -" for an image without a board. Throws Error naming
// the file, line and problem (e.g. a wrong number of corners for an image).
std::vector<BoardObservation> read_corners(const std::filesystem::path& path, const BoardSpec& board);
// The content of a corners file (throws Error for non-finite corners).
std::string format_corners(const std::vector<BoardObservation>& observations);
void write_corners(const std::filesystem::path& path, const std::vector<BoardObservation>& observations,
                   bool overwrite = false);

// Board poses: p_camera = rotation * p_board + translation.
using BoardPose = Pose;

struct SyntheticBoards {
  std::vector<BoardObservation> observations;
  std::vector<BoardPose> poses;
};
// Observations of `count` boards by a known camera, spread over the whole field of
// view (the rim included), every corner inside the image; Gaussian pixel noise of
// sigma noise_px. Reproducible from the seed on any platform.
SyntheticBoards synthesize_boards(const Camera& camera, const BoardSpec& board, int count, double noise_px,
                                  std::uint64_t seed);

struct CalibrationResult {
  CameraParameters camera;
  std::vector<BoardPose> poses;            // per observation with a board, in file order
  std::vector<std::string> used_images;    // their filenames
  std::vector<double> per_image_rms_px;
  double rms_px = 0;
  long observations = 0;                   // corners used
  struct Outlier {
    std::string filename;
    int corner;
    double error_px;
  };
  std::vector<Outlier> outliers;           // corners the robust loss discounted (> 5 sigma)
  std::vector<std::string> parameter_names;  // model parameters, then cx, cy, a_y
  std::vector<double> parameters, sigmas;    // values and 1-sigma uncertainties (covariance of the solve)
  std::vector<std::string> warnings;         // e.g. boards that leave most of the image uncovered
};

// Joint solve. Initialisation works for lenses past 180 deg: an equidistant model
// scanned over focal lengths, each board placed from its corners' rays, the best
// start refined. Throws Error on too little or degenerate data.
CalibrationResult calibrate(const std::vector<BoardObservation>& observations, const BoardSpec& board, int width,
                            int height, const ModelSpec& model);

}  // namespace fishcam
