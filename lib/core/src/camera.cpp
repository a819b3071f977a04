#include "fishcam/core/camera.hpp"
#include "fishcam/core/error.hpp"

#include <Eigen/Eigenvalues>
#include "fishcam/core/parallel.hpp"
#include "fishcam/core/stderr_capture.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <sstream>

namespace fishcam {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDeg = 180 / std::numbers::pi;

template <typename... T>
[[noreturn]] void fail(const T&... parts) {
  std::ostringstream msg;
  (msg << ... << parts);
  throw Error(msg.str());
}

bool finite(const Eigen::Vector2d& v) { return v.allFinite(); }

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
    // Newton with backtracking (a step that does not lower |D(m) - goal| is halved) from m.
    // A step far past the domain's plane radius is halved as well: no ray of the camera
    // lies there, and a lens evaluated there may fail and say so (libmrcal's CAHVORE;
    // the constructor checked libmrcal up to this far past, lens_evaluation_end).
    const double u_end = model.plane_radius(domain.theta_max, &derivative);
    const double m_reach = u_end * (1 + 1e-9) + 1e-5 * (1 + u_end);
    Eigen::Vector2d residual;
    const auto newton = [&](Eigen::Vector2d* m, const Eigen::Vector2d& goal, int iterations) {
      Eigen::Matrix2d jacobian;
      residual = distorted(model, terms, *m, &jacobian) - goal;
      double error = residual.norm();
      const double tolerance = 1e-15 * std::max(1.0, goal.norm());
      for (int iteration = 0; iteration < iterations && error > tolerance; ++iteration) {
        const double det = jacobian.determinant();
        if (!(std::abs(det) > 0) || !std::isfinite(det)) return;
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
        if (!(next_error < error)) return;  // no progress: as close as doubles get
        *m = next, residual = next_residual, jacobian = next_jacobian, error = next_error;
      }
    };
    const double tolerance_px = 1e-7 + 1e-15 * rho * pixel_scale.maxCoeff();  // what doubles resolve 1e8 px out
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

// The largest theta* <= the radial domain's theta_max below which the distortion map
// D is one-to-one on the disk |m| <= u(theta*): det(dD/dm) > 0 on every ring and each
// ring's image star-shaped about D(0) (its angle increasing), which together make D
// injective. (T(0) = 0 for tangential terms; an mrcal lens may move the centre.)
// Rings are scanned, the first failing one bisected. nullopt: no ring fails.
template <class Model, class Distortion>
std::optional<double> distortion_fold(const Model& model, const Distortion& terms, const ValidDomain& radial) {
  if constexpr (!HasUndistortedPlane<Model>) {
    return std::nullopt;
  } else {
    constexpr int kRings = 1024, kAzimuths = 360;
    std::array<Eigen::Vector2d, kAzimuths> directions;
    for (int k = 0; k < kAzimuths; ++k) {
      const double phi = 2 * std::numbers::pi * k / kAzimuths;
      directions[size_t(k)] = {std::cos(phi), std::sin(phi)};
    }
    const Eigen::Vector2d centre = distorted(model, terms, Eigen::Vector2d::Zero());
    const auto ring_ok = [&](double theta) {
      double derivative;
      const double u = model.plane_radius(theta, &derivative);
      if (!std::isfinite(u)) return false;
      Eigen::Vector2d first, previous;
      for (int k = 0; k < kAzimuths; ++k) {
        Eigen::Matrix2d jacobian;
        const Eigen::Vector2d d = distorted(model, terms, u * directions[size_t(k)], &jacobian) - centre;
        if (!(jacobian.determinant() > 0)) return false;
        if (k == 0) {
          first = d;
        } else if (!(previous.x() * d.y() - previous.y() * d.x() > 0)) {
          return false;
        }
        previous = d;
      }
      return previous.x() * first.y() - previous.y() * first.x() > 0;
    };
    const double end = radial.closed ? radial.theta_max : radial.theta_max * (1 - 1e-9);
    // Rings in blocks, each block's rings in parallel (an mrcal lens costs libmrcal
    // calls per point); the first failing ring is the same as in a serial scan.
    constexpr int kBlock = 64;
    std::array<unsigned char, kBlock> ok;
    double good = 0;
    for (int first = 1; first <= kRings; first += kBlock) {
      const int count = std::min(kBlock, kRings + 1 - first);
      parallel_for(count, [&](int begin, int stop) {
        for (int i = begin; i < stop; ++i) ok[size_t(i)] = ring_ok(end * (first + i) / kRings);
      });
      for (int i = 0; i < count; ++i) {
        const double theta = end * (first + i) / kRings;
        if (ok[size_t(i)]) {
          good = theta;
          continue;
        }
        double bad = theta;
        for (int bisection = 0; bisection < 60 && bad - good > 1e-15; ++bisection) {
          const double mid = 0.5 * (good + bad);
          (ring_ok(mid) ? good : bad) = mid;
        }
        return good;
      }
    }
    return std::nullopt;
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

template <bool kWithJacobian, class Model, class Part>
bool project_point(const Model& model, const Part& part, const CameraParameters& params, const double* mapping,
                   const ValidDomain& domain, const Eigen::Vector3d& point, Eigen::Vector2d* pixel,
                   Eigen::Matrix<double, 2, 3>* jacobian) {
  if (!params.skew.any()) return project_unskewed<kWithJacobian>(model, part, mapping, domain, point, pixel, jacobian);
  // q with c = 0, a = 1, then pixel = c + a (.) (S q).
  const double unit[4] = {0, 0, 1, 1};
  Eigen::Vector2d q;
  Eigen::Matrix<double, 2, 3> dq;
  if (!project_unskewed<kWithJacobian>(model, part, unit, domain, point, &q, &dq)) {
    pixel->setConstant(kNaN);
    if constexpr (kWithJacobian) jacobian->setConstant(kNaN);
    return false;
  }
  const Eigen::Matrix2d as = Eigen::Vector2d(mapping[2], mapping[3]).asDiagonal() * params.skew.matrix();
  *pixel = Eigen::Vector2d(mapping[0], mapping[1]) + as * q;
  if constexpr (kWithJacobian) *jacobian = as * dq;
  return true;
}

// (x, y) = ((u - cx) / a_x, (v - cy) / a_y), which is S q for a skewed grid.
// start: distorted_ray_of's guess, for a camera with a plane distortion.
template <class Model, class Part>
bool ray_of_point(const Model& model, const Part& part, const CameraParameters& params, const ValidDomain& domain,
                  const InverseTable& table, double x, double y, InversePath path, double* ray,
                  Eigen::Vector2d* start = nullptr) {
  if (params.skew.any()) {
    const double xy = params.skew.xy, yx = params.skew.yx, det = 1 - xy * yx;
    const double qx = (x - xy * y) / det, qy = (y - yx * x) / det;
    x = qx, y = qy;
  }
  if constexpr (std::is_same_v<Part, NoPlaneDistortion>) {
    return ray_of(model, domain, table, x, y, path, ray);
  } else {
    return distorted_ray_of(model, domain, table, part, params.pixel_scale, x, y, ray, start);
  }
}

// Runs body(begin, end) over [0, n) on the installed thread pool, in chunks worth a thread.
template <class Body>
void parallel_chunks(size_t n, const Body& body) {
  constexpr size_t kChunk = 8192;
  const int stripes = static_cast<int>((n + kChunk - 1) / kChunk);
  if (stripes <= 1) return body(size_t{0}, n);
  parallel_for(stripes, [&](int begin, int end) {
    body(static_cast<size_t>(begin) * kChunk, std::min(n, static_cast<size_t>(end) * kChunk));
  });
}

// Every pixel centre's ray, pixel i's to x[i * kStride], y[i * kStride], z[i * kStride]:
// interleaved (kStride 3) or in planes (1).
template <std::size_t kStride>
void unproject_pixels(const CameraParameters& params, const ValidDomain& domain, const InverseTable& table, float* x,
                      float* y, float* z, InversePath path) {
  const size_t w = static_cast<size_t>(params.width), h = static_cast<size_t>(params.height);
  const Eigen::Vector2d c = params.principal_point, inv_scale = params.pixel_scale.cwiseInverse();
  visit_parts(params, [&](const auto& m, const auto& part) {
    parallel_for(static_cast<int>(h), [&](int first_row, int end_row) {
      for (int row = first_row; row < end_row; ++row) {
        const double v = (row - c.y()) * inv_scale.y();
        const size_t first = w * static_cast<size_t>(row);
        // Along a row, a non-radial camera's Newton starts from the pixel before's
        // solution (the row on one thread: the rays do not depend on the threads).
        Eigen::Vector2d start = Eigen::Vector2d::Constant(kNaN);
        for (size_t col = 0; col < w; ++col) {
          const double u = (double(col) - c.x()) * inv_scale.x();
          double ray[3] = {kNaN, kNaN, kNaN};
          ray_of_point(m, part, params, domain, table, u, v, path, ray, &start);
          const size_t i = (first + col) * kStride;
          x[i] = float(ray[0]), y[i] = float(ray[1]), z[i] = float(ray[2]);
        }
      }
    });
  });
}

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
  out.principal_point = (camera.principal_point.array() + 0.5) * s.array() - 0.5;
  out.pixel_scale = camera.pixel_scale.cwiseProduct(s);
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
  out.principal_point -= Eigen::Vector2d(left, top);
  return out;
}

namespace {

void check_calibration_record(const CalibrationRecord& r, size_t model_params) {
  const auto angle = [](double a) { return a >= 0 && a <= std::numbers::pi; };
  if (!angle(r.theta_max)) fail("calibration.theta_max: must be in [0, 180] degrees, got ", r.theta_max * kDeg);
  for (double a : r.theta_max_by_azimuth) {
    if (!std::isnan(a) && !(angle(a) && a <= r.theta_max)) {
      fail("calibration.theta_max_by_azimuth: every sector's angle must be in [0, theta_max] (or unobserved)");
    }
  }
  const Eigen::MatrixXd& c = r.covariance;
  if (c.size() == 0) return;
  const Eigen::Index n = Eigen::Index(model_params) + 9;
  if (c.rows() != n || c.cols() != n) {
    fail("calibration.covariance: expected ", n, "x", n, " (model parameters, cx, cy, a_y, board motion), got ",
         c.rows(), "x", c.cols());
  }
  if (!c.allFinite()) fail("calibration.covariance: must be finite");
  const double scale = c.cwiseAbs().maxCoeff();
  if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) fail("calibration.covariance: must be symmetric");
  if (c.diagonal().minCoeff() < 0) fail("calibration.covariance: variances (the diagonal) must be >= 0");
  // A covariance is positive semi-definite: a negative eigenvalue (beyond rounding)
  // would give negative variances along some direction, and uncertainties of any size.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(c, Eigen::EigenvaluesOnly);
  if (eigen.info() != Eigen::Success || eigen.eigenvalues().minCoeff() < -1e-9 * scale) {
    fail("calibration.covariance: must be positive semi-definite (smallest eigenvalue ", eigen.eigenvalues().minCoeff(),
         ", largest ", eigen.eigenvalues().maxCoeff(), ")");
  }
}

}  // namespace

Pose compose(const Pose& a, const Pose& b) {
  return Pose{(a.rotation * b.rotation).normalized(), a.rotation * b.translation + a.translation};
}

Pose inverse(const Pose& pose) {
  const Eigen::Quaterniond r = pose.rotation.conjugate();
  return Pose{r, -(r * pose.translation)};
}

CameraParameters limited_to_observed(CameraParameters camera, double margin) {
  if (!camera.calibration) {
    fail(
        "theta limit 'data': the camera carries no calibration record (fishcam calibrate writes one into fishcam "
        "JSON)");
  }
  if (!(margin >= 0 && margin < std::numbers::pi))
    fail("theta limit 'data+DEG': the margin must be in [0, 180) degrees");
  const double limit = std::min(camera.calibration->theta_max + margin, std::numbers::pi);
  camera.theta_limit = camera.theta_limit ? std::min(*camera.theta_limit, limit) : limit;
  return camera;
}

CalibrationRecord CalibrationRecord::nothing_observed() {
  CalibrationRecord r;
  r.theta_max_by_azimuth.fill(kNaN);
  return r;
}

void CalibrationRecord::observe(const Eigen::Vector3d& point) {
  const double theta = std::atan2(point.head<2>().norm(), point.z());
  double& sector = theta_max_by_azimuth[size_t(sector_of(std::atan2(point.y(), point.x())))];
  if (!(sector >= theta)) sector = theta;  // NaN: the sector's first corner
  theta_max = std::max(theta_max, theta);
}

int CalibrationRecord::sector_of(double azimuth) {
  const double turn = 2 * std::numbers::pi;
  const int k = int(std::floor((azimuth + std::numbers::pi) / turn * kAzimuthSectors));
  return std::clamp(k, 0, kAzimuthSectors - 1);
}

bool CalibrationRecord::observed(const Eigen::Vector3d& ray) const {
  const double theta = std::atan2(ray.head<2>().norm(), ray.z());
  const double limit = theta_max_by_azimuth[size_t(sector_of(std::atan2(ray.y(), ray.x())))];
  return theta <= limit;  // false for NaN: no corner in that sector
}

namespace {

// Evaluates the lens at `azimuths` points of the ring of plane radius u (under the
// caller's capture of what libmrcal says); false when one of them has no offset.
bool lens_finite_on_ring(const MrcalLens& lens, double u, int azimuths) {
  bool finite = true;
  for (int k = 0; k < azimuths; ++k) {
    const double phi = 2 * std::numbers::pi * k / azimuths;
    finite = lens.offset(u * Eigen::Vector2d(std::cos(phi), std::sin(phi))).allFinite() && finite;
  }
  return finite;
}

// The domain's rays, 64 rings by 360 azimuths up to theta_max: libmrcal must evaluate
// each without a complaint on standard error, or the lens is refused in one line (a
// projection whose own iteration failed cannot be right).
void check_lens_evaluates(const CameraParameters& p, const MrcalLens& lens, double theta_max) {
  detail::StderrCapture libmrcal;
  std::visit(
      [&](const auto& m) {
        if constexpr (HasUndistortedPlane<std::decay_t<decltype(m)>>) {
          double derivative;
          for (int ring = 1; ring <= 64; ++ring) {
            (void)lens_finite_on_ring(lens, m.plane_radius(theta_max * (1 - 1e-9) * ring / 64, &derivative), 360);
          }
        }
      },
      p.model);
  if (const std::string said = libmrcal.summary(); !said.empty()) {
    fail("mrcal_lens: libmrcal cannot evaluate ", lens.lensmodel().substr(0, 80),
         " everywhere in its domain (it said: ", quoted_for_message(said, 200), ")");
  }
}

// Where the domain of a lens that libmrcal could not evaluate everywhere during the
// scans ends: the largest theta at most theta_max (by steps up to 1 % inside) on whose
// ring, and on a ring just past it (Newton's steps and CAHVORE's central differences
// reach there), libmrcal evaluates at 1440 azimuths without a word. CAHVORE's own
// iteration fails at and past its fold, which the fold scan finds to a few ulps.
// None: libmrcal fails even 1 % inside (the camera is refused).
std::optional<double> lens_evaluation_end(const CameraParameters& p, const MrcalLens& lens, double theta_max) {
  std::optional<double> end;
  std::visit(
      [&](const auto& m) {
        if constexpr (HasUndistortedPlane<std::decay_t<decltype(m)>>) {
          for (double inside : {0.0, 1e-6, 1e-5, 1e-4, 1e-3, 3e-3, 1e-2}) {
            double derivative;
            const double theta = theta_max * (1 - inside);
            const double u = m.plane_radius(theta, &derivative);
            detail::StderrCapture libmrcal;
            const bool evaluates =
                lens_finite_on_ring(lens, u, 1440) && lens_finite_on_ring(lens, u * (1 + 1e-9) + 2e-5 * (1 + u), 1440);
            if (evaluates && libmrcal.summary().empty()) {
              end = theta;
              return;
            }
          }
        }
      },
      p.model);
  return end;
}

}  // namespace

Camera::Camera(CameraParameters parameters, double table_tolerance_px) : params_(std::move(parameters)) {
  if (params_.width <= 0 || params_.height <= 0 || params_.width > (1 << 16) || params_.height > (1 << 16)) {
    fail("width/height: must be in [1, 65536], got ", params_.width, "x", params_.height);
  }
  if (!finite(params_.principal_point)) fail("principal_point: must be finite");
  if (!finite(params_.pixel_scale) || !(params_.pixel_scale.minCoeff() > 0)) {
    fail("pixel_scale: a_x and a_y must be finite and > 0, got ", params_.pixel_scale.x(), ", ",
         params_.pixel_scale.y());
  }
  for (double p : model_params(params_.model)) {
    if (!std::isfinite(p)) fail(model_name(params_.model), ": parameters must be finite");
  }
  if (const std::string problem = std::visit([](const auto& m) { return m.invalid(); }, params_.model);
      !problem.empty()) {
    fail(model_name(params_.model), ": ", problem);
  }
  if (params_.pose) {
    Pose& pose = *params_.pose;
    if (!pose.rotation.coeffs().allFinite() || !pose.translation.allFinite()) fail("pose: must be finite");
    const double norm = pose.rotation.norm();
    if (std::abs(norm - 1) > 1e-6) fail("pose: rotation quaternion must have unit norm, got ", norm);
    pose.rotation.normalize();
  }
  if (params_.calibration) check_calibration_record(*params_.calibration, model_params(params_.model).size());
  domain_ = std::visit([&](const auto& m) { return compute_domain(m, params_.theta_limit); }, params_.model);
  const PixelSkew& skew = params_.skew;
  if (!std::isfinite(skew.xy) || !std::isfinite(skew.yx)) fail("skew: xy and yx must be finite");
  if (!(1 - skew.xy * skew.yx > 0)) {
    fail("skew: the pixel grid must keep its orientation (1 - xy yx > 0), got xy ", skew.xy, ", yx ", skew.yx);
  }
  if (displaces(params_.distortion)) {
    // libmrcal says on standard error where its own projection fails (CAHVORE's
    // iteration: "too many iterations"), never to the terminal from here: the scans
    // meet such rays at and past the fold, so what it said is checked over the domain.
    std::string libmrcal_said;
    {
      detail::StderrCapture libmrcal;
      limit_to_plane_fold();
      libmrcal_said = libmrcal.summary();
    }
    const MrcalLens* lens = params_.mrcal_lens();
    if (!libmrcal_said.empty() && lens) {
      const std::optional<double> end = lens_evaluation_end(params_, *lens, domain_.theta_max);
      if (!end) {
        fail("mrcal_lens: libmrcal cannot evaluate ", lens->lensmodel().substr(0, 80),
             " next to the end of its domain (it said: ", quoted_for_message(libmrcal_said, 200), ")");
      }
      if (*end < domain_.theta_max) {
        domain_.theta_max = *end;
        domain_.closed = true;
        domain_.rho_max = rho(*end);
      }
    }
    {
      detail::StderrCapture libmrcal;
      bound_plane_reach();
      if (libmrcal_said.empty()) libmrcal_said = libmrcal.summary();
    }
    if (!libmrcal_said.empty() && lens) check_lens_evaluates(params_, *lens, domain_.theta_max);
  }
  table_ = std::visit([&](const auto& m) { return InverseTable(m, domain_, table_tolerance_px); }, params_.model);
}

void Camera::limit_to_plane_fold() {
  const std::string part(distortion_name(params_.distortion));
  if (const std::string problem = std::visit([](const auto& d) { return d.invalid(); }, params_.distortion);
      !problem.empty()) {
    fail(part, ".", problem);
  }
  const std::vector<std::string> bases = std::visit([](const auto& d) { return d.base_models(); }, params_.distortion);
  if (std::find(bases.begin(), bases.end(), model_name(params_.model)) == bases.end()) {
    std::string list;
    for (size_t i = 0; i < bases.size(); ++i) list += (i == 0 ? "" : i + 1 == bases.size() ? " or " : ", ") + bases[i];
    fail(part, ": only the ", list, " model's undistorted plane takes ",
         std::visit([](const auto& d) { return d.description(); }, params_.distortion), " (the model is ",
         model_name(params_.model), ")");
  }
  const std::optional<double> fold = std::visit(
      [&](const auto& m) {
        return std::visit([&](const auto& d) { return distortion_fold(m, d, domain_); }, params_.distortion);
      },
      params_.model);
  if (fold && *fold < domain_.theta_max * (1 - 1e-12)) {  // else the radial limit comes first
    if (!(*fold > 0)) {
      fail(part, ": the distortion is not one-to-one even next to the principal point");
    }
    domain_.theta_max = *fold;
    domain_.closed = true;
    domain_.limited_by = ValidDomain::Limit::distortion_fold;
    domain_.rho_max = rho(*fold);
  }
}

void Camera::bound_plane_reach() {
  if (!domain_.closed) return;
  // |D| is largest on the image of the domain's rim (the image is star-shaped about
  // D(0), |.| convex): sampled densely, with a 1 % margin for what lies between samples.
  const auto reach = [&](const auto& model, const auto& terms) {
    double derivative, largest = 0;
    const double u = model.plane_radius(domain_.theta_max, &derivative);
    for (int k = 0; k < 1440; ++k) {
      const double phi = 2 * std::numbers::pi * k / 1440;
      largest = std::max(largest, distorted(model, terms, u * Eigen::Vector2d(std::cos(phi), std::sin(phi))).norm());
    }
    return 1.01 * largest;
  };
  std::visit(
      [&](const auto& m) {
        if constexpr (HasUndistortedPlane<std::decay_t<decltype(m)>>) {
          domain_.plane_reach = std::visit([&](const auto& d) { return reach(m, d); }, params_.distortion);
        }
      },
      params_.model);
}

double Camera::rho(double theta) const {
  return std::visit([&](const auto& m) { return m.rho(theta); }, params_.model);
}

double Camera::drho(double theta) const {
  return std::visit([&](const auto& m) { return m.drho(theta); }, params_.model);
}

double Camera::theta_from_rho(double rho) const {
  return std::visit([&](const auto& m) { return theta_of(m, domain_, table_, rho, InversePath::robust); },
                    params_.model);
}

double Camera::theta_from_rho_table(double rho) const {
  return std::visit([&](const auto& m) { return theta_of(m, domain_, table_, rho, InversePath::table); },
                    params_.model);
}

double Camera::rho_of_pixel(const Eigen::Vector2d& pixel) const {
  return (pixel - params_.principal_point).cwiseQuotient(params_.pixel_scale).norm();
}

bool Camera::project(const Eigen::Vector3d& point, Eigen::Vector2d* pixel,
                     Eigen::Matrix<double, 2, 3>* jacobian) const {
  const std::array<double, 4> mapping{params_.principal_point.x(), params_.principal_point.y(), params_.pixel_scale.x(),
                                      params_.pixel_scale.y()};
  return visit_parts(params_, [&](const auto& m, const auto& part) {
    return jacobian ? project_point<true>(m, part, params_, mapping.data(), domain_, point, pixel, jacobian)
                    : project_point<false>(m, part, params_, mapping.data(), domain_, point, pixel, nullptr);
  });
}

bool Camera::unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d* ray) const {
  const double x = (pixel.x() - params_.principal_point.x()) / params_.pixel_scale.x();
  const double y = (pixel.y() - params_.principal_point.y()) / params_.pixel_scale.y();
  const bool ok = visit_parts(params_, [&](const auto& m, const auto& part) {
    return ray_of_point(m, part, params_, domain_, table_, x, y, InversePath::robust, ray->data());
  });
  if (!ok) ray->setConstant(kNaN);
  return ok;
}

void Camera::project(std::span<const Eigen::Vector3d> points, std::span<Eigen::Vector2d> pixels,
                     std::span<std::uint8_t> valid) const {
  if (pixels.size() != points.size() || (!valid.empty() && valid.size() != points.size())) {
    throw Error("project: output sizes must match the number of points");
  }
  const std::array<double, 4> mapping{params_.principal_point.x(), params_.principal_point.y(), params_.pixel_scale.x(),
                                      params_.pixel_scale.y()};
  visit_parts(params_, [&](const auto& m, const auto& part) {
    parallel_chunks(points.size(), [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        const bool ok = project_point<false>(m, part, params_, mapping.data(), domain_, points[i], &pixels[i], nullptr);
        if (!valid.empty()) valid[i] = ok;
      }
    });
  });
}

void Camera::unproject(std::span<const Eigen::Vector2d> pixels, std::span<Eigen::Vector3d> rays,
                       std::span<std::uint8_t> valid, InversePath path) const {
  if (rays.size() != pixels.size() || (!valid.empty() && valid.size() != pixels.size())) {
    throw Error("unproject: output sizes must match the number of pixels");
  }
  const Eigen::Vector2d c = params_.principal_point, inv_scale = params_.pixel_scale.cwiseInverse();
  visit_parts(params_, [&](const auto& m, const auto& part) {
    parallel_chunks(pixels.size(), [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        const double x = (pixels[i].x() - c.x()) * inv_scale.x(), y = (pixels[i].y() - c.y()) * inv_scale.y();
        const bool ok = ray_of_point(m, part, params_, domain_, table_, x, y, path, rays[i].data());
        if (!ok) rays[i].setConstant(kNaN);
        if (!valid.empty()) valid[i] = ok;
      }
    });
  });
}

void Camera::unproject_image(std::span<float> rays_xyz, InversePath path) const {
  const size_t n = static_cast<size_t>(params_.width) * static_cast<size_t>(params_.height);
  if (rays_xyz.size() != 3 * n) throw Error("unproject_image: output must hold 3 * width * height floats");
  unproject_pixels<3>(params_, domain_, table_, rays_xyz.data(), rays_xyz.data() + 1, rays_xyz.data() + 2, path);
}

void Camera::unproject_image(std::span<float> x, std::span<float> y, std::span<float> z, InversePath path) const {
  const size_t n = static_cast<size_t>(params_.width) * static_cast<size_t>(params_.height);
  if (x.size() < n || y.size() < n || z.size() < n) {
    throw Error("unproject_image: each output plane must hold width * height floats");
  }
  unproject_pixels<1>(params_, domain_, table_, x.data(), y.data(), z.data(), path);
}

Camera::FieldOfView Camera::field_of_view_deg() const {
  const double w = params_.width - 0.5, h = params_.height - 0.5, cx = params_.principal_point.x(),
               cy = params_.principal_point.y();
  const bool centred = cx >= -0.5 && cx <= w && cy >= -0.5 && cy <= h;
  // What the image sees between two points of its border, along the line between them
  // (through the principal point when it lies in the image): the angles of the
  // rays of the pixels that have one, never the model's domain where no pixel reaches.
  constexpr int kSamples = 512;
  const auto across = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    if (centred && radial()) {  // exact: the domain is a disk about the principal point
      const auto theta_at = [&](const Eigen::Vector2d& q) {
        const double rho = rho_of_pixel(q);
        return domain_.contains_rho(rho) ? theta_from_rho(rho) : domain_.theta_max;
      };
      return theta_at(a) + theta_at(b);
    }
    std::optional<Eigen::Vector3d> first, last;
    double theta_a = 0, theta_b = 0;
    const Eigen::Vector2d centre(cx, cy);
    for (int k = 0; k <= kSamples; ++k) {
      const Eigen::Vector2d q = a + (b - a) * (double(k) / kSamples);
      Eigen::Vector3d ray;
      if (!unproject(q, &ray)) continue;
      ray.normalize();
      if (!first) first = ray;
      last = ray;
      const double theta = std::acos(std::clamp(ray.z(), -1.0, 1.0));
      // Which side of the principal point the sample lies on.
      ((q - centre).dot(b - a) < 0 ? theta_a : theta_b) =
          std::max((q - centre).dot(b - a) < 0 ? theta_a : theta_b, theta);
    }
    if (centred) return theta_a + theta_b;
    return first ? std::acos(std::clamp(first->dot(*last), -1.0, 1.0)) : 0.0;
  };
  const double row = std::clamp(cy, -0.5, h), column = std::clamp(cx, -0.5, w);
  return {kDeg * across({-0.5, row}, {w, row}), kDeg * across({column, -0.5}, {column, h}),
          kDeg * std::max(across({-0.5, -0.5}, {w, h}), across({w, -0.5}, {-0.5, h}))};
}

}  // namespace fishcam
