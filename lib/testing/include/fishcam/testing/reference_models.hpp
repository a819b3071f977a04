// Independent references written from the published formulas, in 3D (no radial
// model, no fishcam code): what the readers' cameras are checked against.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cmath>
#include <vector>

namespace fishcam::test {

struct Intrinsics {
  double fx, fy, cx, cy;
};

// Kannala-Brandt as OpenCV's fisheye model writes it: theta_d = theta (1 + k1 theta^2 + ...).
inline Eigen::Vector2d kannala_brandt(const Intrinsics& k, const std::array<double, 4>& d, const Eigen::Vector3d& p) {
  const double chi = std::hypot(p.x(), p.y()), theta = std::atan2(chi, p.z()), t2 = theta * theta;
  const double theta_d = theta * (1 + t2 * (d[0] + t2 * (d[1] + t2 * (d[2] + t2 * d[3]))));
  const double s = chi > 0 ? theta_d / chi : 1 / p.z();
  return {k.fx * s * p.x() + k.cx, k.fy * s * p.y() + k.cy};
}
// Usenko et al. 2018.
inline Eigen::Vector2d ucm_xi(const Intrinsics& k, double xi, const Eigen::Vector3d& p) {
  const double den = xi * p.norm() + p.z();
  return {k.fx * p.x() / den + k.cx, k.fy * p.y() / den + k.cy};
}
inline Eigen::Vector2d eucm(const Intrinsics& k, double alpha, double beta, const Eigen::Vector3d& p) {
  const double d = std::sqrt(beta * (p.x() * p.x() + p.y() * p.y()) + p.z() * p.z());
  const double den = alpha * d + (1 - alpha) * p.z();
  return {k.fx * p.x() / den + k.cx, k.fy * p.y() / den + k.cy};
}
inline Eigen::Vector2d double_sphere(const Intrinsics& k, double xi, double alpha, const Eigen::Vector3d& p) {
  const double d1 = p.norm(), shifted = xi * d1 + p.z();
  const double d2 = std::sqrt(p.x() * p.x() + p.y() * p.y() + shifted * shifted);
  const double den = alpha * d2 + (1 - alpha) * shifted;
  return {k.fx * p.x() / den + k.cx, k.fy * p.y() / den + k.cy};
}
// Mei & Rives 2007 without tangential terms.
inline Eigen::Vector2d mei(const Intrinsics& k, double xi, double k1, double k2, const Eigen::Vector3d& p) {
  const double den = p.z() + xi * p.norm();
  const double mx = p.x() / den, my = p.y() / den, r2 = mx * mx + my * my;
  const double g = 1 + k1 * r2 + k2 * r2 * r2;
  return {k.fx * mx * g + k.cx, k.fy * my * g + k.cy};
}
// Mei & Rives 2007 with its tangential terms (camodocal MEI, Kalibr omni-radtan):
// the point on the unit sphere, shifted by xi, projected, distorted by k1, k2, p1, p2.
inline Eigen::Vector2d mei_radtan(const Intrinsics& k, double xi, const std::array<double, 4>& d,
                                  const Eigen::Vector3d& p) {
  const Eigen::Vector3d s = p.normalized();
  const double mx = s.x() / (s.z() + xi), my = s.y() / (s.z() + xi);
  const double r2 = mx * mx + my * my, g = 1 + d[0] * r2 + d[1] * r2 * r2;
  const double dx = 2 * d[2] * mx * my + d[3] * (r2 + 2 * mx * mx);
  const double dy = d[2] * (r2 + 2 * my * my) + 2 * d[3] * mx * my;
  return {k.fx * (mx * g + dx) + k.cx, k.fy * (my * g + dy) + k.cy};
}
// valeoai/WoodScape scripts/calibration/projection.py.
inline Eigen::Vector2d woodscape(const std::vector<double>& k, double width, double height, double cx_offset,
                                 double cy_offset, double aspect, const Eigen::Vector3d& p) {
  const double chi = std::hypot(p.x(), p.y()), theta = std::atan2(chi, p.z());
  double rho = 0, power = theta;
  for (double c : k) rho += c * power, power *= theta;
  const double cx = width / 2 + cx_offset - 0.5, cy = height / 2 + cy_offset - 0.5;
  return {cx + rho * p.x() / chi, cy + rho * p.y() / chi * aspect};
}

// OCamCalib (Scaramuzza's ocam_functions.c), in its own frame: a point (x, y, z)
// with x along rows, y along columns, the camera looking along -z; pixels as
// (row, column) from 0. `pol` is a0..aN, `invpol` world2cam's polynomial.
struct OCamCalib {
  std::vector<double> pol, invpol;
  double xc, yc, c, d, e;  // centre (row, column); affine
};
// cam2world: the ray (x, y, pol(rho)) of the pixel (row, column), not normalised.
inline Eigen::Vector3d ocam_cam2world(const OCamCalib& o, double row, double column) {
  const double inv_det = 1 / (o.c - o.d * o.e);
  const double xp = inv_det * ((row - o.xc) - o.d * (column - o.yc));
  const double yp = inv_det * (-o.e * (row - o.xc) + o.c * (column - o.yc));
  const double r = std::hypot(xp, yp);
  double z = 0, power = 1;
  for (double a : o.pol) z += a * power, power *= r;
  return {xp, yp, z};
}
// world2cam with invpol (OCamCalib's fast projection; invpol approximates pol's inverse).
inline Eigen::Vector2d ocam_world2cam(const OCamCalib& o, const Eigen::Vector3d& p) {
  const double norm = std::hypot(p.x(), p.y());
  const double theta = std::atan(p.z() / norm);
  double rho = 0, power = 1;
  for (double a : o.invpol) rho += a * power, power *= theta;
  const double x = p.x() / norm * rho, y = p.y() / norm * rho;
  return {x * o.c + y * o.d + o.xc, x * o.e + y + o.yc};  // (row, column)
}
// world2cam with pol's exact inverse: the rho whose cam2world ray has the point's
// elevation, by bisection on [0, rho_hi] (pol's elevation increasing there).
inline Eigen::Vector2d ocam_world2cam_exact(const OCamCalib& o, const Eigen::Vector3d& p, double rho_hi) {
  const double norm = std::hypot(p.x(), p.y()), elevation = std::atan2(p.z(), norm);
  const auto elevation_of = [&](double r) {
    double z = 0, power = 1;
    for (double a : o.pol) z += a * power, power *= r;
    return std::atan2(z, r);
  };
  double lo = 0, hi = rho_hi;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (elevation_of(mid) > elevation ? hi : lo) = mid;  // the elevation rises from -90 deg as rho grows
  }
  const double rho = 0.5 * (lo + hi), x = p.x() / norm * rho, y = p.y() / norm * rho;
  return {x * o.c + y * o.d + o.xc, x * o.e + y + o.yc};
}

}  // namespace fishcam::test
