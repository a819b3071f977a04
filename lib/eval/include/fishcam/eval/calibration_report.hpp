// A calibration's report to look at (fishcam calibrate --report, fishcam report): an
// HTML page with PNG figures, as Kalibr's PDF report and mrcal's show-residuals and
// show-projection-uncertainty show a calibration -- residual vectors over the image
// and per image, their histogram against the expected distribution, board coverage,
// the observed domain per azimuth beside the camera's, the projection-uncertainty map,
// per-image RMS with outliers marked and, for rigs, each instant's relative pose.
// Everything is returned as file contents; the caller writes them (together, so a
// report is never half-written: fishcam/io/atomic_file.hpp).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fishcam/core/board.hpp"
#include "fishcam/core/camera.hpp"
#include "fishcam/fit/calibration.hpp"

namespace fishcam {

// One corner of a calibration's images: where it was detected and its residual
// (projected minus detected, px) through the result's camera and its board's pose
// (the board warped as the result's board_warp says).
struct CornerFit {
  int image = 0;   // index into CalibrationResult::used_images
  int corner = 0;  // as the corners file numbers it (a rig's renumbered images: reversed)
  Eigen::Vector2d detected, residual;
  bool outlier = false;  // among CalibrationResult::outliers (left out of the solve)
};

// Every corner of the result's images (used_images, in that order; `observations`
// are those the result was solved from, matched by file name). Throws Error when an
// image is missing from them or a corner does not project. The RMS of the corners
// that are not outliers is the result's rms_px.
std::vector<CornerFit> corner_fits(const CalibrationResult& result, const std::vector<BoardObservation>& observations,
                                   const BoardSpec& board);

// The projection uncertainty (projection_uncertainty, worst direction, px) every
// `step`-th pixel from (0, 0): NaN where the pixel has no ray; `observed` 1 where its
// ray lies inside the angles the calibration observed. The camera carries a covariance.
struct UncertaintyMap {
  cv::Mat sigma;                            // CV_64F, rows = ceil(height / step), cols = ceil(width / step)
  cv::Mat observed;                         // CV_8U
  std::vector<double> everywhere, in_data;  // the finite values, and those observed
};
UncertaintyMap uncertainty_map(const Camera& camera, int step, std::optional<double> distance);
// The map coloured (viridis up to `top` px, black = no ray, dimmed = outside the
// observed angles), at the camera's size.
cv::Mat uncertainty_heatmap(const UncertaintyMap& map, double top, int width, int height);

// A file of a report folder: its name in the folder, its bytes.
struct ReportFile {
  std::string name, bytes;
};

// One camera's report: index.html and the figures it shows. `result` is what
// calibrate or locate_boards returned, `observations` its corners, `written` the
// camera as written (its valid domain is drawn beside the observed one), `title`
// names the calibration (the corners file). The uncertainty map is drawn when the
// camera carries a covariance (the page says so otherwise).
std::vector<ReportFile> calibration_report(const CalibrationResult& result, const CameraParameters& written,
                                           const std::vector<BoardObservation>& observations, const BoardSpec& board,
                                           const std::string& title);

// A rig's: one section per camera (figures named cameraK-...), and per camera k > 0
// each instant's relative pose camera 0 -> k (each camera's boards located with its
// own intrinsics, locate_boards) against the joint solve's, in degrees and board units.
std::vector<ReportFile> rig_calibration_report(const RigCalibrationResult& rig,
                                               const std::vector<CameraParameters>& written,
                                               const std::vector<std::vector<BoardObservation>>& observations,
                                               const BoardSpec& board, const std::vector<std::string>& titles);

}  // namespace fishcam
