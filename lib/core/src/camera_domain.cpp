#include "fail.hpp"
#include "fishcam/core/camera.hpp"
#include "fishcam/core/error.hpp"
#include "fishcam/core/parallel.hpp"
#include "fishcam/core/stderr_capture.hpp"
#include "point_projection.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

// A camera's construction: its parameters checked, its domain found (the radial
// model's, then where a plane distortion folds or libmrcal stops evaluating a lens).

namespace fishcam {
namespace {

using detail::distorted;
using detail::fail;
using detail::kDeg;
using detail::kNaN;

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

void check_calibration_record(const CalibrationRecord& r, size_t intrinsics) {
  const auto angle = [](double a) { return a >= 0 && a <= std::numbers::pi; };
  if (!angle(r.theta_max)) fail("calibration.theta_max: must be in [0, 180] degrees, got ", r.theta_max * kDeg);
  for (double a : r.theta_max_by_azimuth) {
    if (!std::isnan(a) && !(angle(a) && a <= r.theta_max)) {
      fail("calibration.theta_max_by_azimuth: every sector's angle must be in [0, theta_max] (or unobserved)");
    }
  }
  const Eigen::MatrixXd& c = r.covariance;
  if (c.size() == 0) return;
  const Eigen::Index n = Eigen::Index(intrinsics) + 9;
  if (c.rows() != n || c.cols() != n) {
    fail("calibration.covariance: expected ", n, "x", n,
         " (model parameters, plane distortion terms, cx, cy, a_y, board motion), got ", c.rows(), "x", c.cols());
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

// The radius of the model's undistorted plane at theta (the models a plane
// distortion sits on have one: their base_models()).
PlaneRadius plane_radius_of(const RadialModel& model) {
  return [&model](double theta) {
    return std::visit(
        [&](const auto& m) {
          if constexpr (HasUndistortedPlane<std::decay_t<decltype(m)>>) {
            double derivative;
            return m.plane_radius(theta, &derivative);
          } else {
            return std::numeric_limits<double>::quiet_NaN();
          }
        },
        model);
  };
}

}  // namespace

Camera::Camera(CameraParameters parameters, double table_tolerance_px) : params_(std::move(parameters)) {
  if (params_.width <= 0 || params_.height <= 0 || params_.width > (1 << 16) || params_.height > (1 << 16)) {
    fail("width/height: must be in [1, 65536], got ", params_.width, "x", params_.height);
  }
  if (const std::string problem = params_.grid.invalid(); !problem.empty()) fail(problem);
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
  if (params_.calibration) {
    check_calibration_record(*params_.calibration,
                             model_params(params_.model).size() + numbers_of(params_.distortion).values.size());
  }
  if (params_.theta_limit_by_azimuth) {
    for (double a : *params_.theta_limit_by_azimuth) {
      if (!(a >= 0 && a <= std::numbers::pi)) {
        fail("theta_limit_by_azimuth: every sector's limit must be in [0, 180] degrees, got ", a * kDeg);
      }
    }
  }
  domain_ = std::visit([&](const auto& m) { return compute_domain(m, params_.theta_limit); }, params_.model);
  if (displaces(params_.distortion)) {
    // A part evaluated by another library may say on standard error where its own
    // evaluation fails (libmrcal's CAHVORE iteration: "too many iterations"), never to
    // the terminal from here: the scans meet such rays at and past the fold, so the
    // part is asked where it evaluates, and checked over the domain.
    std::string said;
    {
      detail::StderrCapture capture;
      limit_to_plane_fold();
      said = capture.summary();
    }
    const PlaneRadius radius = plane_radius_of(params_.model);
    const std::string part(distortion_name(params_.distortion));
    const std::string what = std::visit([](const auto& d) { return d.description(); }, params_.distortion);
    if (!said.empty()) {
      const std::optional<double> end =
          std::visit([&](const auto& d) { return d.evaluation_end(radius, domain_.theta_max); }, params_.distortion);
      if (!end) {
        fail(part, ": ", what.substr(0, 100),
             " cannot be evaluated next to the end of its domain (it said: ", quoted_for_message(said, 200), ")");
      }
      if (*end < domain_.theta_max) {
        domain_.theta_max = *end;
        domain_.closed = true;
        domain_.rho_max = rho(*end);
      }
    }
    {
      detail::StderrCapture capture;
      bound_plane_reach();
      if (said.empty()) said = capture.summary();
    }
    if (!said.empty()) {
      const std::string problem = std::visit(
          [&](const auto& d) { return d.evaluation_problem(radius, domain_.theta_max); }, params_.distortion);
      if (!problem.empty())
        fail(part, ": ", what.substr(0, 100), " cannot be evaluated everywhere in its domain (", problem, ")");
    }
  }
  table_ =
      std::visit([&](const auto& m) { return std::make_shared<const InverseTable>(m, domain_, table_tolerance_px); },
                 params_.model);
}

void Camera::limit_to_plane_fold() {
  const std::string part(distortion_name(params_.distortion));
  if (const std::string problem = std::visit([](const auto& d) { return d.invalid(); }, params_.distortion);
      !problem.empty()) {
    fail(part, ".", problem);
  }
  const std::vector<std::string> bases = std::visit([](const auto& d) { return d.base_models(); }, params_.distortion);
  if (std::find(bases.begin(), bases.end(), model_name(params_.model)) == bases.end()) {
    fail(part, ": only the ", choices_for_message(bases), " model's undistorted plane takes ",
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

}  // namespace fishcam
