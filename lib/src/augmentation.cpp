#include "fishcam/augmentation.hpp"

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include <array>
#include <bit>
#include <atomic>
#include <cmath>
#include <numbers>

namespace fishcam {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

// The source camera as the float kernel needs it.
struct SourceParams {
  enum class Kind { polynomial, stereographic, pinhole };
  Kind kind = Kind::polynomial;
  std::array<float, 16> c{};  // rho = c[1] theta + ... + c[n] theta^n
  int n = 0;
  float f = 0;  // stereographic, pinhole
  float cx = 0, cy = 0, ax = 1, ay = 1;
  float cos_theta_max = -1;
  bool closed = true;
  float width = 0, height = 0;
};

SourceParams source_params(const Camera& camera) {
  SourceParams p;
  std::visit(
      [&](const auto& m) {
        using Model = std::decay_t<decltype(m)>;
        if constexpr (PolynomialInTheta<Model>) {
          const auto c = m.power_coefficients();
          p.kind = SourceParams::Kind::polynomial;
          p.n = static_cast<int>(c.size()) - 1;
          for (size_t i = 0; i < c.size(); ++i) p.c[i] = static_cast<float>(c[i]);
        } else {
          p.kind = std::is_same_v<Model, Stereographic<double>> ? SourceParams::Kind::stereographic
                                                                : SourceParams::Kind::pinhole;
          p.f = static_cast<float>(m.f());
        }
      },
      camera.model());
  p.cx = float(camera.principal_point().x()), p.cy = float(camera.principal_point().y());
  p.ax = float(camera.pixel_scale().x()), p.ay = float(camera.pixel_scale().y());
  p.cos_theta_max = float(std::cos(camera.domain().theta_max));
  p.closed = camera.domain().closed;
  p.width = float(camera.width()), p.height = float(camera.height());
  return p;
}

struct PoseParams {
  float rt[9];  // R transposed, row-major: P = R^T q
  float t[3];
  float c;  // |t|^2 - 1
};

PoseParams pose_params(const ViewpointChange& change) {
  PoseParams p;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) p.rt[3 * r + k] = float(change.rotation(k, r));
  }
  for (int k = 0; k < 3; ++k) p.t[k] = float(change.translation[k]);
  p.c = float(change.translation.squaredNorm() - 1);
  return p;
}

using cv::v_float32;

// atan2(y, x) for y >= 0: an odd minimax polynomial for atan on [0, 1] (abs error
// 4e-8 in exact arithmetic, 1.4e-7 rad in float) and the usual octant folding.
inline v_float32 atan2_nonnegative_y(const v_float32& y, const v_float32& x) {
  const v_float32 ax = cv::v_abs(x);
  const v_float32 lo = cv::v_min(y, ax), hi = cv::v_max(y, ax);
  const v_float32 r = lo / hi, r2 = r * r;
  v_float32 p = cv::vx_setall_f32(-0.0040545590806092685f);
  for (float k : {0.02186293012890829f, -0.05591228945515758f, 0.09642194826292869f, -0.13908628681826157f,
                  0.19946565506173233f, -0.33329860775184583f, 0.9999993355776432f}) {
    p = cv::v_fma(p, r2, cv::vx_setall_f32(k));
  }
  v_float32 a = p * r;
  a = cv::v_select(y > ax, cv::vx_setall_f32(float(std::numbers::pi / 2)) - a, a);
  return cv::v_select(x < cv::vx_setzero_f32(), cv::vx_setall_f32(float(std::numbers::pi)) - a, a);
}

// One vector of output pixels: rays d -> source pixel (x, y) and the inside mask.
template <DepthPrior kPrior, bool kInsideSphere, SourceParams::Kind kKind>
inline void warp_vector(const v_float32& dx, const v_float32& dy, const v_float32& dz, const PoseParams& pose,
                        const SourceParams& src, v_float32* out_x, v_float32* out_y, v_float32* inside) {
  const v_float32 zero = cv::vx_setzero_f32();
  const v_float32 tx = cv::vx_setall_f32(pose.t[0]), ty = cv::vx_setall_f32(pose.t[1]),
                  tz = cv::vx_setall_f32(pose.t[2]);
  v_float32 qx = dx, qy = dy, qz = dz;
  v_float32 valid = dz == dz;  // false for the NaN rays of invalid output pixels
  if constexpr (kPrior == DepthPrior::target_sphere) {
    qx = dx - tx, qy = dy - ty, qz = dz - tz;
  } else if constexpr (kPrior == DepthPrior::source_sphere) {
    // |s d - t| = 1: s^2 - 2 b s + c = 0 with b = d.t, c = |t|^2 - 1 (docs/augmentation.md).
    const v_float32 c = cv::vx_setall_f32(pose.c);
    const v_float32 b = cv::v_fma(dx, tx, cv::v_fma(dy, ty, dz * tz));
    const v_float32 disc = b * b - c;
    v_float32 s;
    if constexpr (kInsideSphere) {  // c < 0: one positive root; the form without cancellation
      const v_float32 sq = cv::v_sqrt(disc);
      s = cv::v_select(b >= zero, b + sq, (zero - c) / (sq - b));
    } else {  // c >= 0: the nearer of two positive roots, when the ray meets the sphere
      const v_float32 sq = cv::v_sqrt(cv::v_max(disc, zero));
      s = c / (b + sq);
      valid = valid & (disc >= zero) & (b > zero) & (s > zero);
    }
    qx = cv::v_fma(s, dx, zero - tx), qy = cv::v_fma(s, dy, zero - ty), qz = cv::v_fma(s, dz, zero - tz);
  }
  const float* r = pose.rt;
  const v_float32 px = cv::v_fma(cv::vx_setall_f32(r[0]), qx, cv::v_fma(cv::vx_setall_f32(r[1]), qy, cv::vx_setall_f32(r[2]) * qz));
  const v_float32 py = cv::v_fma(cv::vx_setall_f32(r[3]), qx, cv::v_fma(cv::vx_setall_f32(r[4]), qy, cv::vx_setall_f32(r[5]) * qz));
  const v_float32 pz = cv::v_fma(cv::vx_setall_f32(r[6]), qx, cv::v_fma(cv::vx_setall_f32(r[7]), qy, cv::vx_setall_f32(r[8]) * qz));

  // Projection by the source camera (the direction of P is all that matters).
  const v_float32 chi2 = cv::v_fma(px, px, py * py);
  const v_float32 norm = cv::v_sqrt(cv::v_fma(pz, pz, chi2));
  const v_float32 cos_limit = cv::vx_setall_f32(src.cos_theta_max) * norm;
  valid = valid & (src.closed ? pz >= cos_limit : pz > cos_limit) & ((chi2 > zero) | (pz > zero));
  v_float32 scale;  // rho(theta) / chi
  if constexpr (kKind == SourceParams::Kind::stereographic) {
    // 2 f tan(theta/2) / chi = 2 f / (|P| + Pz); for Pz < 0 the same as chi^2 / (|P| - Pz).
    const v_float32 denominator = cv::v_select(pz >= zero, norm + pz, chi2 / (norm - pz));
    scale = cv::vx_setall_f32(2 * src.f) / denominator;
  } else if constexpr (kKind == SourceParams::Kind::pinhole) {
    scale = cv::vx_setall_f32(src.f) / pz;
  } else {
    const v_float32 chi = cv::v_sqrt(chi2);
    const v_float32 theta = atan2_nonnegative_y(chi, pz);
    v_float32 rho = cv::vx_setall_f32(src.c[src.n]);
    for (int i = src.n - 1; i >= 1; --i) rho = cv::v_fma(rho, theta, cv::vx_setall_f32(src.c[i]));
    rho = rho * theta;
    // On the axis rho / chi -> rho'(0) / Pz.
    scale = cv::v_select(chi > zero, rho / chi, cv::vx_setall_f32(src.c[1]) / pz);
  }
  const v_float32 nan = cv::vx_setall_f32(kNaNf);
  const v_float32 u = cv::v_fma(cv::vx_setall_f32(src.ax) * scale, px, cv::vx_setall_f32(src.cx));
  const v_float32 v = cv::v_fma(cv::vx_setall_f32(src.ay) * scale, py, cv::vx_setall_f32(src.cy));
  valid = valid & (u == u) & (v == v);
  *out_x = cv::v_select(valid, u, nan);
  *out_y = cv::v_select(valid, v, nan);
  const v_float32 half = cv::vx_setall_f32(-0.5f);
  *inside = valid & (u >= half) & (v >= half) & (u < cv::vx_setall_f32(src.width - 0.5f)) &
            (v < cv::vx_setall_f32(src.height - 0.5f));
}

// Pixels [begin, end) of the flat output image. The ray planes are padded to a
// whole number of vectors, so the last partial vector is computed in full and
// only its pixels inside the image are written.
template <DepthPrior kPrior, bool kInsideSphere, SourceParams::Kind kKind>
long warp_range(const float* rx, const float* ry, const float* rz, size_t begin, size_t end, const PoseParams& pose,
                const SourceParams& src, float* map_x, float* map_y, uchar* valid) {
  constexpr int kLanes = v_float32::nlanes;
  alignas(64) float x[kLanes], y[kLanes], in[kLanes];
  long invalid = 0;
  for (size_t i = begin; i < end; i += kLanes) {
    v_float32 u, v, inside;
    warp_vector<kPrior, kInsideSphere, kKind>(cv::vx_load(rx + i), cv::vx_load(ry + i), cv::vx_load(rz + i), pose, src,
                                              &u, &v, &inside);
    const size_t count = std::min<size_t>(kLanes, end - i);
    if (count == kLanes) {
      cv::v_store(map_x + i, u);
      cv::v_store(map_y + i, v);
    } else {
      cv::v_store(x, u);
      cv::v_store(y, v);
      std::copy(x, x + count, map_x + i);
      std::copy(y, y + count, map_y + i);
    }
    cv::v_store(in, inside);
    for (size_t k = 0; k < count; ++k) {
      const bool ok = std::bit_cast<std::uint32_t>(in[k]) != 0;
      valid[i + k] = ok;
      invalid += !ok;
    }
  }
  return invalid;
}

using RangeKernel = long (*)(const float*, const float*, const float*, size_t, size_t, const PoseParams&,
                             const SourceParams&, float*, float*, uchar*);

template <DepthPrior kPrior, bool kInsideSphere>
RangeKernel kernel_for(SourceParams::Kind kind) {
  switch (kind) {
    case SourceParams::Kind::polynomial: return warp_range<kPrior, kInsideSphere, SourceParams::Kind::polynomial>;
    case SourceParams::Kind::stereographic:
      return warp_range<kPrior, kInsideSphere, SourceParams::Kind::stereographic>;
    case SourceParams::Kind::pinhole: return warp_range<kPrior, kInsideSphere, SourceParams::Kind::pinhole>;
  }
  return nullptr;
}

// One dispatch per map: prior x (inside the sphere or not) x source model kind.
RangeKernel kernel_for(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind) {
  switch (prior) {
    case DepthPrior::infinity: return kernel_for<DepthPrior::infinity, true>(kind);
    case DepthPrior::target_sphere: return kernel_for<DepthPrior::target_sphere, true>(kind);
    case DepthPrior::source_sphere:
      return inside_sphere ? kernel_for<DepthPrior::source_sphere, true>(kind)
                           : kernel_for<DepthPrior::source_sphere, false>(kind);
  }
  return nullptr;
}

void allocate(const Camera& source, const Camera& target, WarpMaps* maps) {
  maps->source_size = cv::Size(source.width(), source.height());
  maps->map_x.create(target.height(), target.width(), CV_32FC1);
  maps->map_y.create(target.height(), target.width(), CV_32FC1);
  maps->valid.create(target.height(), target.width(), CV_8UC1);
}

}  // namespace

std::optional<Eigen::Vector3d> source_point(const Eigen::Vector3d& d, const ViewpointChange& change,
                                            DepthPrior prior) {
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

ViewpointWarp::ViewpointWarp(Camera source, Camera target) : source_(std::move(source)), target_(std::move(target)) {
  const size_t n = size_t(target_.width()) * size_t(target_.height());
  const size_t padded = (n + 63) / 64 * 64;
  std::vector<float> interleaved(3 * n);
  target_.unproject_image(interleaved, InversePath::table);
  rays_.create(3, static_cast<int>(padded), CV_32FC1);
  rays_.setTo(kNaNf);
  float* planes[3] = {rays_.ptr<float>(0), rays_.ptr<float>(1), rays_.ptr<float>(2)};
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) planes[k][i] = interleaved[3 * i + k];
  }
}

void ViewpointWarp::compute(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps) const {
  allocate(source_, target_, maps);
  const SourceParams src = source_params(source_);
  const PoseParams pose = pose_params(change);
  const RangeKernel kernel = kernel_for(prior, change.translation.squaredNorm() < 1, src.kind);
  const size_t n = size_t(target_.width()) * size_t(target_.height());
  constexpr size_t kChunk = 16384;  // a multiple of every SIMD width
  const int chunks = static_cast<int>((n + kChunk - 1) / kChunk);
  std::atomic<long> invalid{0};
  cv::parallel_for_(cv::Range(0, chunks), [&](const cv::Range& r) {
    const size_t begin = size_t(r.start) * kChunk, end = std::min(n, size_t(r.end) * kChunk);
    invalid += kernel(rays_.ptr<float>(0), rays_.ptr<float>(1), rays_.ptr<float>(2), begin, end, pose, src,
                      maps->map_x.ptr<float>(), maps->map_y.ptr<float>(), maps->valid.ptr<uchar>());
  });
  maps->invalid_count = invalid;
}

void ViewpointWarp::compute_exact(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps) const {
  allocate(source_, target_, maps);
  std::atomic<long> invalid{0};
  const double w = source_.width() - 0.5, h = source_.height() - 0.5;
  cv::parallel_for_(cv::Range(0, target_.height()), [&](const cv::Range& rows) {
    long local = 0;
    for (int v = rows.start; v < rows.end; ++v) {
      for (int u = 0; u < target_.width(); ++u) {
        Eigen::Vector3d ray;
        Eigen::Vector2d pixel(std::nan(""), std::nan(""));
        if (target_.unproject(Eigen::Vector2d(u, v), &ray)) {
          if (const auto p = source_point(ray, change, prior)) source_.project(*p, &pixel);
        }
        maps->map_x.at<float>(v, u) = float(pixel.x());
        maps->map_y.at<float>(v, u) = float(pixel.y());
        const bool ok = pixel.x() >= -0.5 && pixel.x() < w && pixel.y() >= -0.5 && pixel.y() < h;
        maps->valid.at<uchar>(v, u) = ok;
        local += !ok;
      }
    }
    invalid += local;
  });
  maps->invalid_count = invalid;
}

namespace {

void check_input(const cv::Mat& image, const WarpMaps& maps, const char* what) {
  if (maps.map_x.empty()) throw Error(std::string(what) + ": no maps computed");
  if (image.empty()) throw Error(std::string(what) + ": empty image");
  if (image.size() != maps.source_size) {
    throw Error(std::string(what) + ": image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                " but the source camera is " + std::to_string(maps.source_size.width) + "x" +
                std::to_string(maps.source_size.height));
  }
}

}  // namespace

void warp_image(const cv::Mat& image, const WarpMaps& maps, cv::Mat* out) {
  check_input(image, maps, "warp_image");
  if (image.depth() != CV_8U && image.depth() != CV_16U) throw Error("warp_image: expected an 8- or 16-bit image");
  if (image.channels() < 1 || image.channels() > 4) throw Error("warp_image: expected 1 to 4 channels");
  // Replicating the border only affects the outermost half pixel (still inside the
  // image); everything outside is then set by the mask, whatever remap put there.
  cv::remap(image, *out, maps.map_x, maps.map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  if (maps.invalid_count > 0) out->setTo(cv::Scalar::all(0), maps.valid == 0);
}

void warp_labels(const cv::Mat& labels, const WarpMaps& maps, int fill, cv::Mat* out) {
  check_input(labels, maps, "warp_labels");
  if (labels.channels() != 1 || (labels.depth() != CV_8U && labels.depth() != CV_16U)) {
    throw Error("warp_labels: expected a single-channel 8- or 16-bit label image");
  }
  const int max_label = labels.depth() == CV_8U ? 255 : 65535;
  if (fill < 0 || fill > max_label) throw Error("warp_labels: fill value does not fit the label image");
  cv::remap(labels, *out, maps.map_x, maps.map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(fill));
  if (maps.invalid_count > 0) out->setTo(cv::Scalar(fill), maps.valid == 0);
}

}  // namespace fishcam
