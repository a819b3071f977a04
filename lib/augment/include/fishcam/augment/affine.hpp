// The affine baseline of the paper's §V.C.2: rotation about the image centre,
// translation, isotropic scale, applied to the image as it is (no camera model).
// Resampled like the viewpoint augmentation: the same sampling maps, so
// warp_image / warp_labels give bilinear images, nearest labels and the same fill.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

#include "fishcam/augment/augmentation.hpp"

namespace fishcam {

// Where the content moves: a source pixel x lands at
//   x' = c + scale * R(rotation_deg) * (x - c) + (translation.x * W, translation.y * H)
// with c = ((W - 1) / 2, (H - 1) / 2) the image centre and R a counter-clockwise
// rotation as the image is seen (y pointing down; cv::getRotationMatrix2D's sense).
struct AffineChange {
  double rotation_deg = 0;
  Eigen::Vector2d translation = Eigen::Vector2d::Zero();  // fractions of the image width and height
  double scale = 1;
};

// Throws Error unless every value is finite and the scale positive.
void check_affine(const AffineChange& change);

// Uniform, independent ranges: rotation in [-max_rotation_deg, max_rotation_deg],
// translation in [-max_translation, max_translation] per axis, scale in
// [min_scale, max_scale].
struct AffinePreset {
  std::string_view name;
  double max_rotation_deg;
  double max_translation;
  double min_scale, max_scale;
};
// Named like the viewpoint presets. train and large: the paper's ranges (30 deg,
// 0.3, [0.5, 1.5]); small and medium: those ranges scaled by 1/3 and 2/3 (the
// paper trains with one range only; these are for comparing at matching strength).
const std::array<AffinePreset, 4>& affine_presets();
std::optional<AffinePreset> find_affine_preset(std::string_view name);
// The preset called `name`, or Error "WHAT: unknown preset 'NAME' (expected ...)".
AffinePreset affine_preset(std::string_view name, std::string_view what = "preset");
// Seeded like random_change (SeededUniform); draw order: rotation, tx, ty, scale.
AffineChange random_affine(const AffinePreset& preset, std::uint64_t seed);

// Where the source pixel x lands (the formula above), for points: keypoints,
// polygon vertices, box corners.
Eigen::Vector2d affine_forward(const AffineChange& change, cv::Size size, const Eigen::Vector2d& x);

// Sampling maps (MapKind::sampling) of the change for images of `size`: where a
// pixel's source lies inside the image, its coordinates; elsewhere kOutsideSource.
void affine_maps(const AffineChange& change, cv::Size size, WarpMaps* maps);

// The affine baseline applied as ViewpointWarp::augment applies a viewpoint change:
// io's image bilinear, labels nearest, fills and validity, for images of `size`.
// The one pipeline `fishcam augment --method affine`, augment-dataset and Python use.
void affine_augment(const AffineChange& change, cv::Size size, const AugmentIO& io);

}  // namespace fishcam
