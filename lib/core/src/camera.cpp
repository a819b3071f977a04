#include "fishcam/core/camera.hpp"
#include "fishcam/core/error.hpp"
#include "fishcam/core/parallel.hpp"
#include "point_projection.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>

// A camera's projection and unprojection, of one point and of batches (the parts are
// visited once per call or batch). Construction and the domain: camera_domain.cpp;
// operations on the parameters: camera_parameters.cpp.

namespace fishcam {
namespace {

using detail::kDeg;
using detail::kNaN;
using detail::project_point;
using detail::ray_of_point;
using detail::theta_of;
using detail::visit_parts;

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
  const Eigen::Vector2d c = params.grid.principal_point, inv_scale = params.grid.pixel_scale.cwiseInverse();
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

double Camera::rho(double theta) const {
  return std::visit([&](const auto& m) { return m.rho(theta); }, params_.model);
}

double Camera::drho(double theta) const {
  return std::visit([&](const auto& m) { return m.drho(theta); }, params_.model);
}

double Camera::theta_from_rho(double rho) const {
  return std::visit([&](const auto& m) { return theta_of(m, domain_, *table_, rho, InversePath::robust); },
                    params_.model);
}

double Camera::theta_from_rho_table(double rho) const {
  return std::visit([&](const auto& m) { return theta_of(m, domain_, *table_, rho, InversePath::table); },
                    params_.model);
}

double Camera::rho_of_pixel(const Eigen::Vector2d& pixel) const {
  return (pixel - params_.grid.principal_point).cwiseQuotient(params_.grid.pixel_scale).norm();
}

bool Camera::project(const Eigen::Vector3d& point, Eigen::Vector2d* pixel,
                     Eigen::Matrix<double, 2, 3>* jacobian) const {
  const std::array<double, 4> mapping = params_.grid.mapping();
  return visit_parts(params_, [&](const auto& m, const auto& part) {
    return jacobian ? project_point<true>(m, part, params_, mapping.data(), domain_, point, pixel, jacobian)
                    : project_point<false>(m, part, params_, mapping.data(), domain_, point, pixel, nullptr);
  });
}

bool Camera::unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d* ray) const {
  const Eigen::Vector2d s = params_.grid.skewed_offset(pixel);
  const bool ok = visit_parts(params_, [&](const auto& m, const auto& part) {
    return ray_of_point(m, part, params_, domain_, *table_, s.x(), s.y(), InversePath::robust, ray->data());
  });
  if (!ok) ray->setConstant(kNaN);
  return ok;
}

void Camera::project(std::span<const Eigen::Vector3d> points, std::span<Eigen::Vector2d> pixels,
                     std::span<std::uint8_t> valid) const {
  if (pixels.size() != points.size() || (!valid.empty() && valid.size() != points.size())) {
    throw Error("project: output sizes must match the number of points");
  }
  const std::array<double, 4> mapping = params_.grid.mapping();
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
  const Eigen::Vector2d c = params_.grid.principal_point, inv_scale = params_.grid.pixel_scale.cwiseInverse();
  visit_parts(params_, [&](const auto& m, const auto& part) {
    parallel_chunks(pixels.size(), [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        const double x = (pixels[i].x() - c.x()) * inv_scale.x(), y = (pixels[i].y() - c.y()) * inv_scale.y();
        const bool ok = ray_of_point(m, part, params_, domain_, *table_, x, y, path, rays[i].data());
        if (!ok) rays[i].setConstant(kNaN);
        if (!valid.empty()) valid[i] = ok;
      }
    });
  });
}

void Camera::unproject_image(std::span<float> rays_xyz, InversePath path) const {
  const size_t n = static_cast<size_t>(params_.width) * static_cast<size_t>(params_.height);
  if (rays_xyz.size() != 3 * n) throw Error("unproject_image: output must hold 3 * width * height floats");
  unproject_pixels<3>(params_, domain_, *table_, rays_xyz.data(), rays_xyz.data() + 1, rays_xyz.data() + 2, path);
}

void Camera::unproject_image(std::span<float> x, std::span<float> y, std::span<float> z, InversePath path) const {
  const size_t n = static_cast<size_t>(params_.width) * static_cast<size_t>(params_.height);
  if (x.size() < n || y.size() < n || z.size() < n) {
    throw Error("unproject_image: each output plane must hold width * height floats");
  }
  unproject_pixels<1>(params_, domain_, *table_, x.data(), y.data(), z.data(), path);
}

Camera::FieldOfView Camera::field_of_view_deg() const {
  const double w = params_.width - 0.5, h = params_.height - 0.5, cx = params_.grid.principal_point.x(),
               cy = params_.grid.principal_point.y();
  const bool centred = cx >= -0.5 && cx <= w && cy >= -0.5 && cy <= h;
  // What the image sees between two points of its border, along the line between them
  // (through the principal point when it lies in the image): the angles of the
  // rays of the pixels that have one, never the model's domain where no pixel reaches.
  constexpr int kSamples = 512;
  const auto across = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    if (centred && radial() &&
        !params_.theta_limit_by_azimuth) {  // exact: the domain is a disk about the principal point
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
