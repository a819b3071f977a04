// Fitting a camera model to correspondences (rays and the pixels they hit), and
// converting one model into another, with the error it costs reported honestly.
#pragma once

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fishcam/core/camera.hpp"

namespace fishcam {

// A model to fit: a registry name (model_names_text()); "polynomial:N" gives the
// polynomial's order (default 4); "MODEL+tangential" adds OpenCV's tangential terms
// p1, p2 and "MODEL+thin-prism" those and the thin prism s1..s4 (the models with an
// undistorted plane: pinhole, opencv, mei), which only a calibration solves
// (mrcal's LENSMODEL_OPENCV8 is opencv+tangential, OPENCV12 opencv+thin-prism).
// mrcal's splined model, named as mrcal names it
// (LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=200), is the
// stereographic model with that lens on its plane (fishcam/core/mrcal_lens.hpp):
// only a calibration solves it.
struct ModelSpec {
  std::string name;
  int order = 4;                // polynomial only
  int tangential_terms = 0;     // 0, 2 (p1, p2) or 6 (p1, p2, s1..s4)
  std::string mrcal_lens = {};  // mrcal's lensmodel on the model's plane ("": none)
};
// The highest polynomial order fitted: past it the normal equations in theta^k
// lose most of double's digits (a Polynomial itself holds up to
// Polynomial::kMaxOrder coefficients, read from files).
constexpr int kMaxFittedPolynomialOrder = 12;
ModelSpec parse_model_spec(std::string_view text);  // throws Error on unknown names

struct Correspondence {
  Eigen::Vector3d ray;    // camera frame, any length
  Eigen::Vector2d pixel;  // where it is seen
};

// Pixels of the camera's image inside its valid domain, every `step` pixels in u and
// v (offset by `offset`), with their unit rays; only rays up to max_theta when given.
// For images past 4 M grid points the step grows so that at most about 4 M are taken.
std::vector<Correspondence> sample_image(const Camera& camera, int step, int offset = 0,
                                         std::optional<double> max_theta = std::nullopt);

struct FitOptions {
  bool fit_center = false;  // free the principal point
  bool fit_aspect = false;  // free a_y (a_x stays)
};

// The model that best reprojects the correspondences (least squares on pixel error):
// a weighted linear least-squares start on rho(theta) for fixed principal point and
// pixel scale (exact for that case: every model is linear in its parameters, after
// Kannala-Brandt's reparametrization), then Ceres on the full pixel error with the
// freed parameters. `start` gives the image size, principal point and pixel scale.
// Throws Error if the data cannot determine the model (too few samples, pinhole
// with rays at or past 90 deg, a degenerate system).
CameraParameters fit_camera(std::span<const Correspondence> samples, const ModelSpec& model,
                            const CameraParameters& start, const FitOptions& options = {});

// The paper's eqs. 13-14: f = rho / theta (equidistant), f = rho / (2 tan(theta / 2))
// (stereographic), with rho = W / 2 (half the image width, px) and theta = half the
// source's horizontal field of view (Camera::field_of_view_deg).
CameraParameters paper_camera(const Camera& source, const ModelSpec& model);

struct ErrorReport {
  long samples = 0;
  long unprojectable = 0;  // samples the camera cannot project (outside its valid domain)
  double rms_px = 0, p99_px = 0, max_px = 0;
  // The same over rays with theta < 90 deg (what OpenCV's fisheye functions can use).
  long samples_below_90 = 0;
  double rms_below_90_px = 0, max_below_90_px = 0;
  struct Bin {
    double theta_from_deg, theta_to_deg;
    long samples;
    double rms_px, max_px;
  };
  std::vector<Bin> by_angle;  // 10-degree bins
};
// Pixel error of `camera` reprojecting the correspondences.
ErrorReport reprojection_errors(const Camera& camera, std::span<const Correspondence> samples);

// What `fishcam convert` does: the model fitted to the source camera ("lsq": least
// squares over every 4th pixel of its valid image, up to max_theta when given;
// "paper": eqs. 13-14), and its error over a denser grid (every 2nd pixel).
// A source that is not radially symmetric (tangential terms, an mrcal lens) has its
// principal point and a_y fitted too, whatever the options say: a radial model about
// the source's principal point is not the best radial model. `non_radial` then
// measures, over the same evaluation rays, the error no radial model can avoid about
// the fitted principal point and pixel scale: what remains after the best free-form
// rho(theta) (fitted per 0.25-degree band), i.e. each pixel's offset across its ray's
// azimuth and the spread of its radius within its band (not computed for a radial
// source, where it is ~0).
struct Conversion {
  CameraParameters camera;
  ErrorReport report;
  double widest_theta = 0;  // radians: the widest ray of the evaluation grid
  struct NonRadial {
    long samples = 0;
    double rms_px = 0, max_px = 0;
  } non_radial;
  bool center_and_aspect_fitted = false;
};
// The conversion methods' names ("lsq", "paper"): the CLI's choices and messages.
const std::vector<std::string>& conversion_method_names();
// Throws Error "method: expected lsq or paper, got 'NAME'" unless name is one.
void check_conversion_method(std::string_view name);
Conversion convert_camera(const Camera& source, const ModelSpec& model, std::string_view method = "lsq",
                          std::optional<double> max_theta = std::nullopt, const FitOptions& options = {});

// The error of `fitted` at every pixel of the source's image: |fitted(ray) - pixel|
// for the ray of the pixel's centre, row-major W x H; NaN where the source has no
// ray or `fitted` cannot project it. The images must have the same size.
std::vector<float> reprojection_error_map(const Camera& source, const Camera& fitted);

// An error report as one JSON object: rms_px, p99_px, max_px, samples, unprojectable,
// below_90_deg, by_angle, and the fitted model, parameters, principal_point, pixel_scale.
std::string fit_report_json(const CameraParameters& fitted, const ErrorReport& report);

// How differently two calibrations of one camera project, after fitting the small
// rotation between their frames (a calibration fixes the camera frame only up to
// a rotation traded against the principal point), as mrcal.projection_diff does:
// rays of A's pixels (every `step` px), rotated, projected by B.
struct ProjectionDiff {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // A's camera frame -> B's
  long pixels = 0;                                         // compared (valid in both and inside B's image)
  double rms_px = 0, max_px = 0;
};
struct ProjectionDiffOptions {
  int step = 8;
  bool fit_rotation = true;
  // Compare (and fit the rotation on) only A's pixels for which this holds, given the
  // pixel and A's ray: mrcal's region restriction (e.g. where the calibration's
  // corners were). Empty: every pixel valid in both.
  std::function<bool(const Eigen::Vector2d& pixel, const Eigen::Vector3d& ray)> region;
  // Weigh each pixel in the rotation fit by 1 / (sigma_A^2 + sigma_B^2), the two
  // cameras' projection uncertainties at infinity (fishcam/fit/calibration.hpp): where a
  // calibration is unsure, its difference counts less. Both need a covariance.
  bool weigh_by_uncertainty = false;
};
ProjectionDiff projection_diff(const Camera& a, const Camera& b, const ProjectionDiffOptions& options);
ProjectionDiff projection_diff(const Camera& a, const Camera& b, int step = 8, bool fit_rotation = true);

}  // namespace fishcam
