// The source camera in the float kernel's form (kernel_source.hpp): each part's form
// (the radial model's, the plane distortion's, the pixel grid's), OCam's start
// polynomial, the mrcal lenses' tables, and the check of the kernel against the exact
// projection.
#include "kernel_source.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "fishcam/core/parallel.hpp"
#include "grid_warp.hpp"

namespace fishcam::detail {
namespace {

// Float spacing at 8192 is 2^-10 px: coordinates beyond it cannot meet the tolerance.
constexpr double kFloatCoordinateLimit = 8192;

// A double that survives the conversion to float: finite, and not flushed into
// the subnormal range (where float keeps too few digits).
bool float_exact_enough(double x) {
  const double a = std::abs(x);
  return a == 0 || (a >= double(std::numeric_limits<float>::min()) && a <= double(std::numeric_limits<float>::max()));
}

// The float kernel's form of each model; nullopt for a model it has no form for
// (such a camera takes the exact path: never another model's formula).
template <class Model>
std::optional<SourceParams> kernel_model(const Model& m) {
  SourceParams p;
  if constexpr (PolynomialInTheta<Model>) {
    std::vector<double> c = m.power_coefficients();
    while (c.size() > 2 && c.back() == 0) c.pop_back();  // equivalent parameterisations, one kernel input
    if (c.size() - 1 > size_t(detail::RadialForm::kMaxDegree)) return std::nullopt;
    p.radial.kind = SourceParams::Kind::polynomial;
    p.radial.n = static_cast<int>(c.size()) - 1;
    for (size_t i = 0; i < c.size(); ++i) p.radial.c[i] = static_cast<float>(c[i]);
  } else if constexpr (HasUnifiedForm<Model>) {
    const UnifiedForm u = m.unified_form();
    for (double x : {u.f, u.xi, u.alpha, u.beta, u.k1, u.k2, u.k3, u.k4, u.k5, u.k6}) {
      if (!float_exact_enough(x)) return std::nullopt;
    }
    p.radial.kind = SourceParams::Kind::unified;
    p.radial.f = float(u.f), p.radial.xi = float(u.xi), p.radial.alpha = float(u.alpha), p.radial.beta = float(u.beta);
    p.radial.k1 = float(u.k1), p.radial.k2 = float(u.k2), p.radial.k3 = float(u.k3);
    p.radial.k4 = float(u.k4), p.radial.k5 = float(u.k5), p.radial.k6 = float(u.k6);
  } else if constexpr (HasRayPolynomial<Model>) {
    p.radial.kind = SourceParams::Kind::ray_polynomial;  // the start polynomial: ray_polynomial_start()
    for (size_t i = 0; i < 5; ++i) {
      if (!float_exact_enough(m.ray_polynomial()[i])) return std::nullopt;
      p.radial.a[i] = float(m.ray_polynomial()[i]);
    }
  } else {
    return std::nullopt;
  }
  return p;
}

// The ray-polynomial kernel's Newton start: rho(theta) fitted by a polynomial in theta
// (least squares, degree 10) on [0, theta_fit], theta_fit being where rho reaches 1.25
// times the farthest image corner (so past it every ray lands outside the image), or
// the domain's end. False when the fit misses by more than 5 % of that radius; the
// kernel's three Newton steps and float_kernel_agrees decide the rest.
bool ray_polynomial_start(const Camera& camera, SourceParams* p) {
  const Eigen::Matrix2d unskew = camera.skew().matrix().inverse();
  double reach = 0;
  for (double u : {-0.5, camera.width() - 0.5}) {
    for (double v : {-0.5, camera.height() - 0.5}) {
      const Eigen::Vector2d offset =
          (Eigen::Vector2d(u, v) - camera.principal_point()).cwiseQuotient(camera.pixel_scale());
      reach = std::max(reach, (unskew * offset).norm());
    }
  }
  reach *= 1.25;
  const ValidDomain& d = camera.domain();
  const double theta_fit = d.contains_rho(reach) ? camera.theta_from_rho(reach) : d.theta_max;
  if (!(theta_fit > 0)) return false;
  constexpr int kSamples = 400, kDegree = 10;
  std::vector<double> theta(kSamples + 1), rho(kSamples + 1);
  for (int i = 0; i <= kSamples; ++i) {
    theta[size_t(i)] = theta_fit * i / kSamples;
    rho[size_t(i)] = camera.rho(theta[size_t(i)]);
  }
  const PowerSeriesFit fit = fit_power_series(theta, rho, 1, kDegree);
  if (!(fit.worst <= 0.05 * reach)) return false;
  p->radial.n = kDegree;
  p->radial.c[0] = 0;
  for (int j = 0; j < kDegree; ++j) p->radial.c[j + 1] = float(fit.coefficients[size_t(j)]);
  p->radial.theta_fit = float(theta_fit), p->radial.rho_fit = float(camera.rho(theta_fit));
  return true;
}

// Where a lens table must hold: the source image and this margin around it.
constexpr double kLensTableMarginPx = 16;

// The lens's offset at u, or none past reach (the plane radius of the camera's valid
// domain): libmrcal is not asked where no ray of the camera can be, since its own
// iteration fails there and says so on standard error (CAHVORE: "too many iterations").
Eigen::Vector2d lens_offset_within(const MrcalLens& lens, const Eigen::Vector2d& u, double reach) {
  if (!(u.norm() <= reach)) return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  return lens.offset(u);
}

// The bicubic on the cell (cx, cy) of the layout that interpolates f delta_u at 4 x 4
// points (t, s in -1/2, -1/6, 1/6, 1/2 about the cell's centre; g = u * cells_per_u +
// origin): 32 floats as SourceParams::lens_cells keeps them, NaN where a point has no
// projection or past reach. On mrcal's spline cells (MrcalLens::polynomial_cells) it is
// the spline itself, which is that polynomial there. Returns whether a point's pixel
// lies in the image or its margin (always true without an image).
bool lens_kernel_cell(const MrcalLens& lens, const MrcalLens::PolynomialCells& layout, double f, const Camera* image,
                      double reach, int cx, int cy, float* cell) {
  static const Eigen::Matrix4d inverse = [] {
    Eigen::Matrix4d vandermonde;  // rows: the nodes; columns: powers of t
    for (int a = 0; a < 4; ++a) {
      for (int i = 0; i < 4; ++i) vandermonde(a, i) = std::pow(a / 3.0 - 0.5, i);
    }
    return Eigen::Matrix4d(vandermonde.inverse());
  }();
  Eigen::Matrix4d samples[2];
  bool seen = !image;
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) {  // t = a / 3 - 1/2 along x, s = b / 3 - 1/2 along y
      const Eigen::Vector2d g(cx + a / 3.0, cy + b / 3.0);
      const Eigen::Vector2d u = (g - layout.origin) / layout.cells_per_u;
      const Eigen::Vector2d delta = f * lens_offset_within(lens, u, reach);
      samples[0](a, b) = delta.x(), samples[1](a, b) = delta.y();
      if (!seen) {  // the point's pixel, c + a (.) (S f (u + delta))
        const Eigen::Vector2d pixel =
            image->principal_point() + image->pixel_scale().cwiseProduct(image->skew().matrix() * (f * u + delta));
        seen = pixel.x() >= -0.5 - kLensTableMarginPx && pixel.y() >= -0.5 - kLensTableMarginPx &&
               pixel.x() < image->width() - 0.5 + kLensTableMarginPx &&
               pixel.y() < image->height() - 0.5 + kLensTableMarginPx;
      }
    }
  }
  if (!samples[0].allFinite() || !samples[1].allFinite()) {
    std::fill(cell, cell + 32, std::numeric_limits<float>::quiet_NaN());
    return seen;
  }
  for (int k = 0; k < 2; ++k) {
    const Eigen::Matrix4d c = inverse * samples[k] * inverse.transpose();  // c(i, j): t^i s^j
    for (int j = 0; j < 4; ++j) {
      for (int i = 0; i < 4; ++i) cell[16 * k + 4 * j + i] = float(c(i, j));
    }
  }
  return seen;
}

// Every cell of the layout (lens_kernel_cell), row by row; seen (given an image) says
// which cells have a point in it or its margin.
std::vector<float> lens_kernel_cells(const MrcalLens& lens, const MrcalLens::PolynomialCells& layout, double f,
                                     const Camera* image = nullptr,
                                     double reach = std::numeric_limits<double>::infinity(),
                                     std::vector<unsigned char>* seen = nullptr) {
  std::vector<float> out(size_t(layout.nx) * size_t(layout.ny) * 32);
  if (seen) seen->assign(size_t(layout.nx) * size_t(layout.ny), 0);
  cv::parallel_for_(cv::Range(0, layout.ny), [&](const cv::Range& rows) {
    for (int cy = rows.start; cy < rows.end; ++cy) {
      for (int cx = 0; cx < layout.nx; ++cx) {
        const size_t i = size_t(cy) * size_t(layout.nx) + size_t(cx);
        const bool in_image = lens_kernel_cell(lens, layout, f, image, reach, cx, cy, out.data() + 32 * i);
        if (seen) (*seen)[i] = in_image;
      }
    }
  });
  return out;
}

// The table of an mrcal lens without polynomial cells (CAHVOR, CAHVORE, LONLAT,
// LATLON): it must hold where the kernel can need it, the plane points m of the
// source image and kLensTableMarginPx around it (sampled every 1/128 of the image,
// their bounding box widened by 2 % per side; past it a ray lands outside the image:
// float_kernel_agrees checks that), in square cells, 32 across the longer side and
// doubled until the bicubics meet kLensTableTolerancePx at 3 x 3 points between their
// nodes in every cell that sees the image; a cell that does not see it and misses
// the tolerance (next to LONLAT's pole, where the chart is singular) becomes NaN (no
// source). No offset past reach, the plane radius of the domain's end (lens_offset_within).
// nullopt when kLensTableMaxCells per side do not do, or no pixel has a ray.
constexpr double kLensTableTolerancePx = 1e-4;
constexpr int kLensTableMaxCells = 256;

struct LensTable {
  MrcalLens::PolynomialCells layout;
  std::vector<float> cells;
};

std::optional<LensTable> lens_table(const Camera& camera, const MrcalLens& lens, double focal, double xi,
                                    double plane_per_m, double reach) {
  constexpr int kSteps = 128;
  const double x0 = -0.5 - kLensTableMarginPx, y0 = -0.5 - kLensTableMarginPx;
  const double dx = (camera.width() + 2 * kLensTableMarginPx) / kSteps;
  const double dy = (camera.height() + 2 * kLensTableMarginPx) / kSteps;
  std::vector<Eigen::Vector2d> pixels;
  for (int j = 0; j <= kSteps; ++j) {
    for (int i = 0; i <= kSteps; ++i) pixels.emplace_back(x0 + i * dx, y0 + j * dy);
  }
  std::vector<Eigen::Vector3d> rays(pixels.size());
  camera.unproject(pixels, rays);
  Eigen::AlignedBox2d box;
  for (const Eigen::Vector3d& r : rays) {
    const Eigen::Vector2d m = r.head<2>() / (xi * r.norm() + r.z());
    if (m.allFinite()) box.extend(m);
  }
  if (box.isEmpty()) return std::nullopt;
  const Eigen::Vector2d widen = 0.02 * box.sizes();
  box.min() -= widen, box.max() += widen;
  const double longer = box.sizes().maxCoeff();
  if (!(longer > 0) || !std::isfinite(longer)) return std::nullopt;
  const double pixels_per_f = camera.pixel_scale().cwiseAbs().maxCoeff();
  const auto max_nan_first = [](double a, double b) { return std::isnan(a) || a >= b ? a : b; };
  for (int across = 32; across <= kLensTableMaxCells; across *= 2) {
    LensTable table;
    const double h = longer / across;  // the cell's side in m
    MrcalLens::PolynomialCells& layout = table.layout;
    layout.cells_per_u = 1 / (h * plane_per_m);
    layout.origin = -box.min() / h;
    layout.nx = std::max(1, int(std::ceil(box.sizes().x() / h)));
    layout.ny = std::max(1, int(std::ceil(box.sizes().y() / h)));
    std::vector<unsigned char> seen;
    table.cells = lens_kernel_cells(lens, layout, focal, &camera, reach, &seen);
    std::vector<double> row_worst(size_t(layout.ny), 0);
    cv::parallel_for_(cv::Range(0, layout.ny), [&](const cv::Range& rows) {
      for (int cy = rows.start; cy < rows.end; ++cy) {
        double worst = 0;
        for (int cx = 0; cx < layout.nx; ++cx) {
          const size_t index = size_t(cy) * size_t(layout.nx) + size_t(cx);
          float* cell = table.cells.data() + 32 * index;
          if (std::isnan(cell[0])) continue;  // no projection: no source there
          double error = 0;
          for (double t : {-1.0 / 3, 0.0, 1.0 / 3}) {
            for (double s : {-1.0 / 3, 0.0, 1.0 / 3}) {
              const Eigen::Vector2d g(cx + 0.5 + t, cy + 0.5 + s);
              const Eigen::Vector2d exact =
                  focal * lens_offset_within(lens, (g - layout.origin) / layout.cells_per_u, reach);
              Eigen::Vector2d interpolated = Eigen::Vector2d::Zero();
              for (int k = 0; k < 2; ++k) {
                for (int j = 3; j >= 0; --j) {
                  double row = 0;
                  for (int i = 3; i >= 0; --i) row = row * t + cell[16 * k + 4 * j + i];
                  interpolated[k] = interpolated[k] * s + row;
                }
              }
              // A point between the nodes without a projection: NaN, which fails.
              error = max_nan_first(error, pixels_per_f * (interpolated - exact).norm());
            }
          }
          if (seen[index]) {
            worst = max_nan_first(worst, error);
          } else if (!(error <= kLensTableTolerancePx)) {
            std::fill(cell, cell + 32, std::numeric_limits<float>::quiet_NaN());
          }
        }
        row_worst[size_t(cy)] = worst;
      }
    });
    double worst = 0;
    for (double e : row_worst) worst = max_nan_first(worst, e);
    if (worst <= kLensTableTolerancePx) return table;
    // A bicubic's error falls 16-fold per halving of the cells where the offsets are
    // smooth; one that cannot reach the tolerance so (near a chart's pole) stops here.
    if (!(worst <= kLensTableTolerancePx * std::pow(16.0, std::log2(double(kLensTableMaxCells) / across)))) break;
  }
  return std::nullopt;
}

// The float kernel's form of each plane distortion (fishcam/core/plane_distortion.hpp)
// in p; false where float arithmetic cannot be trusted (the warp takes the exact path).
// A part without an overload here does not compile: give it one, returning false if
// the kernel has no form of it.
bool kernel_plane_form(const Camera&, const NoPlaneDistortion&, SourceParams*, KernelSource*) { return true; }

bool kernel_plane_form(const Camera&, const TangentialDistortion& part, SourceParams* p, KernelSource*) {
  // Tangential terms on the unified form's plane m = P_xy / D: alpha = 0 only.
  if (p->radial.kind != SourceParams::Kind::unified || p->radial.alpha != 0) return false;
  const TangentialTerms& t = part.terms;
  for (double x : t.values()) {
    if (!float_exact_enough(x)) return false;
  }
  p->plane.tangential = true;
  p->plane.p1 = float(t.p1), p->plane.p2 = float(t.p2);
  p->plane.s1 = float(t.s[0]), p->plane.s2 = float(t.s[1]), p->plane.s3 = float(t.s[2]), p->plane.s4 = float(t.s[3]);
  return true;
}

bool kernel_plane_form(const Camera& camera, const MrcalLensDistortion& part, SourceParams* p, KernelSource* source) {
  const MrcalLens* lens = part.lens.get();
  // On the stereographic or pinhole plane (unified, alpha = 0): u = m * plane_per_m.
  if (p->radial.kind != SourceParams::Kind::unified || p->radial.alpha != 0) return false;
  std::optional<double> focal, plane_per_m;
  double reach = std::numeric_limits<double>::infinity();  // the plane radius of the domain's end
  std::visit(
      [&](const auto& m) {
        if constexpr (HasUndistortedPlane<std::decay_t<decltype(m)>>) {
          const auto ratio = [&](double theta) {
            double derivative;
            return m.plane_radius(theta, &derivative) * (p->radial.xi + std::cos(theta)) / std::sin(theta);
          };
          focal = m.focal(), plane_per_m = ratio(0.5);
          double derivative;
          reach = m.plane_radius(camera.domain().theta_max, &derivative);
          if (!(std::abs(ratio(1.0) - *plane_per_m) <= 1e-12 * *plane_per_m)) plane_per_m.reset();
        }
      },
      camera.model());
  if (!focal || !plane_per_m) return false;
  std::optional<MrcalLens::PolynomialCells> layout = lens->polynomial_cells();
  if (layout) {
    source->lens_cells = lens_kernel_cells(*lens, *layout, *focal);
    for (float x : source->lens_cells) {  // absolute values in pixels: only overflow matters
      if (!std::isfinite(x)) return false;
    }
  } else {
    std::optional<LensTable> table = lens_table(camera, *lens, *focal, p->radial.xi, *plane_per_m, reach);
    if (!table) return false;
    for (float& x : table->cells) {  // overflow: no projection the kernel can trust
      if (std::isinf(x)) x = std::numeric_limits<float>::quiet_NaN();
    }
    layout = table->layout;
    source->lens_cells = std::move(table->cells);
    p->plane.lens_bounded = true;
  }
  p->plane.lens_nx = layout->nx, p->plane.lens_ny = layout->ny;
  p->plane.lens_scale = float(*plane_per_m * layout->cells_per_u);
  p->plane.lens_origin_x = float(layout->origin.x()), p->plane.lens_origin_y = float(layout->origin.y());
  p->plane.lens_cells = source->lens_cells.data();
  return true;
}

}  // namespace

// The source camera for the float kernel, or null where float arithmetic
// cannot be trusted to kFloatTolerancePx: the one place that decides.
std::shared_ptr<KernelSource> float_source_params(const Camera& camera) {
  // The kernel's domain is a disk (one cos theta_max): a limit per azimuth takes the exact path.
  if (camera.parameters().theta_limit_by_azimuth) return nullptr;
  auto source = std::make_shared<KernelSource>();
  std::optional<SourceParams> p = std::visit([](const auto& m) { return kernel_model(m); }, camera.model());
  if (!p) return nullptr;
  if (p->radial.kind == SourceParams::Kind::ray_polynomial && !ray_polynomial_start(camera, &*p)) return nullptr;
  if (displaces(camera.distortion()) &&
      !std::visit([&](const auto& part) { return kernel_plane_form(camera, part, &*p, source.get()); },
                  camera.distortion())) {
    return nullptr;
  }
  if (camera.skew().any()) {
    for (double x : {camera.skew().xy, camera.skew().yx}) {
      if (!float_exact_enough(x)) return nullptr;
    }
    p->grid.skewed = true;
    p->grid.xy = float(camera.skew().xy), p->grid.yx = float(camera.skew().yx);
  }
  const double cx = camera.principal_point().x(), cy = camera.principal_point().y();
  // Every coordinate the kernel adds up must have float spacing well below the tolerance.
  const double magnitude = std::max({std::abs(cx), std::abs(cy), double(camera.width()), double(camera.height())});
  if (magnitude > kFloatCoordinateLimit) return nullptr;
  for (double x : {cx, cy, camera.pixel_scale().x(), camera.pixel_scale().y()}) {
    if (!float_exact_enough(x)) return nullptr;
  }
  for (int i = 0; i <= p->radial.n; ++i) {
    if (!std::isfinite(p->radial.c[i]) ||
        (p->radial.c[i] != 0 && std::abs(p->radial.c[i]) < std::numeric_limits<float>::min())) {
      return nullptr;
    }
  }
  p->grid.cx = float(cx), p->grid.cy = float(cy);
  p->grid.ax = float(camera.pixel_scale().x()), p->grid.ay = float(camera.pixel_scale().y());
  // A domain up to pi needs no angle test (the kernel excludes the -z axis itself):
  // float rays next to -z have z = -1 exactly, which a cos test would reject.
  p->domain.cos_theta_max =
      camera.domain().theta_max >= std::numbers::pi ? -2.0f : float(std::cos(camera.domain().theta_max));
  p->domain.closed = camera.domain().closed;
  p->grid.width = float(camera.width()), p->grid.height = float(camera.height());
  source->params = *p;
  return source;
}

// The kernel for this CPU against Camera::project over the source's whole valid
// domain: rays at 512 angles (and the last 1e-3, 1e-5 rad of the domain) x 8
// azimuths, seen through the identity and through two rotations. The rotations
// matter: a rotated ray next to the source's -z axis keeps only a float's absolute
// error in its x and y, which rho / chi multiplies (a full-circle fisheye's rim was
// 0.12 px off). True when every pixel inside the image agrees to kFloatTolerancePx
// and so does the inside/outside decision (but within the tolerance of the image
// border or the limit angle).
bool float_kernel_agrees(const Camera& camera, const SourceParams& src) {
  constexpr int kAngles = 512, kAzimuths = 8;
  constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
  const double theta_max = camera.domain().theta_max;
  std::vector<double> thetas;
  for (int a = 0; a < kAngles; ++a) thetas.push_back(theta_max * a / kAngles);
  for (double before : {1e-3, 1e-5}) thetas.push_back(theta_max - before);
  const size_t count = (thetas.size() * kAzimuths + 63) / 64 * 64;  // a multiple of every SIMD width
  std::vector<float> rx(count, kNaNf), ry(count, kNaNf), rz(count, kNaNf), map_x(count), map_y(count);
  std::vector<unsigned char> valid(count);
  std::vector<Eigen::Vector3d> exact(count, Eigen::Vector3d::Constant(kNaNf));
  const double w = camera.width() - 0.5, h = camera.height() - 0.5;
  for (const RigidMotion& change :
       {RigidMotion{}, RigidMotion::from_euler_deg({40, -25, 10}), RigidMotion::from_euler_deg({-90, 0, 35})}) {
    for (size_t a = 0; a < thetas.size(); ++a) {
      for (int k = 0; k < kAzimuths; ++k) {
        const double phi = 2 * std::numbers::pi * (k + 0.25 * double(a % 4)) / kAzimuths;
        const Eigen::Vector3d source_ray(std::sin(thetas[a]) * std::cos(phi), std::sin(thetas[a]) * std::sin(phi),
                                         std::cos(thetas[a]));
        // The kernel's input: the target ray that sees it, in float.
        const Eigen::Vector3d d = change.rotation * source_ray;
        const size_t i = a * kAzimuths + size_t(k);
        rx[i] = float(d.x()), ry[i] = float(d.y()), rz[i] = float(d.z());
        exact[i] = change.rotation.transpose() * Eigen::Vector3d(rx[i], ry[i], rz[i]);  // the very input, exactly
      }
    }
    const detail::RangeKernel kernel = select_kernel_for_cpu(DepthPrior::infinity, true, src.radial.kind, false);
    kernel(rx.data(), ry.data(), rz.data(), 0, count, pose_params(change), src,
           detail::KernelOutput{map_x.data(), map_y.data(), valid.data()});
    for (size_t i = 0; i < count; ++i) {
      if (!exact[i].allFinite()) continue;
      Eigen::Vector2d pixel;
      const bool projects = camera.project(exact[i], &pixel);
      const bool inside = projects && pixel.x() >= -0.5 && pixel.x() < w && pixel.y() >= -0.5 && pixel.y() < h;
      if (inside && valid[i]) {
        if (std::hypot(map_x[i] - pixel.x(), map_y[i] - pixel.y()) > kFloatTolerancePx) return false;
      } else if (inside != bool(valid[i])) {
        const double theta = std::atan2(std::hypot(exact[i].x(), exact[i].y()), exact[i].z());
        const bool at_limit = std::abs(theta - theta_max) < 1e-6;
        const double border = std::min({pixel.x() + 0.5, w - pixel.x(), pixel.y() + 0.5, h - pixel.y()});
        if (!at_limit && !(projects && std::abs(border) <= kFloatTolerancePx)) return false;
      }
    }
  }
  return true;
}

}  // namespace fishcam::detail
