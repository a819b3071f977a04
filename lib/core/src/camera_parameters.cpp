#include "fail.hpp"
#include "fishcam/core/camera.hpp"
#include "fishcam/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

// Operations on a camera's parameters: resized and cropped images, poses, the
// calibration record's observed angles.

namespace fishcam {
namespace {

using detail::fail;

}  // namespace

TangentialTerms CameraParameters::tangential_terms() const {
  const auto* part = std::get_if<TangentialDistortion>(&distortion);
  return part ? part->terms : TangentialTerms{};
}

const MrcalLens* CameraParameters::mrcal_lens() const {
  const auto* part = std::get_if<MrcalLensDistortion>(&distortion);
  return part ? part->lens.get() : nullptr;
}

CameraParameters resized(const CameraParameters& camera, int width, int height) {
  if (width < 1 || height < 1) fail("resized: width and height must be >= 1, got ", width, "x", height);
  const Eigen::Vector2d s(double(width) / camera.width, double(height) / camera.height);
  CameraParameters out = camera;
  out.width = width, out.height = height;
  out.grid = camera.grid.resized(s);
  if (out.calibration && out.calibration->covariance.size() > 0) {
    // d cx' = s_x d cx, d cy' = s_y d cy, d a_y' = s_y d a_y; nothing else changes.
    Eigen::MatrixXd& c = out.calibration->covariance;
    const Eigen::Index n = c.rows() - 9;
    const double scale[3] = {s.x(), s.y(), s.y()};
    for (int k = 0; k < 3; ++k) c.row(n + k) *= scale[k], c.col(n + k) *= scale[k];
  }
  return out;
}

CameraParameters cropped(const CameraParameters& camera, int left, int top, int width, int height) {
  if (width < 1 || height < 1) fail("cropped: width and height must be >= 1, got ", width, "x", height);
  CameraParameters out = camera;
  out.width = width, out.height = height;
  out.grid = camera.grid.cropped(left, top);
  return out;
}

CameraParameters mirrored(const CameraParameters& camera, bool horizontal, bool vertical) {
  CameraParameters out = camera;
  out.grid = camera.grid.mirrored(camera.width, camera.height, horizontal, vertical);
  if (out.calibration && out.calibration->covariance.size() > 0) {
    // d cx' = -d cx (horizontal), d cy' = -d cy and d a_y' = -d a_y (vertical).
    Eigen::MatrixXd& c = out.calibration->covariance;
    const Eigen::Index n = c.rows() - 9;
    const bool flips[3] = {horizontal, vertical, vertical};
    for (int k = 0; k < 3; ++k) {
      if (flips[k]) c.row(n + k) *= -1, c.col(n + k) *= -1;
    }
  }
  return out;
}

Pose compose(const Pose& a, const Pose& b) {
  return Pose{(a.rotation * b.rotation).normalized(), a.rotation * b.translation + a.translation};
}

Pose inverse(const Pose& pose) {
  const Eigen::Quaterniond r = pose.rotation.conjugate();
  return Pose{r, -(r * pose.translation)};
}

int azimuth_sector(double azimuth) {
  const double turn = 2 * std::numbers::pi;
  const int k = int(std::floor((azimuth + std::numbers::pi) / turn * kAzimuthSectors));
  return std::clamp(k, 0, kAzimuthSectors - 1);
}

double angle_near_azimuth(const AzimuthSectors& sectors, double azimuth) {
  constexpr double kStep = 2 * std::numbers::pi / kAzimuthSectors;
  const int k = azimuth_sector(azimuth);
  // The nearer neighbour: the one before in the sector's first half, else the one after.
  const double start = -std::numbers::pi + k * kStep;
  const int neighbour = (azimuth - start < kStep / 2 ? k + kAzimuthSectors - 1 : k + 1) % kAzimuthSectors;
  const double a = sectors[size_t(k)], b = sectors[size_t(neighbour)];
  return std::isnan(a) ? b : std::isnan(b) ? a : std::max(a, b);
}

CameraParameters limited_to_observed(CameraParameters camera, double margin) {
  if (!camera.calibration) {
    fail(
        "theta limit 'data': the camera carries no calibration record (fishcam calibrate writes one into fishcam "
        "JSON)");
  }
  if (!(margin >= 0 && margin < std::numbers::pi))
    fail("theta limit 'data+DEG': the margin must be in [0, 180) degrees");
  AzimuthSectors limit{};
  for (size_t k = 0; k < limit.size(); ++k) {
    const double observed = camera.calibration->theta_max_by_azimuth[k];
    limit[k] = std::min((std::isnan(observed) ? 0.0 : observed) + margin, std::numbers::pi);
    if (camera.theta_limit) limit[k] = std::min(limit[k], *camera.theta_limit);
    if (camera.theta_limit_by_azimuth) limit[k] = std::min(limit[k], (*camera.theta_limit_by_azimuth)[k]);
  }
  camera.theta_limit = *std::max_element(limit.begin(), limit.end());
  camera.theta_limit_by_azimuth = limit;
  return camera;
}

CalibrationRecord CalibrationRecord::nothing_observed() {
  CalibrationRecord r;
  r.theta_max_by_azimuth.fill(std::numeric_limits<double>::quiet_NaN());
  return r;
}

void CalibrationRecord::observe(const Eigen::Vector3d& point) {
  const double theta = std::atan2(point.head<2>().norm(), point.z());
  double& sector = theta_max_by_azimuth[size_t(azimuth_sector(std::atan2(point.y(), point.x())))];
  if (!(sector >= theta)) sector = theta;  // NaN: the sector's first corner
  theta_max = std::max(theta_max, theta);
}

bool CalibrationRecord::observed(const Eigen::Vector3d& ray) const {
  const double theta = std::atan2(ray.head<2>().norm(), ray.z());
  return theta <= angle_near_azimuth(theta_max_by_azimuth, std::atan2(ray.y(), ray.x()));  // false for NaN
}

}  // namespace fishcam
