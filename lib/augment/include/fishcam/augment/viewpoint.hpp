// Viewpoint changes (the paper's eq. 7), depth priors and seeded random poses.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "fishcam/augment/depth_prior.hpp"
#include "fishcam/core/camera.hpp"

namespace fishcam {

// P' = R P + t (eq. 7) as a matrix and a vector: a point P of the source camera
// frame, in the frame of the output camera. The camera appears to move the
// opposite way. What warps apply; a ViewpointChange (below) makes one.
struct RigidMotion {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  // Degrees about the camera x, y, z axes, R = Rz * Ry * Rx (x applied first).
  static RigidMotion from_euler_deg(const Eigen::Vector3d& degrees_xyz,
                                    const Eigen::Vector3d& translation = Eigen::Vector3d::Zero());
  // Rodrigues vector (axis * angle, radians).
  static RigidMotion from_rodrigues(const Eigen::Vector3d& r,
                                    const Eigen::Vector3d& translation = Eigen::Vector3d::Zero());
  static RigidMotion from_quaternion(const Eigen::Quaterniond& q,
                                     const Eigen::Vector3d& translation = Eigen::Vector3d::Zero());
  // The x, y, z angles (degrees) with rotation = Rz * Ry * Rx, y in [-90, 90].
  Eigen::Vector3d euler_deg() const;
  RigidMotion inverse() const;
  bool is_identity() const { return rotation == Eigen::Matrix3d::Identity() && translation.isZero(0); }
};

// Throws Error unless the change is finite and its rotation a rotation matrix
// (what every warp checks before use: a NaN change must not become a black image).
void check_change(const RigidMotion& change);

// The pose (camera -> reference) of the camera that sees P' = R P + t when the
// camera at camera_to_reference sees P: the camera after the viewpoint change
// (t in the reference's units).
Pose moved_camera(const Pose& camera_to_reference, const RigidMotion& change);
// The camera of an augmented image: the same intrinsics, its pose moved by the
// change (a camera without a pose gets one relative to its own frame before the
// change), so that 3-D tasks stay consistent with the image. A calibration record
// is dropped: the virtual camera's pixels see other rays than the calibration did.
CameraParameters augmented_camera(CameraParameters camera, const RigidMotion& change);
// Cheap (no tables rebuilt) unless the camera carries a calibration record.
Camera augmented_camera(const Camera& camera, const RigidMotion& change);

// Uniform, independent ranges per degree of freedom: rotation in
// [-max_rotation_deg, +max_rotation_deg] about each axis, translation in
// [-max_translation, +max_translation] along each axis (unit-sphere units).
struct PosePreset {
  std::string_view name;
  double max_rotation_deg;
  double max_translation;
};
// The paper's: small (10 deg, 0.1), medium (20, 0.3), large (30, 0.5), train (30, 0.5).
const std::array<PosePreset, 4>& pose_presets();
std::optional<PosePreset> find_pose_preset(std::string_view name);
// The presets' names, in the table's order (CLI choices, Python, messages).
const std::vector<std::string>& pose_preset_names();
// The preset called `name`, or Error "WHAT: unknown preset 'NAME' (expected small,
// medium, large or train)".
PosePreset pose_preset(std::string_view name, std::string_view what = "preset");

// A viewpoint change as it is drawn, given and recorded (Python's
// fishcam.ViewpointChange): degrees about x, y, z (R = Rz Ry Rx) and t, kept exactly
// as given so that records print the numbers drawn.
struct ViewpointChange {
  Eigen::Vector3d rotation_deg;  // about x, y, z
  Eigen::Vector3d translation;
  RigidMotion motion() const { return RigidMotion::from_euler_deg(rotation_deg, translation); }
};
// Uniform numbers in [0, 1) reproducible on any platform: std::mt19937_64 (its
// output is fixed by the standard) mapped by our own code, not by a standard
// distribution (whose algorithm the standard leaves open). Every seeded draw uses it.
class SeededUniform {
 public:
  explicit SeededUniform(std::uint64_t seed) : engine_(seed) {}
  double next() { return double(engine_() >> 11) * 0x1.0p-53; }  // 53 random bits
  // Uniform in [-half_range, half_range).
  double symmetric(double half_range) { return (2 * next() - 1) * half_range; }

 private:
  std::mt19937_64 engine_;
};

// Draw order: rx, ry, rz, tx, ty, tz (SeededUniform::symmetric each).
ViewpointChange random_change(const PosePreset& preset, std::uint64_t seed);
// The change `prior` applies of `pose`: the prior at infinity sees rotations only, so
// the translation is dropped -- what the image gets, and so what the moved camera and
// the records say (fishcam.transforms does the same).
ViewpointChange applied_under(ViewpointChange change, DepthPrior prior);
// A seed per (key, index) from one user seed (SplitMix64 over FNV-1a of the key).
std::uint64_t derive_seed(std::uint64_t seed, std::string_view key, std::uint64_t index);

}  // namespace fishcam
