#pragma once

#include "fishcam/core/models/model_base.hpp"
#include "fishcam/core/models/pinhole.hpp"

namespace fishcam {

// OpenCV's pinhole model with its rational radial distortion (cv::projectPoints'
// k1..k6; mrcal's LENSMODEL_OPENCV4/5/8 without the tangential terms): with
// r = tan(theta) and s = r^2,
//   rho = f r (1 + k1 s + k2 s^2 + k3 s^3) / (1 + k4 s + k5 s^2 + k6 s^3).
// Parameters f, k1, k2, k3, k4, k5, k6 (OpenCV's fx, fy map to f = fx, a_y = fy / fx).
// Valid: theta < pi/2 and below the first pole of the denominator (open), up to the
// first fold (found by compute_domain's scan, closed there).
template <typename Scalar>
class OpenCV {
 public:
  static constexpr std::string_view kName = "opencv";
  static constexpr std::array<std::string_view, 7> kParamNames{"f", "k1", "k2", "k3", "k4", "k5", "k6"};

  OpenCV() = default;
  explicit OpenCV(const Scalar* p, int = 7) : p_{p[0], p[1], p[2], p[3], p[4], p[5], p[6]} {}
  OpenCV(Scalar f, Scalar k1, Scalar k2, Scalar k3, Scalar k4 = Scalar(0), Scalar k5 = Scalar(0), Scalar k6 = Scalar(0))
      : p_{f, k1, k2, k3, k4, k5, k6} {}

  std::string invalid() const { return ""; }
  // The radial distortion factor N(s) / D(s) of the undistorted radius r = tan(theta).
  Scalar distortion(const Scalar& s) const {
    return (Scalar(1) + s * (p_[1] + s * (p_[2] + s * p_[3]))) / (Scalar(1) + s * (p_[4] + s * (p_[5] + s * p_[6])));
  }
  Scalar rho(const Scalar& theta) const {
    using std::tan;
    const Scalar r = tan(theta);
    return p_[0] * r * distortion(r * r);
  }
  Scalar rho(const Scalar& theta, Scalar* drho) const {
    using std::tan;
    const Scalar r = tan(theta), s = r * r;
    const Scalar n = Scalar(1) + s * (p_[1] + s * (p_[2] + s * p_[3]));
    const Scalar d = Scalar(1) + s * (p_[4] + s * (p_[5] + s * p_[6]));
    const Scalar dn = p_[1] + s * (Scalar(2) * p_[2] + s * Scalar(3) * p_[3]);
    const Scalar dd = p_[4] + s * (Scalar(2) * p_[5] + s * Scalar(3) * p_[6]);
    // d/dtheta [r n / d] = (1 + s) [n / d + 2 s (n' d - n d') / d^2]
    *drho = p_[0] * (Scalar(1) + s) * (n / d + Scalar(2) * s * (dn * d - n * dd) / (d * d));
    return p_[0] * r * n / d;
  }
  Scalar drho(const Scalar& theta) const {
    Scalar d;
    rho(theta, &d);
    return d;
  }
  double theta_limit() const {
    // Poles in s = tan^2(theta) up to 1e12 (theta = 90 - 6e-5 degrees).
    const double d[4] = {1, double(p_[4]), double(p_[5]), double(p_[6])};
    const std::optional<double> pole = first_positive_root(d, 1e12);
    return pole ? std::atan(std::sqrt(*pole)) : std::numbers::pi / 2;
  }
  static constexpr bool limit_is_open() { return true; }
  OpenCV scaled(const Scalar& s) const {
    OpenCV out = *this;
    out.p_[0] = out.p_[0] * s;
    return out;
  }
  std::vector<Scalar> params() const { return {p_[0], p_[1], p_[2], p_[3], p_[4], p_[5], p_[6]}; }
  UnifiedForm unified_form() const {
    return {double(p_[0]), 0, 0, 1, double(p_[1]), double(p_[2]), double(p_[3]), double(p_[4]), double(p_[5]),
            double(p_[6])};
  }

  // The undistorted plane m = (X, Y) / Z (fishcam/core/tangential.hpp): R = N / D.
  static constexpr bool kTakesTangentialTerms = true;
  // m and the focal length for a camera-frame point, generic in the scalar type (a
  // calibration solving tangential terms differentiates them).
  Scalar plane_point(const Scalar* point, Scalar* m) const {
    m[0] = point[0] / point[2], m[1] = point[1] / point[2];
    return p_[0];
  }
  double focal() const { return double(p_[0]); }
  static double plane_radius(double theta, double* derivative) {
    return Pinhole<double>::plane_radius(theta, derivative);
  }
  static double theta_of_plane_radius(double r) { return std::atan(r); }
  double radial_factor(double s, double* derivative) const {
    const double k[7] = {double(p_[0]), double(p_[1]), double(p_[2]), double(p_[3]),
                         double(p_[4]), double(p_[5]), double(p_[6])};
    const double n = 1 + s * (k[1] + s * (k[2] + s * k[3])), d = 1 + s * (k[4] + s * (k[5] + s * k[6]));
    const double dn = k[1] + s * (2 * k[2] + s * 3 * k[3]), dd = k[4] + s * (2 * k[5] + s * 3 * k[6]);
    *derivative = (dn * d - n * dd) / (d * d);
    return n / d;
  }

  static std::vector<double> initial_params(double f, int) { return {f, 0, 0, 0, 0, 0, 0}; }
  static std::vector<std::vector<double>> fit_starts(double f) { return {{f, 0, 0, 0, 0, 0, 0}}; }
  static std::pair<double, double> param_bounds(int i) {
    if (i == 0) return {0.0, detail::kInf};
    return {-detail::kInf, detail::kInf};
  }

 private:
  Scalar p_[7]{Scalar(1), Scalar(0), Scalar(0), Scalar(0), Scalar(0), Scalar(0), Scalar(0)};
};

}  // namespace fishcam
