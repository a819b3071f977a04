// The non-radial part of OpenCV's distortion (tangential p1, p2 and thin-prism
// s1..s4), added on a model's undistorted plane. For the models that have one
// (HasUndistortedPlane in models/model_base.hpp: pinhole and opencv with m = (X, Y) / Z,
// mei with m = (X, Y) / (Z + xi |P|)) a camera projects
//   pixel = c + a (.) f (m R(|m|^2) + T(m)),
// where f R(|m|^2) |m| = rho(theta) is the radial model and, with r2 = |m|^2,
//   T_x = 2 p1 x y + p2 (r2 + 2 x^2) + s1 r2 + s2 r2^2,
//   T_y = p1 (r2 + 2 y^2) + 2 p2 x y + s3 r2 + s4 r2^2
// (cv::projectPoints, camodocal MEI, Kalibr radtan, mrcal LENSMODEL_OPENCVn).
// Terms all zero: the camera is radial.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string_view>

namespace fishcam {

struct TangentialTerms {
  static constexpr std::array<std::string_view, 6> kNames{"p1", "p2", "s1", "s2", "s3", "s4"};
  double p1 = 0, p2 = 0;
  std::array<double, 4> s{};  // thin prism s1..s4

  bool any() const { return p1 != 0 || p2 != 0 || s[0] != 0 || s[1] != 0 || s[2] != 0 || s[3] != 0; }
  bool any_thin_prism() const { return s[0] != 0 || s[1] != 0 || s[2] != 0 || s[3] != 0; }
  std::array<double, 6> values() const { return {p1, p2, s[0], s[1], s[2], s[3]}; }
  static TangentialTerms from_values(const std::array<double, 6>& v) { return {v[0], v[1], {v[2], v[3], v[4], v[5]}}; }
  bool operator==(const TangentialTerms&) const = default;

  // T(m) for the terms v = (p1, p2, s1..s4) (the first `count`, the rest zero), generic
  // in the scalar type: what a calibration solving the terms differentiates.
  template <typename T>
  static void offset_of(const T* v, int count, const T& x, const T& y, T* out) {
    const auto term = [&](int i) { return i < count ? v[i] : T(0); };
    const T r2 = x * x + y * y;
    out[0] = T(2) * term(0) * x * y + term(1) * (r2 + T(2) * x * x) + (term(2) + term(3) * r2) * r2;
    out[1] = term(0) * (r2 + T(2) * y * y) + T(2) * term(1) * x * y + (term(4) + term(5) * r2) * r2;
  }

  // T(m), with dT/dm on request.
  Eigen::Vector2d offset(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian = nullptr) const {
    const double x = m.x(), y = m.y(), r2 = x * x + y * y;
    if (jacobian) {
      const double prism_x = 2 * s[0] + 4 * s[1] * r2, prism_y = 2 * s[2] + 4 * s[3] * r2;
      *jacobian << 2 * p1 * y + 6 * p2 * x + prism_x * x, 2 * p1 * x + 2 * p2 * y + prism_x * y,
          2 * p1 * x + 2 * p2 * y + prism_y * x, 6 * p1 * y + 2 * p2 * x + prism_y * y;
    }
    const std::array<double, 6> v = values();
    Eigen::Vector2d out;
    offset_of(v.data(), 6, x, y, out.data());
    return out;
  }
};

}  // namespace fishcam
