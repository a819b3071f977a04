// Chessboard calibration: a joint Ceres solve of the intrinsics (any model) and one
// board pose per image, from corners (fishcam/corners.hpp reads them).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fishcam/board.hpp"
#include "fishcam/camera.hpp"
#include "fishcam/fit.hpp"

namespace fishcam {

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
