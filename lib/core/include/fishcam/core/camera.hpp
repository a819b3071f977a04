// A fisheye camera: imager size, principal point, per-axis pixel scale (the
// paper's eq. 5), a radial model rho(theta) and an optional pose.
// Conventions (docs/conventions.md): pixel centres at integer coordinates, (0, 0)
// the centre of the top-left pixel; camera frame x right, y down, z forward;
//   theta = atan2(sqrt(X^2 + Y^2), Z),  u = cx + a_x rho(theta) X / chi,  v = cy + a_y rho(theta) Y / chi.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "fishcam/core/error.hpp"
#include "fishcam/core/model_registry.hpp"
#include "fishcam/core/pixel_grid.hpp"
#include "fishcam/core/plane_distortion.hpp"
#include "fishcam/core/radial_inverse.hpp"
#include "fishcam/core/radial_models.hpp"

namespace fishcam {

// Projection of one point through a model, generic in the scalar type (usable by
// ceres::AutoDiffCostFunction). pixel_mapping = (cx, cy, a_x, a_y). Returns theta;
// the caller decides validity from it. On the optical axis rho/chi is replaced by
// its limit rho'(0)/Z, so Jets get the right first-order derivatives there.
template <class Model, typename T>
T project_radial(const Model& model, const T* pixel_mapping, const T* point, T* pixel) {
  using std::atan2;
  using std::sqrt;
  const T chi2 = point[0] * point[0] + point[1] * point[1];
  T theta, scale;  // scale = rho(theta) / chi
  if (chi2 == T(0)) {
    theta = point[2] > T(0) ? T(0) : T(std::numbers::pi);
    scale = model.drho(T(0)) / point[2];
  } else {
    const T chi = sqrt(chi2);
    theta = atan2(chi, point[2]);
    scale = model.rho(theta) / chi;
  }
  pixel[0] = pixel_mapping[0] + pixel_mapping[2] * scale * point[0];
  pixel[1] = pixel_mapping[1] + pixel_mapping[3] * scale * point[1];
  return theta;
}

// Rigid transform camera -> reference: p_ref = rotation * p_cam + translation.
struct Pose {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};
// a after b: p -> a(b(p)).
Pose compose(const Pose& a, const Pose& b);
Pose inverse(const Pose& pose);

// What a calibration learnt from its data, kept with the camera it produced:
// fishcam JSON holds it, other formats cannot (writing to them drops it, and the
// tools say so). fishcam/fit/calibration.hpp computes it and the projection
// uncertainty from it.
// Incidence angles by azimuth: 24 sectors of 15 degrees, azimuth atan2(y, x) in the
// camera frame, sector k covering [-180 + 15 k, -165 + 15 k) degrees.
inline constexpr int kAzimuthSectors = 24;
using AzimuthSectors = std::array<double, kAzimuthSectors>;
int azimuth_sector(double azimuth);
// The angle next to an azimuth: the larger of the two sectors that meet nearest it
// (the sector holding it and its nearer neighbour), NaN ones skipped (NaN when both
// are). A step function that changes at sector centres, so an angle seen anywhere
// in a sector holds up to the middle of each neighbour: the smoothing `info`'s
// field of view, CalibrationRecord::observed and the per-azimuth limit share.
double angle_near_azimuth(const AzimuthSectors& sectors, double azimuth);

struct CalibrationRecord {
  static constexpr int kAzimuthSectors = fishcam::kAzimuthSectors;
  // Incidence angle theta (radians) of the corners the solve used: the largest, and
  // the largest per azimuth sector -- azimuth atan2(y, x) in the camera frame,
  // sector k covering [-180 + 15 k, -165 + 15 k) degrees; NaN where no corner fell.
  double theta_max = 0;
  AzimuthSectors theta_max_by_azimuth{};
  // Covariance of (model parameters, the plane distortion's numbers (a tangential
  // camera's six terms), cx, cy, a_y, then the mean motion of the board
  // frames relative to the camera: rotation vector (3, radians) and translation (3,
  // board units)), scaled by the solve's residual variance; empty when not known.
  Eigen::MatrixXd covariance;
  // The most rows a covariance may have (a file's is refused past it, and a calibration
  // with more parameters): an mrcal spline of up to ~590 knots (mrcal's documented
  // 30 x 18 has 540).
  static constexpr int kMaxCovarianceRows = 1200;

  // No corner yet (every sector NaN); observe() each corner's camera-frame point.
  static CalibrationRecord nothing_observed();
  void observe(const Eigen::Vector3d& point);
  // Whether a camera-frame direction is inside the observed range: theta at most
  // the observed angle next to its azimuth (angle_near_azimuth).
  bool observed(const Eigen::Vector3d& ray) const;
};

struct CameraParameters {
  int width = 0;
  int height = 0;
  // The camera's parts, from the ray to the pixel: the radial model rho(theta), a
  // displacement of its undistorted plane (fishcam/core/plane_distortion.hpp: none,
  // OpenCV's tangential terms, an mrcal lens; NoPlaneDistortion for a radial camera),
  // the pixel grid (principal point, pixel scale, skew: fishcam/core/pixel_grid.hpp).
  RadialModel model;
  PlaneDistortion distortion;
  PixelGrid grid;
  std::optional<double> theta_limit;  // radians; a user cap on the valid domain
  // A user cap that varies with azimuth (radians per sector, each in [0, pi], read
  // with angle_near_azimuth): what limited_to_observed sets from the angles a
  // calibration observed. project/unproject refuse directions past it; the valid
  // domain (a disk) ends at theta_limit, which limited_to_observed sets to its largest.
  std::optional<AzimuthSectors> theta_limit_by_azimuth;
  std::optional<Pose> pose;
  std::optional<CalibrationRecord> calibration;

  // No plane distortion, no skew: rho(theta) is the whole projection.
  bool radially_symmetric() const { return !displaces(distortion) && !grid.skew.any(); }
  // The tangential terms of a TangentialDistortion (all zero for any other part).
  TangentialTerms tangential_terms() const;
  // The lens of an MrcalLensDistortion (null for any other part).
  const MrcalLens* mrcal_lens() const;
};

// The same lens for the image resized to width x height: with pixel centres at
// integer coordinates, c' = (c + 0.5) s - 0.5 and a' = a s per axis (s = new / old
// size), exactly; model, user limit and pose unchanged, the calibration record's
// covariance re-expressed for the new cx, cy, a_y. Throws Error for sizes < 1.
CameraParameters resized(const CameraParameters& camera, int width, int height);

// The same lens for the image cropped to the width x height window whose top-left
// pixel is (left, top) of this image (a window past the image's edges is what a padded
// crop gives): c' = c - (left, top); model, pixel scale, user limit, pose and
// calibration record unchanged (a shift does not change their uncertainty). Throws
// Error for sizes < 1.
CameraParameters cropped(const CameraParameters& camera, int left, int top, int width, int height);

// The same lens for the image flipped left-right (horizontal) and/or upside down
// (vertical): the pixel grid mirrored (PixelGrid::mirrored: the camera projects every
// point where the flipped image shows it); model, user limit, pose and the observed
// angles unchanged (they are of the camera frame), the calibration record's
// covariance re-expressed for the mirrored cx, cy, a_y.
CameraParameters mirrored(const CameraParameters& camera, bool horizontal, bool vertical);

// The camera with its valid domain capped at the incidence angles its calibration
// observed plus margin (radians, >= 0), per azimuth (theta_limit_by_azimuth: the
// observed angle next to each azimuth; margin alone where no corner fell) and overall
// (theta_limit: the largest), so unprojection and augmentation stop where the
// calibration stops knowing. An earlier limit is kept where it is smaller. Throws
// Error when the camera carries no calibration record.
CameraParameters limited_to_observed(CameraParameters camera, double margin);

// Which theta(rho) a batch unprojection uses.
enum class InversePath {
  robust,  // bracketed Newton per point: |rho(theta) - rho| <= 1e-10 px
  table,   // the camera's inverse table (robust solver in cells next to a fold)
};

class Camera {
 public:
  // Validates the parameters and computes the valid domain and the inverse table.
  // Throws Error naming the offending parameter.
  explicit Camera(CameraParameters parameters, double table_tolerance_px = InverseTable::kDefaultTolerancePx);

  const CameraParameters& parameters() const { return params_; }
  // The same camera with another pose (the pose is not part of the projection:
  // the domain and the inverse table are kept, not recomputed).
  Camera with_pose(std::optional<Pose> pose) const {
    Camera moved = *this;
    moved.params_.pose = std::move(pose);
    return moved;
  }
  int width() const { return params_.width; }
  int height() const { return params_.height; }
  const Eigen::Vector2d& principal_point() const { return params_.grid.principal_point; }
  const Eigen::Vector2d& pixel_scale() const { return params_.grid.pixel_scale; }
  const RadialModel& model() const { return params_.model; }
  const PlaneDistortion& distortion() const { return params_.distortion; }
  const PixelSkew& skew() const { return params_.grid.skew; }
  // Whether the camera is radially symmetric (no plane distortion, no skew): only then do
  // rho, theta_from_rho and rho_of_pixel describe its whole projection.
  bool radial() const { return params_.radially_symmetric(); }
  const ValidDomain& domain() const { return domain_; }
  const InverseTable& inverse_table() const { return *table_; }

  // The radial model (for a camera with a plane distortion, its radial part).
  double rho(double theta) const;
  double drho(double theta) const;
  // The unique theta in the valid domain with rho(theta) = rho (robust solver or
  // closed form); NaN when rho is outside [0, rho_max] or NaN.
  double theta_from_rho(double rho) const;
  // Same through the bulk path (inverse table); error <= inverse_table().worst_error_px().
  double theta_from_rho_table(double rho) const;
  // rho of a pixel: the radius of ((u - cx) / a_x, (v - cy) / a_y).
  double rho_of_pixel(const Eigen::Vector2d& pixel) const;

  // Projects a camera-frame point. False (and NaN pixel) when the point is the
  // origin, non-finite, outside the valid domain, or on the -z axis (the pixel
  // direction is undefined there). The Jacobian d pixel / d point on request.
  bool project(const Eigen::Vector3d& point, Eigen::Vector2d* pixel,
               Eigen::Matrix<double, 2, 3>* jacobian = nullptr) const;
  // Unit ray of a pixel. False (and NaN ray) when rho is outside the valid domain.
  bool unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d* ray) const;

  // Batches: model dispatch once per batch, multithreaded. valid may be empty;
  // otherwise it must have the size of the input (1 = valid).
  void project(std::span<const Eigen::Vector3d> points, std::span<Eigen::Vector2d> pixels,
               std::span<std::uint8_t> valid = {}) const;
  void unproject(std::span<const Eigen::Vector2d> pixels, std::span<Eigen::Vector3d> rays,
                 std::span<std::uint8_t> valid = {}, InversePath path = InversePath::robust) const;
  // Unit rays of every pixel centre, row-major, W*H*3 floats (x, y, z); NaN where invalid.
  void unproject_image(std::span<float> rays_xyz, InversePath path = InversePath::table) const;
  // The same as three planes (x, y and z of every pixel centre, row-major), each of
  // at least W*H floats; what lies past W*H is left as it is.
  void unproject_image(std::span<float> x, std::span<float> y, std::span<float> z,
                       InversePath path = InversePath::table) const;

  // Angular coverage of the image (degrees) through the principal point: theta of
  // the two opposite image borders added (borders at -0.5 and W - 0.5 / H - 0.5),
  // each capped at theta_max when the border is outside the valid domain.
  struct FieldOfView {
    double horizontal, vertical, diagonal;
  };
  FieldOfView field_of_view_deg() const;

 private:
  void limit_to_plane_fold();  // validates the non-radial part, lowers domain_ to where it stays one-to-one
  void bound_plane_reach();    // domain_.plane_reach
  CameraParameters params_;
  ValidDomain domain_;
  // Shared by the copies with_pose makes (an augmented camera per sample): the
  // table depends on the model and the domain only.
  std::shared_ptr<const InverseTable> table_;
};

}  // namespace fishcam
