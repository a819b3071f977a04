// The pixel grid, the last part of a camera's chain (docs/architecture.md, "A camera
// is a chain of parts"): where the image offset q -- rho(theta) along the ray's
// azimuth, plus any plane distortion -- lands in the image,
//   pixel = c + a (.) (S q),   S = [1 xy; yx 1],   det S = 1 - xy yx > 0,
// with c the principal point, a the pixel scale (a_x, a_y; the paper's eq. 5) and S
// the skew (OCamCalib's affine c, d, e; the skew of BoofCV and of Bouguet's toolbox,
// alpha_c = xy). S = 1 for the usual grid. A negative a_x (a_y) mirrors the grid: the
// camera of a horizontally (vertically) flipped image (mirrored()).
#pragma once

#include <Eigen/Core>
#include <array>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace fishcam {

struct PixelSkew {
  double xy = 0, yx = 0;
  bool any() const { return xy != 0 || yx != 0; }
  Eigen::Matrix2d matrix() const { return (Eigen::Matrix2d() << 1, xy, yx, 1).finished(); }
  bool operator==(const PixelSkew&) const = default;
};

struct PixelGrid {
  static constexpr std::string_view kName = "pixel_grid";

  Eigen::Vector2d principal_point = Eigen::Vector2d::Zero();  // c = (cx, cy), pixels
  Eigen::Vector2d pixel_scale = Eigen::Vector2d::Ones();      // a = (a_x, a_y)
  PixelSkew skew;                                             // zero: the usual grid

  // Its numbers, in this order: cx, cy, a_x, a_y, skew_xy, skew_yx.
  static const std::vector<std::string>& parameter_names();
  std::vector<double> values() const;
  // The grid of values(); throws Error unless there are 6 numbers.
  static PixelGrid from_numbers(std::span<const double> values);
  // "" for a grid a camera can have; otherwise what is wrong, naming the field
  // (non-finite numbers, a_x or a_y zero, a skew that turns the grid over).
  std::string invalid() const;

  // (cx, cy, a_x, a_y), what the projection kernels take (project_radial's pixel_mapping).
  std::array<double, 4> mapping() const {
    return {principal_point.x(), principal_point.y(), pixel_scale.x(), pixel_scale.y()};
  }
  // The pixel of image offset q, and d pixel / d q on request.
  Eigen::Vector2d pixel(const Eigen::Vector2d& q, Eigen::Matrix2d* jacobian = nullptr) const;
  // S q of a pixel: ((u - cx) / a_x, (v - cy) / a_y), what unprojection starts from.
  Eigen::Vector2d skewed_offset(const Eigen::Vector2d& pixel) const {
    return {(pixel.x() - principal_point.x()) / pixel_scale.x(), (pixel.y() - principal_point.y()) / pixel_scale.y()};
  }
  // q from S q (the identity without skew).
  Eigen::Vector2d unskewed(const Eigen::Vector2d& skewed) const;

  // The grid for the image resized by s per axis (new size / old size), pixel centres
  // at integer coordinates: c' = (c + 0.5) s - 0.5, a' = a s, exactly; S unchanged.
  PixelGrid resized(const Eigen::Vector2d& s) const;
  // The grid for the image cropped at (left, top): c' = c - (left, top).
  PixelGrid cropped(int left, int top) const;
  // The grid for the image flipped left-right (horizontal: pixel u -> width - 1 - u)
  // and/or upside down (vertical: v -> height - 1 - v): c'x = width - 1 - cx and
  // a'x = -a_x (likewise y), exactly; S unchanged. Flipping twice gives the grid back.
  PixelGrid mirrored(int width, int height, bool horizontal, bool vertical) const;
  // Whether the grid is mirrored (a_x or a_y < 0).
  bool is_mirrored() const { return pixel_scale.x() < 0 || pixel_scale.y() < 0; }

  bool operator==(const PixelGrid&) const = default;
};

}  // namespace fishcam
