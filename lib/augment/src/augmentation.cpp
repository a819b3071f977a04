#include "fishcam/augment/augmentation.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <numbers>

#include "grid_warp.hpp"
#include "warp_kernel.hpp"

namespace fishcam {
namespace detail {

PoseParams pose_params(const ViewpointChange& change) {
  PoseParams p;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) p.rt[3 * r + k] = float(change.rotation(k, r));
  }
  for (int k = 0; k < 3; ++k) p.t[k] = float(change.translation[k]);
  p.c = float(change.translation.squaredNorm() - 1);
  return p;
}

// The kernel for this CPU: AVX2 + FMA where available, else the build's baseline.
// FISHCAM_NO_AVX2 (set to anything) forces the baseline: how the tests cover it.
bool use_avx2() {
  static const bool avx2 =
      !std::getenv("FISHCAM_NO_AVX2") && cv::checkHardwareSupport(CV_CPU_AVX2) && cv::checkHardwareSupport(CV_CPU_FMA3);
  return avx2;
}

RangeKernel select_kernel_for_cpu(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  return use_avx2() ? select_kernel_avx2(prior, inside_sphere, kind, sampling)
                    : select_kernel_baseline(prior, inside_sphere, kind, sampling);
}

GridRowLoops grid_row_loops_for_cpu() { return use_avx2() ? grid_row_loops_avx2() : grid_row_loops_baseline(); }

}  // namespace detail
namespace {

// Whether two matrices' buffers overlap (an output given its own input).
bool shares_memory(const cv::Mat& a, const cv::Mat& b) {
  return !a.empty() && !b.empty() && a.datastart < b.dataend && b.datastart < a.dataend;
}

using detail::pose_params;
using detail::PoseParams;
using detail::select_kernel_for_cpu;
using detail::SourceParams;
static_assert(detail::kOutside == kOutsideSource);

// The float kernel is used only where it agrees with the exact path to this.
constexpr double kFloatTolerancePx = 1e-3;
// Float spacing at 8192 is 2^-10 px: coordinates beyond it cannot meet the tolerance.
constexpr double kFloatCoordinateLimit = 8192;
// cv::remap's own limit on image sizes (it asserts otherwise).
constexpr int kRemapSizeLimit = 32767;

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

// SourceParams with the arrays its pointers refer to.
struct KernelSource {
  SourceParams params;
  std::vector<float> lens_cells;
};

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

// The source camera for the float kernel, or null where float arithmetic
// cannot be trusted to kFloatTolerancePx: the one place that decides.
std::shared_ptr<KernelSource> float_source_params(const Camera& camera) {
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

void allocate(const Camera& source, const Camera& target, MapKind kind, WarpMaps* maps) {
  maps->kind = kind;
  maps->source_size = cv::Size(source.width(), source.height());
  maps->map_x.create(target.height(), target.width(), CV_32FC1);
  maps->map_y.create(target.height(), target.width(), CV_32FC1);
  if (kind == MapKind::geometric) {
    maps->valid.create(target.height(), target.width(), CV_8UC1);
  } else {
    maps->valid.release();
  }
}

}  // namespace

std::optional<Eigen::Vector3d> source_point(const Eigen::Vector3d& d, const ViewpointChange& change, DepthPrior prior) {
  const Eigen::Vector3d& t = change.translation;
  Eigen::Vector3d q = d;
  if (prior == DepthPrior::target_sphere) {
    q = d - t;
  } else if (prior == DepthPrior::source_sphere) {
    const double b = d.dot(t), c = t.squaredNorm() - 1, disc = b * b - c;
    double s;
    if (c < 0) {
      const double sq = std::sqrt(disc);
      s = b >= 0 ? b + sq : -c / (sq - b);
    } else {
      if (!(disc >= 0) || !(b > 0)) return std::nullopt;
      s = c / (b + std::sqrt(disc));
      if (!(s > 0)) return std::nullopt;
    }
    q = s * d - t;
  }
  const double norm = q.norm();
  if (!(norm > 0) || !std::isfinite(norm)) return std::nullopt;
  return Eigen::Vector3d(change.rotation.transpose() * q / norm);
}

namespace {

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
  for (const ViewpointChange& change : {ViewpointChange{}, ViewpointChange::from_euler_deg({40, -25, 10}),
                                        ViewpointChange::from_euler_deg({-90, 0, 35})}) {
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

}  // namespace

namespace {

void check_size(const cv::Mat& image, cv::Size source, const char* what) {
  if (image.empty()) throw Error(std::string(what) + ": empty image");
  if (image.size() != source) {
    throw Error(std::string(what) + ": image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                " but the source camera is " + std::to_string(source.width) + "x" + std::to_string(source.height));
  }
}

void check_maps(const WarpMaps& maps, const char* what) {
  if (maps.map_x.empty()) throw Error(std::string(what) + ": no maps computed");
}

void check_image_input(const cv::Mat& image, cv::Size source, double fill, const char* what) {
  check_size(image, source, what);
  if (image.depth() != CV_8U && image.depth() != CV_16U && image.depth() != CV_32F) {
    throw Error(std::string(what) + ": expected an 8- or 16-bit or float32 image");
  }
  if (image.channels() < 1 || image.channels() > 4) throw Error(std::string(what) + ": expected 1 to 4 channels");
  if (!std::isfinite(fill)) throw Error(std::string(what) + ": fill must be finite");
}

void check_label_input(const cv::Mat& labels, cv::Size source, int fill, const char* what) {
  check_size(labels, source, what);
  if (labels.channels() != 1 || (labels.depth() != CV_8U && labels.depth() != CV_16U)) {
    throw Error(std::string(what) + ": expected a single-channel 8- or 16-bit label image");
  }
  const int max_label = labels.depth() == CV_8U ? 255 : 65535;
  if (fill < 0 || fill > max_label) throw Error(std::string(what) + ": fill value does not fit the label image");
}

}  // namespace

ViewpointWarp::ViewpointWarp(Camera source, Camera target) : source_(std::move(source)), target_(std::move(target)) {
  for (const Camera* c : {&source_, &target_}) {
    if (c->width() >= kRemapSizeLimit || c->height() >= kRemapSizeLimit) {
      throw Error("ViewpointWarp: image size " + std::to_string(c->width()) + "x" + std::to_string(c->height()) +
                  " exceeds the resampling limit (cv::remap: fewer than " + std::to_string(kRemapSizeLimit) +
                  " pixels per side)");
    }
  }
  const std::shared_ptr<KernelSource> src = float_source_params(source_);
  if (!src || !float_kernel_agrees(source_, src->params)) return;           // the exact path needs no cached rays
  kernel_source_ = std::shared_ptr<const SourceParams>(src, &src->params);  // which keeps its arrays
  const size_t n = size_t(target_.width()) * size_t(target_.height());
  const size_t padded = (n + 63) / 64 * 64 + 64;  // whole vectors, and one more for kernels started mid-row
  rays_.create(3, static_cast<int>(padded), CV_32FC1);
  float* planes[3] = {rays_.ptr<float>(0), rays_.ptr<float>(1), rays_.ptr<float>(2)};
  target_.unproject_image(std::span<float>(planes[0], padded), std::span<float>(planes[1], padded),
                          std::span<float>(planes[2], padded), InversePath::table);
  for (float* plane : planes) std::fill(plane + n, plane + padded, std::numeric_limits<float>::quiet_NaN());
  grid_ = detail::make_grid_plan(source_, target_, *kernel_source_, rays_);
}

void ViewpointWarp::compute_grid(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps) const {
  check_change(change);
  if (grid_ && detail::grid_maps(*grid_, *kernel_source_, rays_, target_, change, prior, maps)) return;
  compute(change, prior, maps, MapKind::geometric);
}

int ViewpointWarp::grid_spacing() const { return grid_ ? grid_->spacing : 0; }
double ViewpointWarp::grid_error_px() const { return grid_ ? grid_->measured_error_px : 0; }

void ViewpointWarp::forward(const ViewpointChange& change, DepthPrior prior,
                            std::span<const Eigen::Vector2d> source_pixels, std::span<Eigen::Vector2d> pixels,
                            std::span<std::uint8_t> visible) const {
  check_change(change);
  if (pixels.size() != source_pixels.size() || visible.size() != source_pixels.size()) {
    throw Error("ViewpointWarp::forward: outputs of the wrong size");
  }
  const double w = target_.width() - 0.5, h = target_.height() - 0.5;
  const Eigen::Vector3d& t = change.translation;
  for (size_t i = 0; i < source_pixels.size(); ++i) {
    pixels[i] = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    visible[i] = 0;
    Eigen::Vector3d ray;
    if (!source_.unproject(source_pixels[i], &ray)) continue;
    const Eigen::Vector3d rotated = change.rotation * ray;
    Eigen::Vector3d d = rotated;  // infinity: the direction alone
    if (prior == DepthPrior::source_sphere) {
      d = rotated + t;
    } else if (prior == DepthPrior::target_sphere) {
      // d = t + lambda R p with |d| = 1 and lambda > 0 (the larger root).
      const double b = rotated.dot(t), disc = b * b - (t.squaredNorm() - 1);
      if (!(disc >= 0)) continue;
      const double lambda = -b + std::sqrt(disc);
      if (!(lambda > 0)) continue;
      d = t + lambda * rotated;
    }
    const double norm = d.norm();
    if (!(norm > 0) || !std::isfinite(norm)) continue;
    d /= norm;
    Eigen::Vector2d pixel;
    if (!target_.project(d, &pixel)) continue;
    pixels[i] = pixel;
    const auto back = source_point(d, change, prior);
    visible[i] =
        pixel.x() >= -0.5 && pixel.x() < w && pixel.y() >= -0.5 && pixel.y() < h && back && (*back - ray).norm() < 1e-9;
  }
}

void ViewpointWarp::warp_depth(const ViewpointChange& change, DepthPrior prior, const cv::Mat& depth,
                               DepthValues values, cv::Mat* out, float fill) const {
  if (depth.type() != CV_32FC1) throw Error("warp_depth: expected a float32 single-channel depth map");
  if (depth.cols != source_.width() || depth.rows != source_.height()) {
    throw Error("warp_depth: the depth map is " + std::to_string(depth.cols) + "x" + std::to_string(depth.rows) +
                " but the camera is " + std::to_string(source_.width()) + "x" + std::to_string(source_.height()));
  }
  WarpMaps maps;
  compute(change, prior, &maps, MapKind::sampling);
  cv::remap(depth, *out, maps.map_x, maps.map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(fill));
  if (change.is_identity()) return;
  const int width = target_.width();
  // The output's rays: cached by the float path (NaN where none), else unprojected.
  const bool cached = !rays_.empty();
  cv::parallel_for_(cv::Range(0, target_.height()), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      float* row = out->ptr<float>(v);
      const float* source_x = maps.map_x.ptr<float>(v);
      for (int u = 0; u < width; ++u) {
        const double value = row[u];
        if (source_x[u] == kOutsideSource || !(value > 0) || !std::isfinite(value)) continue;
        Eigen::Vector3d d;
        bool ray = false;
        if (cached) {
          const size_t i = size_t(v) * size_t(width) + size_t(u);
          d = Eigen::Vector3d(rays_.ptr<float>(0)[i], rays_.ptr<float>(1)[i], rays_.ptr<float>(2)[i]);
          ray = d.allFinite();
        } else {
          ray = target_.unproject(Eigen::Vector2d(u, v), &d);
        }
        std::optional<Eigen::Vector3d> s;
        if (ray) s = source_point(d.normalized(), change, prior);
        if (!s || (values == DepthValues::z && !(s->z() > 0))) {
          row[u] = std::numeric_limits<float>::quiet_NaN();  // no ray to re-express along
          continue;
        }
        const Eigen::Vector3d point =
            change.rotation * (*s * (values == DepthValues::z ? value / s->z() : value)) + change.translation;
        row[u] = float(values == DepthValues::z ? point.z() : point.norm());
      }
    }
  });
}

std::optional<MapKind> parse_map_kind(std::string_view name) {
  if (name == "sampling") return MapKind::sampling;
  if (name == "geometric") return MapKind::geometric;
  return std::nullopt;
}

std::string_view to_string(MapKind kind) { return kind == MapKind::sampling ? "sampling" : "geometric"; }

const std::vector<std::string>& map_kind_names() {
  static const std::vector<std::string> names = {std::string(to_string(MapKind::sampling)),
                                                 std::string(to_string(MapKind::geometric))};
  return names;
}

std::optional<DepthValues> parse_depth_values(std::string_view name) {
  if (name == "range") return DepthValues::range;
  if (name == "z") return DepthValues::z;
  return std::nullopt;
}

std::string_view to_string(DepthValues values) { return values == DepthValues::range ? "range" : "z"; }

const std::vector<std::string>& depth_values_names() {
  static const std::vector<std::string> names = {std::string(to_string(DepthValues::range)),
                                                 std::string(to_string(DepthValues::z))};
  return names;
}

std::optional<Sampling> parse_sampling(std::string_view name) {
  if (name == "grid") return Sampling::grid;
  if (name == "exact") return Sampling::exact;
  return std::nullopt;
}

std::string_view to_string(Sampling sampling) { return sampling == Sampling::grid ? "grid" : "exact"; }

const std::vector<std::string>& sampling_names() {
  static const std::vector<std::string> names = {std::string(to_string(Sampling::grid)),
                                                 std::string(to_string(Sampling::exact))};
  return names;
}

void ViewpointWarp::augment(const ViewpointChange& change, DepthPrior prior, const AugmentIO& io,
                            Sampling sampling) const {
  check_change(change);
  const cv::Size source(source_.width(), source_.height());
  if (io.image) check_image_input(*io.image, source, io.fill, "image");
  if (io.labels) check_label_input(*io.labels, source, io.label_fill, "labels");
  if ((io.image && !io.out_image) || (io.labels && !io.out_labels)) throw Error("augment: an input without its output");
  // An output in the memory of its input would be read while it is written: sample a copy.
  AugmentIO safe = io;
  cv::Mat image_copy, labels_copy;
  if (io.image && shares_memory(*io.image, *io.out_image)) safe.image = &(image_copy = io.image->clone());
  if (io.labels && shares_memory(*io.labels, *io.out_labels)) safe.labels = &(labels_copy = io.labels->clone());
  if (sampling == Sampling::grid && grid_ &&
      detail::grid_augment(*grid_, *kernel_source_, rays_, target_, change, prior, safe)) {
    return;
  }
  WarpMaps maps;
  compute(change, prior, &maps);
  if (safe.image) warp_image(*safe.image, maps, safe.out_image, safe.fill);
  if (safe.labels) warp_labels(*safe.labels, maps, safe.label_fill, safe.out_labels);
  if (safe.valid) maps.validity().copyTo(*safe.valid);
}

void ViewpointWarp::compute(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps, MapKind kind) const {
  check_change(change);
  if (!kernel_source_) return compute_double(change, prior, maps, kind);
  allocate(source_, target_, kind, maps);
  const SourceParams& src = *kernel_source_;
  const PoseParams pose = pose_params(change);
  const bool sampling = kind == MapKind::sampling;
  const detail::RangeKernel kernel =
      select_kernel_for_cpu(prior, change.translation.squaredNorm() < 1, src.radial.kind, sampling);
  const detail::KernelOutput out{maps->map_x.ptr<float>(), maps->map_y.ptr<float>(),
                                 sampling ? nullptr : maps->valid.ptr<uchar>()};
  const size_t n = size_t(target_.width()) * size_t(target_.height());
  constexpr size_t kChunk = 16384;  // a multiple of every SIMD width
  const int chunks = static_cast<int>((n + kChunk - 1) / kChunk);
  std::atomic<long> invalid{0};
  cv::parallel_for_(cv::Range(0, chunks), [&](const cv::Range& r) {
    const size_t begin = size_t(r.start) * kChunk, end = std::min(n, size_t(r.end) * kChunk);
    invalid += kernel(rays_.ptr<float>(0), rays_.ptr<float>(1), rays_.ptr<float>(2), begin, end, pose, src, out);
  });
  maps->invalid_count = invalid;
}

void ViewpointWarp::compute_exact(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps) const {
  check_change(change);
  compute_double(change, prior, maps, MapKind::geometric);
}

void ViewpointWarp::compute_double(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps,
                                   MapKind kind) const {
  allocate(source_, target_, kind, maps);
  std::atomic<long> invalid{0};
  const double w = source_.width() - 0.5, h = source_.height() - 0.5;
  const float max_x = float(source_.width() - 1), max_y = float(source_.height() - 1);
  cv::parallel_for_(cv::Range(0, target_.height()), [&](const cv::Range& rows) {
    long local = 0;
    for (int v = rows.start; v < rows.end; ++v) {
      float* out_x = maps->map_x.ptr<float>(v);
      float* out_y = maps->map_y.ptr<float>(v);
      for (int u = 0; u < target_.width(); ++u) {
        Eigen::Vector3d ray;
        Eigen::Vector2d pixel(std::nan(""), std::nan(""));
        if (target_.unproject(Eigen::Vector2d(u, v), &ray)) {
          if (const auto p = source_point(ray, change, prior)) source_.project(*p, &pixel);
        }
        const bool ok = pixel.x() >= -0.5 && pixel.x() < w && pixel.y() >= -0.5 && pixel.y() < h;
        local += !ok;
        if (kind == MapKind::geometric) {
          out_x[u] = float(pixel.x()), out_y[u] = float(pixel.y());
          maps->valid.ptr<uchar>(v)[u] = ok;
        } else {  // as the kernel's sampling maps: clamped onto the outer pixel centres, or far outside
          out_x[u] = ok ? std::clamp(float(pixel.x()), 0.0f, max_x) : kOutsideSource;
          out_y[u] = ok ? std::clamp(float(pixel.y()), 0.0f, max_y) : kOutsideSource;
        }
      }
    }
    invalid += local;
  });
  maps->invalid_count = invalid;
}

cv::Mat WarpMaps::validity() const {
  if (kind == MapKind::geometric) return valid;
  cv::Mat inside = map_x != kOutsideSource;  // 0 or 255
  return inside & 1;
}

void warp_image(const cv::Mat& image, const WarpMaps& maps, cv::Mat* out, double fill) {
  check_maps(maps, "warp_image");
  check_image_input(image, maps.source_size, fill, "warp_image");
  if (maps.kind == MapKind::sampling) {
    // Sources inside the image were clamped onto it; the rest are far outside.
    cv::remap(image, *out, maps.map_x, maps.map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(fill));
    return;
  }
  // Geometric maps: replicating the border only affects the outermost half pixel
  // (still inside the image); everything else is set by the mask, whatever remap
  // made of NaN coordinates.
  cv::remap(image, *out, maps.map_x, maps.map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  if (maps.invalid_count > 0) out->setTo(cv::Scalar::all(fill), maps.valid == 0);
}

void warp_labels(const cv::Mat& labels, const WarpMaps& maps, int fill, cv::Mat* out) {
  check_maps(maps, "warp_labels");
  check_label_input(labels, maps.source_size, fill, "warp_labels");
  cv::remap(labels, *out, maps.map_x, maps.map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(fill));
  if (maps.kind == MapKind::geometric && maps.invalid_count > 0) out->setTo(cv::Scalar(fill), maps.valid == 0);
}

}  // namespace fishcam
