#include "fishcam/core/pixel_grid.hpp"

#include <cmath>
#include <sstream>

#include "fishcam/core/error.hpp"

namespace fishcam {

const std::vector<std::string>& PixelGrid::parameter_names() {
  static const std::vector<std::string> names = {"cx", "cy", "a_x", "a_y", "skew_xy", "skew_yx"};
  return names;
}

std::vector<double> PixelGrid::values() const {
  return {principal_point.x(), principal_point.y(), pixel_scale.x(), pixel_scale.y(), skew.xy, skew.yx};
}

PixelGrid PixelGrid::from_numbers(std::span<const double> values) {
  if (values.size() != parameter_names().size()) {
    throw Error("pixel_grid: expected " + std::to_string(parameter_names().size()) + " numbers, got " +
                std::to_string(values.size()));
  }
  return {{values[0], values[1]}, {values[2], values[3]}, {values[4], values[5]}};
}

std::string PixelGrid::invalid() const {
  std::ostringstream problem;
  if (!principal_point.allFinite()) {
    problem << "principal_point: must be finite";
  } else if (!pixel_scale.allFinite() || !(pixel_scale.cwiseAbs().minCoeff() > 0)) {
    problem << "pixel_scale: a_x and a_y must be finite and non-zero (negative: a mirrored grid), got "
            << pixel_scale.x() << ", " << pixel_scale.y();
  } else if (!std::isfinite(skew.xy) || !std::isfinite(skew.yx)) {
    problem << "skew: xy and yx must be finite";
  } else if (!(1 - skew.xy * skew.yx > 0)) {
    problem << "skew: the pixel grid must keep its orientation (1 - xy yx > 0), got xy " << skew.xy << ", yx "
            << skew.yx;
  }
  return problem.str();
}

Eigen::Vector2d PixelGrid::pixel(const Eigen::Vector2d& q, Eigen::Matrix2d* jacobian) const {
  const Eigen::Matrix2d as = pixel_scale.asDiagonal() * skew.matrix();
  if (jacobian) *jacobian = as;
  return principal_point + as * q;
}

Eigen::Vector2d PixelGrid::unskewed(const Eigen::Vector2d& s) const {
  if (!skew.any()) return s;
  const double det = 1 - skew.xy * skew.yx;
  return {(s.x() - skew.xy * s.y()) / det, (s.y() - skew.yx * s.x()) / det};
}

PixelGrid PixelGrid::resized(const Eigen::Vector2d& s) const {
  PixelGrid out = *this;
  out.principal_point = (principal_point.array() + 0.5) * s.array() - 0.5;
  out.pixel_scale = pixel_scale.cwiseProduct(s);
  return out;
}

PixelGrid PixelGrid::cropped(int left, int top) const {
  PixelGrid out = *this;
  out.principal_point -= Eigen::Vector2d(left, top);
  return out;
}
PixelGrid PixelGrid::mirrored(int width, int height, bool horizontal, bool vertical) const {
  PixelGrid out = *this;
  if (horizontal) out.principal_point.x() = (width - 1) - principal_point.x(), out.pixel_scale.x() *= -1;
  if (vertical) out.principal_point.y() = (height - 1) - principal_point.y(), out.pixel_scale.y() *= -1;
  return out;
}

}  // namespace fishcam
