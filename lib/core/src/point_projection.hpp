#pragma once
// One point through a camera's parts (the radial model, its plane distortion, its
// pixel skew): projection with its Jacobian, and unprojection. Internal to the core
// layer: camera.cpp's batches and camera_domain.cpp's scans share these templates.

#include "fishcam/core/camera.hpp"
#include "fishcam/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <type_traits>
#include <utility>
#include <variant>

namespace fishcam::detail {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kDeg = 180 / std::numbers::pi;

// Projection of one point through a concrete model, with the analytic Jacobian
// when requested (compiled away otherwise).
template <bool kWithJacobian, class Model>
bool project_one(const Model& model, const double* mapping, const ValidDomain& domain, const Eigen::Vector3d& point,
                 Eigen::Vector2d* pixel, Eigen::Matrix<double, 2, 3>* jacobian) {
  // Only the direction matters: a point whose squares would overflow (1e160) or
  // underflow (1e-170) is scaled by a power of two (exact) to magnitude ~1 first;
  // ordinary points skip that (one comparison on the hot path).
  const double magnitude = point.cwiseAbs().maxCoeff();
  double to_unit = 1;
  if (!(magnitude >= 0x1p-400 && magnitude <= 0x1p400) && std::isfinite(magnitude) && magnitude > 0) {
    int exponent = 0;
    std::frexp(magnitude, &exponent);
    to_unit = std::ldexp(1.0, -exponent);
  }
  const Eigen::Vector3d p = point * to_unit;
  const double chi2 = p.x() * p.x() + p.y() * p.y();
  bool ok = p.allFinite() && (chi2 > 0 || p.z() > 0);  // the -z axis has no pixel direction
  const double theta = ok ? project_radial(model, mapping, p.data(), pixel->data()) : kNaN;
  ok = ok && domain.contains_theta(theta) && pixel->allFinite();
  if (!ok) {
    pixel->setConstant(kNaN);
    if constexpr (kWithJacobian) jacobian->setConstant(kNaN);
    return false;
  }
  if constexpr (kWithJacobian) {
    const double ax = mapping[2], ay = mapping[3];
    if (chi2 == 0) {  // on the axis: u = cx + a_x rho'(0) X / Z to first order
      const double s = model.drho(0.0) / p.z();
      *jacobian << ax * s, 0, 0, 0, ay * s, 0;
    } else {
      // s = rho(theta) / chi; ds/dX = X A, ds/dY = Y A, ds/dZ = -rho' / r^2.
      const double chi = std::sqrt(chi2), r2 = chi2 + p.z() * p.z();
      const double rho = model.rho(theta), drho = model.drho(theta);
      const double s = rho / chi;
      const double a = drho * p.z() / (chi2 * r2) - rho / (chi2 * chi);
      const double sz = -drho / r2;
      *jacobian << ax * (s + p.x() * p.x() * a), ax * p.x() * p.y() * a, ax * p.x() * sz,  //
          ay * p.x() * p.y() * a, ay * (s + p.y() * p.y() * a), ay * p.y() * sz;
    }
    *jacobian *= to_unit;  // d pixel / d point = d pixel / d p * to_unit
  }
  return true;
}

// The unit ray of normalized image coordinates (x, y) = ((u - cx) / a_x, (v - cy) / a_y) at angle theta.
inline void ray_from_theta(double x, double y, double rho, double theta, double* ray) {
  if (rho == 0) {
    ray[0] = 0, ray[1] = 0, ray[2] = 1;
    return;
  }
  const double s = std::sin(theta) / rho;
  ray[0] = x * s, ray[1] = y * s, ray[2] = std::cos(theta);
}

// theta(rho) by either path. The robust path starts Newton from the table's value
// where there is one: it then converges in one step, and the bracket still
// guarantees convergence wherever the table is missing or poor.
template <class Model>
double theta_of(const Model& model, const ValidDomain& domain, const InverseTable& table, double rho,
                InversePath path) {
  if constexpr (ClosedFormInverse<Model>) return solve_theta(model, rho, domain);  // cheaper than the table
  double theta = std::numeric_limits<double>::quiet_NaN();
  const bool found = table.lookup(rho, &theta);
  if (found && path == InversePath::table) return theta;
  return solve_theta(model, rho, domain, theta);
}

// The unit ray of normalized image coordinates (x, y); false (ray untouched) outside the domain.
template <class Model>
bool ray_of(const Model& model, const ValidDomain& domain, const InverseTable& table, double x, double y,
            InversePath path, double* ray) {
  double rho = std::sqrt(x * x + y * y);
  // A point projected at theta_max may come back a few ulps past rho_max: it is valid.
  if (domain.closed && rho > domain.rho_max &&
      rho <= domain.rho_max * (1 + 8 * std::numeric_limits<double>::epsilon())) {
    rho = domain.rho_max;
  }
  double s, c;
  if (path == InversePath::table && table.lookup_ray(rho, &s, &c)) {
    ray[0] = x * s, ray[1] = y * s, ray[2] = c;
    return true;
  }
  const double theta = theta_of(model, domain, table, rho, InversePath::robust);
  if (std::isnan(theta)) return false;
  ray_from_theta(x, y, rho, theta, ray);
  return true;
}

// ---- cameras that are not radially symmetric: a plane distortion's offset T(m) on the
// model's undistorted plane (fishcam/core/plane_distortion.hpp)

// The plane radius u(theta) as a radial "model", so project_one gives m and dm/dP.
template <class Model>
struct PlaneRadius {
  const Model& model;
  double rho(double theta) const {
    double derivative;
    return model.plane_radius(theta, &derivative);
  }
  double drho(double theta) const {
    double derivative;
    model.plane_radius(theta, &derivative);
    return derivative;
  }
};

// D(m) = m R(|m|^2) + T(m), with dD/dm on request.
template <class Model, class Distortion>
Eigen::Vector2d distorted(const Model& model, const Distortion& terms, const Eigen::Vector2d& m,
                          Eigen::Matrix2d* jacobian = nullptr) {
  double dr;
  const double r = model.radial_factor(m.squaredNorm(), &dr);
  if (!jacobian) return m * r + terms.offset(m);
  Eigen::Matrix2d dt;
  const Eigen::Vector2d d = m * r + terms.offset(m, &dt);
  *jacobian = r * Eigen::Matrix2d::Identity() + 2 * dr * m * m.transpose() + dt;
  return d;
}

template <bool kWithJacobian, class Model, class Distortion>
bool project_distorted(const Model& model, const double* mapping, const ValidDomain& domain, const Distortion& terms,
                       const Eigen::Vector3d& point, Eigen::Vector2d* pixel, Eigen::Matrix<double, 2, 3>* jacobian) {
  if constexpr (!HasUndistortedPlane<Model>) {
    throw Error("internal: a non-radial part on a model without an undistorted plane");  // the constructor refuses
  } else {
    if (!project_one<kWithJacobian>(model, mapping, domain, point, pixel, jacobian)) return false;
    const double plane_mapping[4] = {0, 0, 1, 1};
    Eigen::Vector2d m;
    Eigen::Matrix<double, 2, 3> dm_dp;
    project_one<kWithJacobian>(PlaneRadius<Model>{model}, plane_mapping, domain, point, &m, &dm_dp);
    const double f = model.focal();
    const Eigen::Vector2d a(mapping[2], mapping[3]);
    Eigen::Matrix2d dt;
    *pixel += f * a.cwiseProduct(terms.offset(m, kWithJacobian ? &dt : nullptr));
    if constexpr (kWithJacobian) *jacobian += f * a.asDiagonal() * dt * dm_dp;
    if (pixel->allFinite()) return true;
    pixel->setConstant(kNaN);
    if constexpr (kWithJacobian) jacobian->setConstant(kNaN);
    return false;
  }
}

// D(m) = goal by Newton with backtracking from *m (a step that does not lower
// |D(m) - goal|, or that leaves the disk |m| <= m_reach, is halved); stops at
// `iterations`, at 1e-15 relative, or where no step makes progress (as close as
// doubles get). Returns the last residual D(m) - goal.
template <class Model, class Distortion>
Eigen::Vector2d plane_newton(const Model& model, const Distortion& terms, const Eigen::Vector2d& goal, double m_reach,
                             int iterations, Eigen::Vector2d* m) {
  Eigen::Matrix2d jacobian;
  Eigen::Vector2d residual = distorted(model, terms, *m, &jacobian) - goal;
  double error = residual.norm();
  const double tolerance = 1e-15 * std::max(1.0, goal.norm());
  for (int iteration = 0; iteration < iterations && error > tolerance; ++iteration) {
    const double det = jacobian.determinant();
    if (!(std::abs(det) > 0) || !std::isfinite(det)) break;
    const Eigen::Vector2d step = jacobian.inverse() * residual;
    double lambda = 1, next_error = kNaN;
    Eigen::Vector2d next, next_residual = Eigen::Vector2d::Constant(kNaN);
    Eigen::Matrix2d next_jacobian = Eigen::Matrix2d::Constant(kNaN);
    for (int halving = 0; halving < 40; ++halving, lambda *= 0.5) {
      next = *m - lambda * step;
      if (!(next.norm() <= m_reach)) continue;
      next_residual = distorted(model, terms, next, &next_jacobian) - goal;
      next_error = next_residual.norm();
      if (next_error < error) break;
    }
    if (!(next_error < error)) break;
    *m = next, residual = next_residual, jacobian = next_jacobian, error = next_error;
  }
  return residual;
}

// The unit ray of normalized image coordinates (x, y) = ((u - cx) / a_x, (v - cy) / a_y):
// D(m) = (x, y) / f solved by Newton with backtracking from the radial inverse, else by
// continuation from D(0); false unless the solution lies in the domain and reprojects
// to within 1e-7 px (relative 1e-15 for pixels beyond 1e8 px). start (optional): a
// first guess for m tried before those (a neighbouring pixel's, for whole images), and
// on return this pixel's m (NaN without one). The domain holds one solution only: the
// guess changes the cost, not the ray (but for rounding).
template <class Model, class Distortion>
bool distorted_ray_of(const Model& model, const ValidDomain& domain, const InverseTable& table, const Distortion& terms,
                      const Eigen::Vector2d& pixel_scale, double x, double y, double* ray,
                      Eigen::Vector2d* start = nullptr) {
  if constexpr (!HasUndistortedPlane<Model>) {
    throw Error("internal: a non-radial part on a model without an undistorted plane");
  } else {
    const double f = model.focal();
    const Eigen::Vector2d target(x / f, y / f);
    const Eigen::Vector2d guess = start ? *start : Eigen::Vector2d::Constant(kNaN);
    if (start) start->setConstant(kNaN);
    if (!target.allFinite() || target.norm() > domain.plane_reach) return false;
    const double rho = std::hypot(x, y);
    double derivative;
    const double theta0 =
        domain.contains_rho(rho) ? theta_of(model, domain, table, rho, InversePath::table) : domain.theta_max;
    if (!std::isfinite(theta0)) return false;
    // A step far past the domain's plane radius is halved (plane_newton): no ray of the
    // camera lies there, and a lens evaluated there may fail and say so (libmrcal's
    // CAHVORE; the constructor checked libmrcal up to this far past, lens_evaluation_end).
    // At an open limit the plane radius grows without bound and evaluates to anything
    // (mei with xi < 1: sin / (xi + cos) past the pole by rounding, -2.6e16): no bound.
    const double u_end = model.plane_radius(domain.theta_max, &derivative);
    const double m_reach = std::isfinite(u_end) && u_end >= 0 ? u_end * (1 + 1e-9) + 1e-5 * (1 + u_end)
                                                              : std::numeric_limits<double>::infinity();
    Eigen::Vector2d residual;
    const auto newton = [&](Eigen::Vector2d* m, const Eigen::Vector2d& goal, int iterations) {
      residual = plane_newton(model, terms, goal, m_reach, iterations, m);
    };
    const double tolerance_px =
        1e-7 + 1e-15 * rho * pixel_scale.cwiseAbs().maxCoeff();  // what doubles resolve 1e8 px out
    // A point projected at theta_max may come back a few ulps past it: it is valid.
    const auto theta_in_domain = [&](double theta) {
      if (domain.closed && theta > domain.theta_max && theta <= domain.theta_max * (1 + 1e-12))
        theta = domain.theta_max;
      return domain.contains_theta(theta) ? theta : kNaN;
    };
    const auto solved = [&](const Eigen::Vector2d& m) {
      return m.allFinite() && f * pixel_scale.cwiseProduct(residual).norm() <= tolerance_px &&
             !std::isnan(theta_in_domain(model.theta_of_plane_radius(m.norm())));
    };
    // From the guess, else from the radial inverse (the centre itself for the principal point) ...
    Eigen::Vector2d m = guess;
    if (m.allFinite()) newton(&m, target, 100);
    if (!solved(m)) {
      m = rho > 0 ? Eigen::Vector2d(target * (model.plane_radius(theta0, &derivative) / target.norm()))
                  : Eigen::Vector2d::Zero();
      if (m.allFinite()) newton(&m, target, 100);
    }
    if (!solved(m)) {
      // ... else along the segment from D(0) to the pixel, which the domain's image
      // contains (star-shaped about D(0)): Newton from each point's solution to the next.
      const Eigen::Vector2d centre = distorted(model, terms, Eigen::Vector2d::Zero());
      m = Eigen::Vector2d::Zero();
      constexpr int kSteps = 16;
      for (int k = 1; k <= kSteps; ++k)
        newton(&m, centre + (target - centre) * (double(k) / kSteps), k < kSteps ? 20 : 100);
    }
    if (!solved(m)) return false;
    if (start) *start = m;
    const double u = m.norm();
    const double theta = theta_in_domain(model.theta_of_plane_radius(u));
    if (u == 0) return ray[0] = 0, ray[1] = 0, ray[2] = 1, true;
    const double s = std::sin(theta) / u;
    ray[0] = m.x() * s, ray[1] = m.y() * s, ray[2] = std::cos(theta);
    return true;
  }
}

// A camera's projection and unprojection through its parts: the radial model, its
// plane distortion (NoPlaneDistortion: none), then its pixel skew
// (CameraParameters::skew) if any. Callers visit the model and the part once per
// call or batch (visit_parts), so the per-point code is inlined for each pair.
template <class F>
decltype(auto) visit_parts(const CameraParameters& params, F&& f) {
  static const PlaneDistortion none = NoPlaneDistortion{};  // for a part that displaces nothing
  return std::visit(std::forward<F>(f), params.model, displaces(params.distortion) ? params.distortion : none);
}

template <bool kWithJacobian, class Model, class Part>
bool project_unskewed(const Model& model, const Part& part, const double* mapping, const ValidDomain& domain,
                      const Eigen::Vector3d& point, Eigen::Vector2d* pixel, Eigen::Matrix<double, 2, 3>* jacobian) {
  if constexpr (std::is_same_v<Part, NoPlaneDistortion>) {
    return project_one<kWithJacobian>(model, mapping, domain, point, pixel, jacobian);
  } else {
    return project_distorted<kWithJacobian>(model, mapping, domain, part, point, pixel, jacobian);
  }
}

// Whether a camera-frame direction lies within the camera's per-azimuth limit (true
// without one). A direction built at the limit may measure a few ulps past it: valid.
inline bool within_azimuth_limit(const CameraParameters& params, const double* v) {
  if (!params.theta_limit_by_azimuth) return true;
  const double theta = std::atan2(std::hypot(v[0], v[1]), v[2]);
  return theta <= angle_near_azimuth(*params.theta_limit_by_azimuth, std::atan2(v[1], v[0])) * (1 + 1e-12);
}

template <bool kWithJacobian, class Model, class Part>
bool project_in_domain(const Model& model, const Part& part, const CameraParameters& params, const double* mapping,
                       const ValidDomain& domain, const Eigen::Vector3d& point, Eigen::Vector2d* pixel,
                       Eigen::Matrix<double, 2, 3>* jacobian) {
  if (!params.grid.skew.any())
    return project_unskewed<kWithJacobian>(model, part, mapping, domain, point, pixel, jacobian);
  // q with c = 0, a = 1, then the grid's pixel c + a (.) (S q).
  const double unit[4] = {0, 0, 1, 1};
  Eigen::Vector2d q;
  Eigen::Matrix<double, 2, 3> dq;
  if (!project_unskewed<kWithJacobian>(model, part, unit, domain, point, &q, &dq)) {
    pixel->setConstant(kNaN);
    if constexpr (kWithJacobian) jacobian->setConstant(kNaN);
    return false;
  }
  Eigen::Matrix2d dpixel;
  *pixel = params.grid.pixel(q, &dpixel);
  if constexpr (kWithJacobian) *jacobian = dpixel * dq;
  return true;
}

template <bool kWithJacobian, class Model, class Part>
bool project_point(const Model& model, const Part& part, const CameraParameters& params, const double* mapping,
                   const ValidDomain& domain, const Eigen::Vector3d& point, Eigen::Vector2d* pixel,
                   Eigen::Matrix<double, 2, 3>* jacobian) {
  if (within_azimuth_limit(params, point.data()))
    return project_in_domain<kWithJacobian>(model, part, params, mapping, domain, point, pixel, jacobian);
  pixel->setConstant(kNaN);
  if constexpr (kWithJacobian) jacobian->setConstant(kNaN);
  return false;
}

// (x, y) = ((u - cx) / a_x, (v - cy) / a_y), which is S q for a skewed grid.
// start: distorted_ray_of's guess, for a camera with a plane distortion.
template <class Model, class Part>
bool ray_in_domain(const Model& model, const Part& part, const CameraParameters& params, const ValidDomain& domain,
                   const InverseTable& table, double x, double y, InversePath path, double* ray,
                   Eigen::Vector2d* start = nullptr) {
  if (params.grid.skew.any()) {
    const Eigen::Vector2d q = params.grid.unskewed({x, y});
    x = q.x(), y = q.y();
  }
  if constexpr (std::is_same_v<Part, NoPlaneDistortion>) {
    return ray_of(model, domain, table, x, y, path, ray);
  } else {
    return distorted_ray_of(model, domain, table, part, params.grid.pixel_scale, x, y, ray, start);
  }
}

// ray_in_domain, and false (ray NaN) where the ray lies past the per-azimuth limit.
template <class Model, class Part>
bool ray_of_point(const Model& model, const Part& part, const CameraParameters& params, const ValidDomain& domain,
                  const InverseTable& table, double x, double y, InversePath path, double* ray,
                  Eigen::Vector2d* start = nullptr) {
  if (!ray_in_domain(model, part, params, domain, table, x, y, path, ray, start)) return false;
  if (within_azimuth_limit(params, ray)) return true;
  ray[0] = ray[1] = ray[2] = kNaN;
  return false;
}

}  // namespace fishcam::detail
