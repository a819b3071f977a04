// Chessboard calibration: a joint Ceres solve of the intrinsics (any model) and one
// board pose per image, from corners (fishcam/io/corners.hpp reads them).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fishcam/core/board.hpp"
#include "fishcam/core/camera.hpp"
#include "fishcam/fit/fit.hpp"

namespace fishcam {

struct CalibrationResult {
  CameraParameters camera;
  std::vector<BoardPose> poses;          // per observation with a board, in file order
  std::vector<std::string> used_images;  // their filenames
  std::vector<double> per_image_rms_px;
  double rms_px = 0;
  long observations = 0;  // corners used
  struct Outlier {
    std::string filename;
    int corner;
    double error_px;
  };
  std::vector<Outlier> outliers;             // corners the robust loss discounted (> 5 sigma)
  std::vector<std::string> parameter_names;  // model parameters, terms solved (p1, ...), cx, cy, a_y
  // Values and 1-sigma uncertainties (the solve's covariance); sigma NaN for a
  // parameter the data do not determine (see undetermined).
  std::vector<double> parameters, sigmas;
  // One text per combination of parameters the data do not determine (a direction
  // of the solve's covariance with no curvature), naming the parameters.
  std::vector<std::string> undetermined;
  double noise_px = 0;  // residual standard deviation per coordinate
  // The boards' warp (CalibrationOptions::board_warp; poses are of the warped board)
  // and its 1-sigma; none where the boards were held flat.
  std::optional<BoardWarp> board_warp;
  BoardWarp board_warp_sigma;
  std::vector<std::string> warnings;  // e.g. boards that leave most of the image uncovered
  // A rig's images whose corners the joint solve read numbered from the other end (a
  // chessboard's 180-degree ambiguity): their poses are of that numbering, their
  // outliers numbered as in the corners file.
  std::vector<std::string> renumbered_images;
};

struct CalibrationOptions {
  // Threads for the independent solves (the model's starts, the initial focal-length
  // scan). Each solve runs on one thread and results are combined in a fixed order,
  // so the result is the same, bit for bit, for every count.
  int threads = 1;
  // Solve the boards' warp (BoardWarp, mrcal's two-parameter calobject_warp, one for
  // every board) with the intrinsics, as mrcal does by default: real boards are
  // rarely flat to the corners' precision. Off: the boards are flat (OpenCV's model).
  // A rig solves one warp in its joint solve (and each camera's own calibration, its
  // start, its own), as mrcal's joint solve does.
  bool board_warp = true;
};

// Joint solve. Initialisation works for lenses past 180 deg: an equidistant model
// scanned over focal lengths, each board placed from its corners' rays, the best
// start refined. Throws Error on too little or degenerate data.
// The result's camera carries a CalibrationRecord: the observed incidence angles
// and the covariance projection uncertainty is computed from.
CalibrationResult calibrate(const std::vector<BoardObservation>& observations, const BoardSpec& board, int width,
                            int height, const ModelSpec& model, const CalibrationOptions& options = {});

// The board poses of a camera whose intrinsics are known, as calibrate finds them
// with the intrinsics held: each board placed from its corners' rays, a robust solve
// (Cauchy, 1 px), the outliers (> 5 robust sigmas) left out, plain least squares.
// The result's camera is `camera`, its parameters the model's, cx, cy and a_y with
// sigma 0. Throws Error naming the image whose corners the camera cannot see.
CalibrationResult locate_boards(const std::vector<BoardObservation>& observations, const BoardSpec& board,
                                const Camera& camera);

// A camera rig (a stereo pair, a car's surround-view cameras): every camera's
// intrinsics, each camera's pose relative to camera 0 and the boards' poses, solved
// jointly from images taken at the same instants. Images of one instant have the
// same file name (the last path component: left/0001.png and right/0001.png).
struct RigCamera {
  std::vector<BoardObservation> observations;
  int width = 0, height = 0;
  ModelSpec model;
  // Intrinsics held fixed (OpenCV's CALIB_FIX_INTRINSIC, mrcal's
  // --skip-intrinsics-solve): only where the camera sits in the rig is solved. Any
  // camera fishcam reads, for width x height images; `model` is then not used.
  std::optional<CameraParameters> fixed_intrinsics = std::nullopt;
};
struct RigCalibrationResult {
  // Per camera: its report (intrinsics, sigmas and the record -- observed angles and
  // the covariance projection uncertainty uses, with this camera's pose relative to
  // camera 0 and every instant's board -- from the joint solve), camera.pose =
  // camera -> camera 0 (camera 0: identity).
  std::vector<CalibrationResult> cameras;
  // Per camera, 1-sigma of its pose relative to camera 0 from the joint covariance:
  // rotation (rad, the angle-axis components' largest) and translation (board units,
  // the largest component); 0 for camera 0.
  std::vector<double> rotation_sigma_rad, translation_sigma;
  std::vector<bool> fixed_intrinsics;  // per camera: held fixed (RigCamera::fixed_intrinsics)
  double rms_px = 0;                   // over every camera's corners (2-D)
  long instants = 0;                   // distinct instants with a board
  std::vector<std::string> warnings;
};
// Each camera must calibrate on its own (>= 3 boards, fishcam::calibrate's checks),
// and every camera must share instants with camera 0, directly or through others.
// Throws Error naming the camera otherwise.
RigCalibrationResult calibrate_rig(const std::vector<RigCamera>& cameras, const BoardSpec& board,
                                   const CalibrationOptions& options = {});

// The reports `fishcam calibrate --json` prints, built here as convert's is
// (fit_report_json). One camera: model, plane_distortion ("none"; "tangential" for
// MODEL+tangential/+thin-prism, "mrcal_lens" for mrcal's spline, whose terms or values
// are among the parameters), rms_px (the corners' 2-D reprojection error;
// mrcal and OpenCV print it per coordinate, rms_per_coordinate_px = rms_px / sqrt 2),
// noise_px, corners, images, outliers, undetermined, observed_theta_max_deg,
// theta_limit_deg and theta_limit_by_azimuth_deg (24 sectors of 15 degrees from -180,
// or null; of `written`, the camera as written), board_warp ({x2, y2: {value, sigma}}
// in board units, or null: flat boards), poses, pose_convention,
// warnings, out, parameters {name: {value, sigma, determined}}, per_image_rms_px.
std::string calibration_report_json(const CalibrationResult& result, const CameraParameters& written,
                                    const std::string& out);
// A rig: rms_px, rms_per_coordinate_px, instants, board_warp (as one camera's: the
// joint solve's), warnings, out, pose_convention, and
// per camera its corners file, model, rms_px, corners, images, outliers, undetermined,
// pose (camera -> camera 0, with sigmas) and parameters {name: {value, sigma}}.
std::string rig_calibration_report_json(const RigCalibrationResult& rig, const std::vector<std::string>& corners_files,
                                        const std::string& out);
// The board poses of `--poses FILE`: {"convention", "poses": [{image,
// quaternion_xyzw, translation, rms_px}, ...]}, or for a rig {"convention",
// "cameras": [{"camera", "poses"}, ...]}.
std::string calibration_poses_json(const CalibrationResult& result);
std::string rig_calibration_poses_json(const RigCalibrationResult& rig);

// Projection uncertainty as mrcal defines it: the spread of the projection of a
// point fixed relative to the calibration boards, seen at `pixel`, through
// calibrations perturbed by the corner noise -- propagated (to first order) from
// the covariance of the intrinsics and the boards' mean motion in the camera's
// CalibrationRecord. The point lies at `distance` (board units) along the pixel's
// ray, or at infinity (nullopt: only rotations move it). Returns the 2x2 covariance
// (px^2); NaN where the pixel does not unproject. Throws Error when the camera
// carries no covariance (only fishcam calibrate writes one).
Eigen::Matrix2d projection_covariance(const Camera& camera, const Eigen::Vector2d& pixel,
                                      std::optional<double> distance);
// Its worst-direction 1-sigma (px): the square root of the larger eigenvalue, as
// mrcal's projection_uncertainty(what = "worstdirection-stdev").
double projection_uncertainty(const Camera& camera, const Eigen::Vector2d& pixel, std::optional<double> distance);

}  // namespace fishcam
