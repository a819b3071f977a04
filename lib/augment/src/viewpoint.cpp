#include "fishcam/augment/viewpoint.hpp"

#include "fishcam/core/error.hpp"

#include <cmath>
#include <numbers>
#include <random>

namespace fishcam {
namespace {

constexpr double kRad = std::numbers::pi / 180;

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace

std::string_view to_string(DepthPrior prior) {
  switch (prior) {
    case DepthPrior::source_sphere:
      return "source-sphere";
    case DepthPrior::target_sphere:
      return "target-sphere";
    case DepthPrior::infinity:
      return "infinity";
  }
  return "?";
}

namespace {
constexpr DepthPrior kDepthPriors[] = {DepthPrior::source_sphere, DepthPrior::target_sphere, DepthPrior::infinity};

}  // namespace

std::optional<DepthPrior> parse_depth_prior(std::string_view name) {
  for (auto p : kDepthPriors) {
    if (name == to_string(p)) return p;
  }
  return std::nullopt;
}

const std::vector<std::string>& depth_prior_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (auto p : kDepthPriors) out.emplace_back(to_string(p));
    return out;
  }();
  return names;
}

const std::vector<std::string>& depth_prior_and_map_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out = depth_prior_names();
    out.emplace_back(kDepthMapName);
    return out;
  }();
  return names;
}

DepthPrior depth_prior(std::string_view name, std::string_view what) {
  if (const auto prior = parse_depth_prior(name)) return *prior;
  throw Error(std::string(what) + ": expected " + choices_for_message(depth_prior_names()) + ", got " +
              quoted_for_message(name));
}

const std::vector<std::string>& pose_preset_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& p : pose_presets()) out.emplace_back(p.name);
    return out;
  }();
  return names;
}

PosePreset pose_preset(std::string_view name, std::string_view what) {
  if (const auto preset = find_pose_preset(name)) return *preset;
  throw Error(std::string(what) + ": unknown preset " + quoted_for_message(name) + " (expected " +
              choices_for_message(pose_preset_names()) + ")");
}

RigidMotion RigidMotion::from_euler_deg(const Eigen::Vector3d& d, const Eigen::Vector3d& translation) {
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(d.z() * kRad, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(d.y() * kRad, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(d.x() * kRad, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  return {r, translation};
}

RigidMotion RigidMotion::from_rodrigues(const Eigen::Vector3d& r, const Eigen::Vector3d& translation) {
  const double angle = r.norm();
  if (angle == 0) return {Eigen::Matrix3d::Identity(), translation};
  return {Eigen::AngleAxisd(angle, r / angle).toRotationMatrix(), translation};
}

RigidMotion RigidMotion::from_quaternion(const Eigen::Quaterniond& q, const Eigen::Vector3d& translation) {
  return {q.normalized().toRotationMatrix(), translation};
}

Eigen::Vector3d RigidMotion::euler_deg() const {
  // R = Rz(c) Ry(b) Rx(a): R(2,0) = -sin b, R(2,1) = cos b sin a, R(1,0) = sin c cos b.
  const Eigen::Matrix3d& r = rotation;
  const double b = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  double a, c;
  if (std::abs(r(2, 0)) < 1 - 1e-12) {
    a = std::atan2(r(2, 1), r(2, 2));
    c = std::atan2(r(1, 0), r(0, 0));
  } else {  // gimbal lock: only a - c (or a + c) is defined; put it all in a
    a = std::atan2(-r(1, 2), r(1, 1));
    c = 0;
  }
  return Eigen::Vector3d(a, b, c) / kRad;
}

RigidMotion RigidMotion::inverse() const { return {rotation.transpose(), -(rotation.transpose() * translation)}; }

Pose moved_camera(const Pose& camera_to_reference, const RigidMotion& change) {
  // p_new = R p_cam + t  =>  p_reference = R_vc R^T p_new + (t_vc - R_vc R^T t).
  const Eigen::Matrix3d r = camera_to_reference.rotation.toRotationMatrix() * change.rotation.transpose();
  Pose moved;
  moved.rotation = Eigen::Quaterniond(r).normalized();
  moved.translation = camera_to_reference.translation - r * change.translation;
  return moved;
}

// The virtual camera sees other rays than the calibrated one did: the calibration
// record (observed angles, covariance) does not carry over.
CameraParameters augmented_camera(CameraParameters camera, const RigidMotion& change) {
  camera.pose = moved_camera(camera.pose.value_or(Pose{}), change);
  camera.calibration.reset();
  return camera;
}

Camera augmented_camera(const Camera& camera, const RigidMotion& change) {
  if (camera.parameters().calibration) return Camera(augmented_camera(camera.parameters(), change));
  return camera.with_pose(augmented_camera(camera.parameters(), change).pose);
}

const std::array<PosePreset, 4>& pose_presets() {
  static const std::array<PosePreset, 4> presets = {{
      {"small", 10, 0.1},
      {"medium", 20, 0.3},
      {"large", 30, 0.5},
      {"train", 30, 0.5},
  }};
  return presets;
}

std::optional<PosePreset> find_pose_preset(std::string_view name) {
  for (const auto& p : pose_presets()) {
    if (p.name == name) return p;
  }
  return std::nullopt;
}

ViewpointChange applied_under(ViewpointChange change, DepthPrior prior) {
  if (prior == DepthPrior::infinity) change.translation.setZero();
  return change;
}

ViewpointChange random_change(const PosePreset& preset, std::uint64_t seed) {
  SeededUniform uniform(seed);
  ViewpointChange change;
  for (int i = 0; i < 3; ++i) change.rotation_deg[i] = uniform.symmetric(preset.max_rotation_deg);
  for (int i = 0; i < 3; ++i) change.translation[i] = uniform.symmetric(preset.max_translation);
  return change;
}

std::uint64_t derive_seed(std::uint64_t seed, std::string_view key, std::uint64_t index) {
  std::uint64_t h = 0xCBF29CE484222325ull;  // FNV-1a
  for (unsigned char c : key) h = (h ^ c) * 0x100000001B3ull;
  return splitmix64(splitmix64(seed ^ h) + index);
}

void check_change(const RigidMotion& change) {
  if (!change.rotation.allFinite() || !change.translation.allFinite()) {
    throw Error("viewpoint change: rotation and translation must be finite");
  }
  const double orthogonality = (change.rotation.transpose() * change.rotation - Eigen::Matrix3d::Identity()).norm();
  if (!(orthogonality <= 1e-9) || !(change.rotation.determinant() > 0)) {
    throw Error("viewpoint change: rotation must be a rotation matrix (orthonormal, determinant +1)");
  }
}

}  // namespace fishcam
