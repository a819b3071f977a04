#include "grid_warp.hpp"

#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <mutex>
#include <numbers>
#include <optional>
#include <vector>

namespace fishcam::detail {
namespace {

// cv::remap's fixed-point step: INTER_BITS fractional bits per coordinate.
constexpr int kFractionBits = cv::INTER_BITS;
constexpr int kFractions = 1 << kFractionBits;  // 32
// The interpolation error allowed at construction: one fixed-point step less the
// float kernel's own tolerance against the exact maps.
constexpr double kGridTolerancePx = 1.0 / kFractions - 1e-3;
// A spacing is taken only if it interpolates at least this share of the cells with
// a source over the measured changes (else a finer one, whose cells bend less, is faster).
constexpr double kMinInterpolatedShare = 0.8;
// Floats past a row's end in the row buffers: interpolation writes whole cells,
// and the spacing-4 loop whole vectors of them.
constexpr std::size_t kRowPadding = 64;
// Output rows per tile: a multiple of every spacing, the maps of a tile stay in cache.
constexpr int kTileRows = 16;
// bilinear_8u's offsets are 32-bit: larger images are interpolated by cv::remap.
constexpr std::ptrdiff_t kMaxFusedImageBytes = std::ptrdiff_t(1) << 31;

std::size_t padded(std::size_t n) { return (n + 63) / 64 * 64 + 64; }  // whole vectors, and one more to read past

// The source coordinates at the nodes of one change (NaN where a node has no source).
struct NodeMaps {
  std::vector<float> x, y;
  std::vector<unsigned char> valid;
};

void node_maps(const GridPlan& plan, const SourceParams& src, const PoseParams& pose, RangeKernel kernel,
               NodeMaps* out) {
  const std::size_t n = std::size_t(plan.nodes_u) * std::size_t(plan.nodes_v);
  out->x.resize(n);
  out->y.resize(n);
  out->valid.resize(n);
  constexpr std::size_t kChunk = 4096;  // a multiple of every SIMD width
  cv::parallel_for_(cv::Range(0, int((n + kChunk - 1) / kChunk)), [&](const cv::Range& r) {
    kernel(plan.node_rays.ptr<float>(0), plan.node_rays.ptr<float>(1), plan.node_rays.ptr<float>(2),
           std::size_t(r.start) * kChunk, std::min(n, std::size_t(r.end) * kChunk), pose, src,
           KernelOutput{out->x.data(), out->y.data(), out->valid.data()});
  });
}

// Whether nodes lie away from a fold (cells_ok asks only when the source camera has
// one): inside the guard radius in the source's normalised coordinates times its
// largest pixel scale. False for NaN.
struct FoldGuard {
  float cx, cy, kx, ky, radius2;
  FoldGuard(const GridPlan& plan, const SourceParams& src)
      : cx(src.grid.cx),
        cy(src.grid.cy),
        kx(std::max(src.grid.ax, src.grid.ay) / src.grid.ax),
        ky(std::max(src.grid.ax, src.grid.ay) / src.grid.ay),
        radius2(plan.fold_guard_radius * plan.fold_guard_radius) {}
  bool operator()(float x, float y) const {
    const float dx = (x - cx) * kx, dy = (y - cy) * ky;
    return dx * dx + dy * dy < radius2;
  }
};

// Scratch space of one thread for a row: the node columns interpolated to the row.
struct RowScratch {
  std::vector<float> column_x, column_y;
  explicit RowScratch(const GridPlan& plan)  // vectors may read past the last node
      : column_x(std::size_t(plan.nodes_u) + 16), column_y(std::size_t(plan.nodes_u) + 16) {}
};

// One output row v, interpolated from the nodes in every cell (cells that are not
// interpolated get whatever the nodes give, NaN included: grid_row overwrites them).
// x and y hold kRowPadding floats past the row: whole cells are written.
void interpolate_row(const GridPlan& plan, const NodeMaps& nodes, int v, int width, float* x, float* y,
                     RowScratch* scratch) {
  const int s = plan.spacing, j = v / s, n = plan.nodes_u;
  const float b = float(v - j * s) / float(s);
  const std::size_t row0 = std::size_t(j) * std::size_t(n), row1 = row0 + std::size_t(n);
  float* cx = scratch->column_x.data();
  float* cy = scratch->column_y.data();
  // Down the node columns first (contiguous: vectorised by the compiler), then across.
  for (int i = 0; i < n; ++i) {
    cx[i] = nodes.x[row0 + std::size_t(i)] + b * (nodes.x[row1 + std::size_t(i)] - nodes.x[row0 + std::size_t(i)]);
    cy[i] = nodes.y[row0 + std::size_t(i)] + b * (nodes.y[row1 + std::size_t(i)] - nodes.y[row0 + std::size_t(i)]);
  }
  const int cells = (width + s - 1) / s;
  if (s == 4) {
    static const GridRowLoops loops = grid_row_loops_for_cpu();
    loops.interpolate4(cx, cy, cells, x, y);
    return;
  }
  const float step = 1.0f / float(s);
  for (int i = 0; i < cells; ++i) {
    const float dx = (cx[i + 1] - cx[i]) * step, dy = (cy[i + 1] - cy[i]) * step;
    for (int a = 0; a < s; ++a) {
      x[i * s + a] = cx[i] + float(a) * dx;
      y[i * s + a] = cy[i] + float(a) * dy;
    }
  }
}

// What one change needs before any row (prepare() below): its pose, the kernel, the
// nodes and which cells are interpolated.
struct GridChange {
  PoseParams pose;
  RangeKernel geometric;
  NodeMaps nodes;
  std::vector<unsigned char> ok;
};

// The source coordinates of output row v: interpolated in interpolated cells, by
// the kernel per pixel elsewhere.
void grid_row(const GridPlan& plan, const GridChange& change, const SourceParams& src, const cv::Mat& pixel_rays, int v,
              int w, float* x, float* y, unsigned char* in, RowScratch* scratch) {
  interpolate_row(plan, change.nodes, v, w, x, y, scratch);
  const int s = plan.spacing, cells = (w + s - 1) / s;
  const unsigned char* ok_row = change.ok.data() + std::size_t(v / s) * std::size_t(plan.nodes_u - 1);
  const std::size_t row = std::size_t(v) * std::size_t(w);
  for (int i = 0; i < cells;) {
    if (ok_row[i]) {
      ++i;
      continue;
    }
    int end = i;
    while (end < cells && !ok_row[end]) ++end;
    // The row's rays from its first pixel on, so the kernel writes the row's buffers.
    change.geometric(pixel_rays.ptr<float>(0) + row, pixel_rays.ptr<float>(1) + row, pixel_rays.ptr<float>(2) + row,
                     std::size_t(i * s), std::size_t(std::min(w, end * s)), change.pose, src, KernelOutput{x, y, in});
    i = end;
  }
}

// Which cells are interpolated: every corner has a source (finite coordinates,
// away from a fold), all four or none inside the source image (cells across its
// border are decided per pixel), and the map bends little enough there.
// Bilinear interpolation over a cell of side S errs by at most S^2/8 (|f_uu| +
// |f_vv|) (the cross term it reproduces); the second differences of the nodes,
// (|D2u f| + |D2v f|) / 8, estimate that at each node, and a cell is interpolated
// only where its corners' estimates stay within kCurvatureBudgetPx (the measurement
// at construction checks the result).
constexpr float kCurvatureBudgetPx = float(kGridTolerancePx);

std::vector<unsigned char> cells_ok(const GridPlan& plan, const SourceParams& src, const NodeMaps& nodes) {
  const int nu = plan.nodes_u, nv = plan.nodes_v, cu = nu - 1, cv_ = nv - 1;
  const float* x = nodes.x.data();
  const float* y = nodes.y.data();
  const bool fold = plan.fold_guard_radius != std::numeric_limits<float>::infinity();
  const FoldGuard guard(plan, src);
  constexpr float kInfinity = std::numeric_limits<float>::infinity();
  // The curvature estimate per node, squared (NaN where the node or a neighbour has
  // no source: such cells fail the comparison below); the outer nodes take their
  // inner neighbour's; infinite next to a fold.
  std::vector<float> bend(nodes.x.size());
  cv::parallel_for_(cv::Range(0, nv), [&](const cv::Range& rows) {
    for (int j = rows.start; j < rows.end; ++j) {
      const std::size_t row = std::size_t(j) * std::size_t(nu);
      const std::size_t centre = std::size_t(std::clamp(j, 1, nv - 2)) * std::size_t(nu);
      float* out = bend.data() + row;
      for (int i = 1; i + 1 < nu; ++i) {
        const std::size_t k = centre + std::size_t(i);
        const float ex = std::abs(x[k - 1] + x[k + 1] - 2 * x[k]) + std::abs(x[k - nu] + x[k + nu] - 2 * x[k]);
        const float ey = std::abs(y[k - 1] + y[k + 1] - 2 * y[k]) + std::abs(y[k - nu] + y[k + nu] - 2 * y[k]);
        out[i] = (ex * ex + ey * ey) * (1.0f / 64);
      }
      out[0] = out[1];
      out[nu - 1] = out[nu - 2];
      if (fold) {
        const float* node_x = x + row;
        const float* node_y = y + row;
        for (int i = 0; i < nu; ++i) out[i] = guard(node_x[i], node_y[i]) ? out[i] : kInfinity;
      }
    }
  });
  constexpr float budget = kCurvatureBudgetPx * kCurvatureBudgetPx;
  std::vector<unsigned char> ok(std::size_t(cu) * std::size_t(cv_));
  cv::parallel_for_(cv::Range(0, cv_), [&](const cv::Range& rows) {
    for (int j = rows.start; j < rows.end; ++j) {
      const std::size_t a0 = std::size_t(j) * std::size_t(nu);
      for (int i = 0; i < cu; ++i) {
        const std::size_t a = a0 + std::size_t(i), b = a + std::size_t(nu);
        // Corners on both sides of the source image's border: the decision is made per pixel by the kernel.
        const int inside = nodes.valid[a] + nodes.valid[a + 1] + nodes.valid[b] + nodes.valid[b + 1];
        ok[std::size_t(j) * std::size_t(cu) + std::size_t(i)] = (inside == 0 || inside == 4) && bend[a] <= budget &&
                                                                bend[a + 1] <= budget && bend[b] <= budget &&
                                                                bend[b + 1] <= budget;
      }
    }
  });
  return ok;
}

// Labels of one output row by their rounded source pixels (kOutsideFixed: the fill),
// what cv::remap with INTER_NEAREST and BORDER_CONSTANT gives for the same map.
template <class Label>
void gather_labels(const cv::Mat& labels, const short* nearest, int w, int fill, Label* out) {
  const Label filled = static_cast<Label>(fill);
  const auto* base = labels.ptr<Label>(0);
  const std::size_t step = labels.step1();
  for (int u = 0; u < w; ++u) {
    const short sx = nearest[2 * u], sy = nearest[2 * u + 1];
    out[u] = sx == kOutsideFixed ? filled : base[std::size_t(sy) * step + std::size_t(sx)];
  }
}

// The nodes' rays for spacing s (the target's unprojection of each node pixel).
cv::Mat node_rays_for(const Camera& target, int s, int* nodes_u, int* nodes_v) {
  *nodes_u = (target.width() - 1 + s - 1) / s + 1 + 1;  // past the last pixel: every row lies inside a cell
  *nodes_v = (target.height() - 1 + s - 1) / s + 1 + 1;
  const std::size_t n = std::size_t(*nodes_u) * std::size_t(*nodes_v);
  std::vector<Eigen::Vector2d> pixels(n);
  for (int j = 0; j < *nodes_v; ++j) {
    for (int i = 0; i < *nodes_u; ++i) pixels[std::size_t(j) * std::size_t(*nodes_u) + std::size_t(i)] = {i * s, j * s};
  }
  std::vector<Eigen::Vector3d> rays(n);
  std::vector<std::uint8_t> valid(n);
  target.unproject(pixels, rays, valid, InversePath::table);
  cv::Mat planes(3, int(padded(n)), CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (std::size_t k = 0; k < n; ++k) {
    if (!valid[k]) continue;
    for (int c = 0; c < 3; ++c) planes.ptr<float>(c)[k] = float(rays[k][c]);
  }
  return planes;
}

double rotation_angle(const Eigen::Matrix3d& r) { return std::acos(std::clamp((r.trace() - 1) / 2, -1.0, 1.0)); }

// Whether the plan's measurement covers the change (else: the per-pixel path).
bool measured(const GridPlan& plan, const RigidMotion& change) {
  return rotation_angle(change.rotation) <= plan.max_rotation_rad && change.translation.norm() <= plan.max_translation;
}

GridChange prepare(const GridPlan& plan, const SourceParams& src, const RigidMotion& change, DepthPrior prior) {
  GridChange out;
  out.pose = pose_params(change);
  out.geometric = select_kernel_for_cpu(prior, change.translation.squaredNorm() < 1, src.radial.kind, false);
  node_maps(plan, src, out.pose, out.geometric, &out.nodes);
  out.ok = cells_ok(plan, src, out.nodes);
  return out;
}

// The smallest distance from the principal point, in normalised coordinates, of the
// image of a closed domain's rim (theta = theta_max): rho_max for a radial camera,
// less with a skew, more or less with a non-radial part (the rim's image is then no
// circle; an mrcal lens may move its centre). Sampled at 1440 azimuths (the guard's 5 %
// covers what lies between); 0 unless the axis's pixel lies inside the disk of that
// radius about the principal point (the disk then lies inside the domain's image:
// it meets no rim point).
double rim_distance(const Camera& source) {
  // A hair inside: a ray built at theta_max itself may measure a few ulps past it.
  const double theta = source.domain().theta_max * (1 - 1e-12), c = std::cos(theta), s = std::sin(theta);
  double nearest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 1440; ++k) {
    const double phi = 2 * std::numbers::pi * k / 1440;
    Eigen::Vector2d pixel;
    if (!source.project(Eigen::Vector3d(s * std::cos(phi), s * std::sin(phi), c), &pixel)) return 0;
    nearest = std::min(nearest, (pixel - source.principal_point()).cwiseQuotient(source.pixel_scale()).norm());
  }
  Eigen::Vector2d axis;
  if (!source.project(Eigen::Vector3d::UnitZ(), &axis)) return 0;
  return (axis - source.principal_point()).cwiseQuotient(source.pixel_scale()).norm() < nearest ? nearest : 0;
}

// The measurement's changes: the corners of the `large` preset's box (the widest changes
// the presets draw), half with each depth prior that moves the view.
std::vector<std::pair<RigidMotion, DepthPrior>> measured_changes(double* max_angle, double* max_translation) {
  std::vector<std::pair<RigidMotion, DepthPrior>> changes;
  *max_angle = 0, *max_translation = 0;
  for (int k = 0; k < 8; ++k) {
    const double sx = k & 1 ? 1 : -1, sy = k & 2 ? 1 : -1, sz = k & 4 ? 1 : -1;
    const RigidMotion change = RigidMotion::from_euler_deg({30 * sx, 30 * sy, 30 * sz}, {0.5 * sy, 0.5 * sz, 0.5 * sx});
    changes.emplace_back(change, k % 2 ? DepthPrior::source_sphere : DepthPrior::target_sphere);
    *max_angle = std::max(*max_angle, rotation_angle(change.rotation));
    *max_translation = std::max(*max_translation, change.translation.norm());
  }
  return changes;
}

// The changes prepared on the plan's nodes, or none unless enough cells are interpolated:
// of the cells with a corner inside the source image, over all the changes.
std::vector<GridChange> prepared_if_mostly_interpolated(
    const GridPlan& plan, const SourceParams& src, const std::vector<std::pair<RigidMotion, DepthPrior>>& changes) {
  std::vector<GridChange> prepared;
  long cells_interpolated = 0, cells_with_source = 0;
  const std::size_t nu = std::size_t(plan.nodes_u), cells_u = nu - 1;
  for (const auto& [change, prior] : changes) {
    const GridChange& p = prepared.emplace_back(prepare(plan, src, change, prior));
    for (std::size_t j = 0; j + 1 < std::size_t(plan.nodes_v); ++j) {
      for (std::size_t i = 0; i < cells_u; ++i) {
        const std::size_t a = j * nu + i, b = a + nu;
        const int inside = p.nodes.valid[a] + p.nodes.valid[a + 1] + p.nodes.valid[b] + p.nodes.valid[b + 1];
        cells_with_source += inside > 0;
        cells_interpolated += p.ok[j * cells_u + i] && inside == 4;
      }
    }
  }
  if (double(cells_interpolated) < kMinInterpolatedShare * double(cells_with_source)) prepared.clear();
  return prepared;
}

constexpr int kRowStep = 3;  // the measurement's rows: v = r kRowStep
constexpr double kTolerance2 = kGridTolerancePx * kGridTolerancePx;

// The worst squared error of the interpolated pixels (NaN: one without a source) against
// the per-pixel float map of the measured rows, which is computed where it is compared
// (8 changes' maps would be 40 MB at 1280 x 966); none once it exceeds the tolerance.
// Each row stripe keeps its own worst, merged under the lock; stripes stop once the
// spacing has failed.
std::optional<double> worst_error2(const GridPlan& plan, const SourceParams& src, const cv::Mat& pixel_rays, int w,
                                   int h, const std::vector<GridChange>& prepared) {
  const int s = plan.spacing, cells = (w + s - 1) / s, rows = (h + kRowStep - 1) / kRowStep;
  const std::size_t row_length = std::size_t(w) + kRowPadding, cells_u = std::size_t(plan.nodes_u) - 1;
  double worst2 = 0;
  std::atomic<bool> failed{false};
  std::mutex merge;
  for (std::size_t c = 0; c < prepared.size() && !failed; ++c) {
    const GridChange& change = prepared[c];
    cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
      std::vector<float> x(row_length), y(row_length), exact_x(row_length), exact_y(row_length);
      std::vector<unsigned char> exact_in(row_length);
      RowScratch scratch(plan);
      float stripe_worst2 = 0;
      for (int r = range.start; r < range.end && !failed.load(std::memory_order_relaxed); ++r) {
        const int v = r * kRowStep;
        const std::size_t ray = std::size_t(v) * std::size_t(w);
        change.geometric(pixel_rays.ptr<float>(0) + ray, pixel_rays.ptr<float>(1) + ray, pixel_rays.ptr<float>(2) + ray,
                         0, std::size_t(w), change.pose, src,
                         KernelOutput{exact_x.data(), exact_y.data(), exact_in.data()});
        interpolate_row(plan, change.nodes, v, w, x.data(), y.data(), &scratch);
        const unsigned char* ok_row = change.ok.data() + std::size_t(v / s) * cells_u;
        for (int i = 0; i < cells; ++i) {
          if (!ok_row[i]) continue;  // computed per pixel
          for (int u = i * s, end = std::min(w, (i + 1) * s); u < end; ++u) {
            const float dx = x[std::size_t(u)] - exact_x[std::size_t(u)];
            const float dy = y[std::size_t(u)] - exact_y[std::size_t(u)];
            // NaN must fail: not max(), which drops it.
            const float e2 = exact_in[std::size_t(u)] ? dx * dx + dy * dy : 0.0f;
            stripe_worst2 = e2 <= stripe_worst2 ? stripe_worst2 : e2;
          }
        }
        if (!(stripe_worst2 <= kTolerance2)) failed = true;
      }
      const std::lock_guard lock(merge);
      worst2 = std::isnan(worst2) || std::isnan(stripe_worst2) ? std::numeric_limits<double>::quiet_NaN()
                                                               : std::max(worst2, double(stripe_worst2));
    });
  }
  if (failed || !(worst2 <= kTolerance2)) return std::nullopt;
  return worst2;
}

}  // namespace

std::shared_ptr<const GridPlan> make_grid_plan(const Camera& source, const Camera& target, const SourceParams& src,
                                               const cv::Mat& pixel_rays) {
  const int w = target.width(), h = target.height();
  if (w < 2 || h < 2) return nullptr;
  double max_angle = 0, max_translation = 0;
  const std::vector<std::pair<RigidMotion, DepthPrior>> changes = measured_changes(&max_angle, &max_translation);
  float fold_guard = std::numeric_limits<float>::infinity();
  if (source.domain().closed)
    fold_guard = float(0.95 * rim_distance(source) * source.pixel_scale().cwiseAbs().maxCoeff());
  for (const int s : {16, 8, 4, 2}) {
    auto plan = std::make_shared<GridPlan>();
    plan->spacing = s;
    plan->node_rays = node_rays_for(target, s, &plan->nodes_u, &plan->nodes_v);
    plan->max_rotation_rad = max_angle + 1e-9;
    plan->max_translation = max_translation + 1e-9;
    plan->fold_guard_radius = fold_guard;
    const std::vector<GridChange> prepared = prepared_if_mostly_interpolated(*plan, src, changes);
    if (prepared.empty()) continue;
    // The largest spacing that keeps the error and leaves most cells to the interpolation.
    if (const std::optional<double> worst2 = worst_error2(*plan, src, pixel_rays, w, h, prepared)) {
      plan->measured_error_px = std::sqrt(*worst2);
      return plan;
    }
  }
  return nullptr;
}

namespace {
// A channels-first 8-bit image as bilinear_8u reads it: one plane where it lies, more
// interleaved into a buffer the calling thread keeps; nullopt where the grid path
// cannot sample it (no fast kernel, not 8-bit, 2 GiB or more). Sampling the planes
// where they lie took two gathers or six loads per pixel and plane against two
// loads: it cost more than this pass over the image (docs/performance.md).
std::optional<BilinearSource> interleaved_planes(const AugmentIO& io, const GridRowLoops& loops) {
  const std::span<const cv::Mat> planes = io.image_planes;
  if (planes.empty() || !loops.bilinear_8u_to_planes || planes[0].depth() != CV_8U) return std::nullopt;
  const int channels = int(planes.size()), width = planes[0].cols, height = planes[0].rows;
  const unsigned char fill = cv::saturate_cast<unsigned char>(io.fill);
  const auto source = [&](const unsigned char* data, std::size_t step) {
    return BilinearSource{data,
                          data + (height - 1) * step + std::size_t(width) * channels,
                          step,
                          width,
                          height,
                          channels,
                          {fill, fill, fill, fill}};
  };
  if (channels == 1) {
    if (planes[0].dataend - planes[0].data >= kMaxFusedImageBytes) return std::nullopt;
    return source(planes[0].data, planes[0].step[0]);
  }
  // Rows of whole cache lines starting one byte past one: OpenCV's merge writes an
  // aligned row with non-temporal stores, which leave it out of the cache the warp
  // then reads it from.
  const std::size_t step = (std::size_t(width) * channels + 63) / 64 * 64;
  if (std::ptrdiff_t(step * height) >= kMaxFusedImageBytes) return std::nullopt;
  // Kept at the largest size this thread has used (grown only: no refill of memory it has).
  thread_local std::vector<unsigned char> buffer;
  if (buffer.size() < step * height + 64) buffer.resize(step * height + 64);
  const std::uintptr_t start = reinterpret_cast<std::uintptr_t>(buffer.data());
  unsigned char* const data = buffer.data() + ((64 - start % 64) % 64 + 1) % 64;
  cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const unsigned char* row_planes[4] = {};
      for (int c = 0; c < channels; ++c) row_planes[c] = planes[std::size_t(c)].ptr<unsigned char>(v);
      cv::hal::merge8u(row_planes, data + std::size_t(v) * step, width, channels);
    }
  });
  return source(data, step);
}
}  // namespace

bool grid_augment(const GridPlan& plan, const SourceParams& src, const cv::Mat& pixel_rays, const Camera& target,
                  const RigidMotion& change, DepthPrior prior, const AugmentIO& io) {
  const GridRowLoops loops = grid_row_loops_for_cpu();
  if (!measured(plan, change)) return false;
  const bool planar = !io.image_planes.empty();
  std::optional<BilinearSource> fused = planar ? interleaved_planes(io, loops) : std::nullopt;
  if (planar && !fused) return false;  // the caller samples an interleaved copy
  const GridChange prepared = prepare(plan, src, change, prior);
  const int w = target.width(), h = target.height();
  if (io.image) io.out_image->create(h, w, io.image->type());
  if (io.labels) io.out_labels->create(h, w, io.labels->type());
  if (io.valid) io.valid->create(h, w, CV_8UC1);
  const float limit_x = src.grid.width - 0.5f, limit_y = src.grid.height - 0.5f;
  const float max_x = src.grid.width - 1, max_y = src.grid.height - 1;
  // 8-bit images with 1 to 4 channels are interpolated row by row while the row's
  // maps are in L1 (byte for byte what cv::remap gives); others by cv::remap per tile.
  if (io.image && loops.bilinear_8u && io.image->depth() == CV_8U && io.image->channels() <= 4 &&
      io.image->dataend - io.image->data < kMaxFusedImageBytes) {
    const cv::Mat& image = *io.image;
    const unsigned char fill = cv::saturate_cast<unsigned char>(io.fill);
    fused = BilinearSource{image.data, image.dataend,    image.step[0],           image.cols,
                           image.rows, image.channels(), {fill, fill, fill, fill}};
  }
  const int tiles = (h + kTileRows - 1) / kTileRows;
  // One stripe per tile: threads take the next tile as they finish one (tiles through
  // the image circle cost more than those above it; 2 threads ran 3 % faster than
  // with 4 stripes per thread, 1 thread the same).
  cv::parallel_for_(cv::Range(0, tiles), [&](const cv::Range& range) {
    const std::size_t row_length = static_cast<std::size_t>(w) + kRowPadding;
    std::vector<float> x(row_length), y(row_length);
    std::vector<unsigned char> in(row_length);
    RowScratch scratch(plan);
    // Rows past the tile's for 8 pixels: bilinear_8u reads whole vectors past a row's end.
    const int spare_rows = (8 + w - 1) / w;
    cv::Mat fixed(kTileRows + spare_rows, w, CV_16SC2), fractions(kTileRows + spare_rows, w, CV_16UC1);
    cv::Mat nearest(kTileRows, w, CV_16SC2);
    for (int tile = range.start; tile < range.end; ++tile) {
      const int r0 = tile * kTileRows, r1 = std::min(h, r0 + kTileRows);
      for (int v = r0; v < r1; ++v) {
        grid_row(plan, prepared, src, pixel_rays, v, w, x.data(), y.data(), in.data(), &scratch);
        loops.to_fixed_point(x.data(), y.data(), w, limit_x, limit_y, max_x, max_y, fixed.ptr<short>(v - r0),
                             fractions.ptr<unsigned short>(v - r0), nearest.ptr<short>(v - r0),
                             io.valid ? io.valid->ptr<unsigned char>(v) : nullptr);
        if (planar) {
          unsigned char* out_rows[4] = {};
          for (int c = 0; c < fused->channels; ++c)
            out_rows[c] = io.out_image_planes[std::size_t(c)].ptr<unsigned char>(v);
          loops.bilinear_8u_to_planes(*fused, fixed.ptr<short>(v - r0), fractions.ptr<unsigned short>(v - r0), w,
                                      out_rows);
        } else if (fused) {
          loops.bilinear_8u(*fused, fixed.ptr<short>(v - r0), fractions.ptr<unsigned short>(v - r0), w,
                            io.out_image->ptr<unsigned char>(v));
        }
      }
      const int rows = r1 - r0;
      if (io.image && !fused) {
        cv::Mat out = io.out_image->rowRange(r0, r1);
        cv::remap(*io.image, out, fixed.rowRange(0, rows), fractions.rowRange(0, rows), cv::INTER_LINEAR,
                  cv::BORDER_CONSTANT, cv::Scalar::all(io.fill));
      }
      if (io.labels) {
        // Nearest neighbour is a lookup: done here, from the rounded map, without a remap call.
        for (int v = r0; v < r1; ++v) {
          if (io.labels->depth() == CV_8U) {
            gather_labels<unsigned char>(*io.labels, nearest.ptr<short>(v - r0), w, io.label_fill,
                                         io.out_labels->ptr<unsigned char>(v));
          } else {
            gather_labels<unsigned short>(*io.labels, nearest.ptr<short>(v - r0), w, io.label_fill,
                                          io.out_labels->ptr<unsigned short>(v));
          }
        }
      }
    }
  });
  return true;
}

bool grid_maps(const GridPlan& plan, const SourceParams& src, const cv::Mat& pixel_rays, const Camera& target,
               const RigidMotion& change, DepthPrior prior, WarpMaps* maps) {
  if (!measured(plan, change)) return false;
  const GridChange prepared = prepare(plan, src, change, prior);
  const int w = target.width(), h = target.height();
  maps->kind = MapKind::geometric;
  maps->source_size = cv::Size(int(src.grid.width), int(src.grid.height));
  maps->map_x.create(h, w, CV_32FC1);
  maps->map_y.create(h, w, CV_32FC1);
  maps->valid.create(h, w, CV_8UC1);
  const float limit_x = src.grid.width - 0.5f, limit_y = src.grid.height - 0.5f;
  std::atomic<long> invalid{0};
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& range) {
    const std::size_t row_length = static_cast<std::size_t>(w) + kRowPadding;
    std::vector<float> row_x(row_length), row_y(row_length);
    std::vector<unsigned char> in(row_length);
    RowScratch scratch(plan);
    long local = 0;
    for (int v = range.start; v < range.end; ++v) {
      grid_row(plan, prepared, src, pixel_rays, v, w, row_x.data(), row_y.data(), in.data(), &scratch);
      float* x = maps->map_x.ptr<float>(v);
      float* y = maps->map_y.ptr<float>(v);
      std::copy(row_x.begin(), row_x.begin() + w, x);
      std::copy(row_y.begin(), row_y.begin() + w, y);
      unsigned char* valid = maps->valid.ptr<unsigned char>(v);
      for (int u = 0; u < w; ++u) {
        valid[u] = x[u] >= -0.5f && x[u] < limit_x && y[u] >= -0.5f && y[u] < limit_y;
        local += !valid[u];
      }
    }
    invalid += local;
  });
  maps->invalid_count = invalid;
  return true;
}

}  // namespace fishcam::detail
