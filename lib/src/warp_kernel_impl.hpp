// The warp kernel's templates, included once per instruction set by
// warp_kernel_<isa>.cpp inside namespace fishcam::detail::<isa>. OpenCV's
// universal intrinsics give the vector width of the compile flags (4 floats with
// SSE2, 8 with AVX2).
#include <opencv2/core/hal/intrin.hpp>

#include <limits>
#include <numbers>

#include "warp_kernel.hpp"

namespace fishcam::detail::FISHCAM_KERNEL_ISA {

using cv::v_float32;
constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();


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
  if constexpr (kKind == SourceParams::Kind::unified) {
    // w = xi |P| + Pz; behind the camera (Pz < 0, xi > 0) as
    // (xi^2 chi^2 + (xi^2 - 1) Pz^2) / (xi |P| - Pz), without the cancellation
    // (stereographic, xi = 1: chi^2 / (|P| - Pz)).
    const v_float32 xi = cv::vx_setall_f32(src.xi);
    v_float32 w = cv::v_fma(xi, norm, pz);
    if (src.xi > 0) {
      const v_float32 numerator =
          src.xi == 1 ? chi2
                      : cv::v_fma(cv::vx_setall_f32(src.xi * src.xi), chi2, cv::vx_setall_f32(src.xi * src.xi - 1) * pz * pz);
      w = cv::v_select(pz >= zero, w, numerator / cv::v_fma(xi, norm, zero - pz));
    }
    v_float32 d = w;
    if (src.alpha != 0) {
      const v_float32 alpha = cv::vx_setall_f32(src.alpha);
      const v_float32 root = cv::v_sqrt(cv::v_fma(cv::vx_setall_f32(src.beta), chi2, w * w));
      d = cv::v_fma(alpha, root, (cv::vx_setall_f32(1.0f) - alpha) * w);
    }
    scale = cv::vx_setall_f32(src.f) / d;
    if (src.k1 != 0 || src.k2 != 0) {  // mei: radial distortion of r = chi / D
      const v_float32 r2 = chi2 / (d * d);
      scale = scale * cv::v_fma(r2, cv::v_fma(r2, cv::vx_setall_f32(src.k2), cv::vx_setall_f32(src.k1)),
                                cv::vx_setall_f32(1.0f));
    }
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
template <DepthPrior kPrior, bool kInsideSphere, SourceParams::Kind kKind, bool kSampling>
long warp_range(const float* rx, const float* ry, const float* rz, std::size_t begin, std::size_t end,
                const PoseParams& pose, const SourceParams& src, const KernelOutput& out) {
  constexpr int kLanes = v_float32::nlanes;
  alignas(64) float x[kLanes], y[kLanes], in[kLanes];
  const v_float32 zero = cv::vx_setzero_f32(), outside = cv::vx_setall_f32(kOutside);
  const v_float32 max_x = cv::vx_setall_f32(src.width - 1), max_y = cv::vx_setall_f32(src.height - 1);
  long invalid = 0;
  for (std::size_t i = begin; i < end; i += kLanes) {
    v_float32 u, v, inside;
    warp_vector<kPrior, kInsideSphere, kKind>(cv::vx_load(rx + i), cv::vx_load(ry + i), cv::vx_load(rz + i), pose, src,
                                              &u, &v, &inside);
    if constexpr (kSampling) {
      // Inside the image by up to half a pixel past the outer centres: clamp (the
      // edge pixel, as replication would give); elsewhere far outside.
      u = cv::v_select(inside, cv::v_min(cv::v_max(u, zero), max_x), outside);
      v = cv::v_select(inside, cv::v_min(cv::v_max(v, zero), max_y), outside);
    }
    const std::size_t count = end - i < std::size_t(kLanes) ? end - i : std::size_t(kLanes);
    if (count == std::size_t(kLanes)) {
      cv::v_store(out.map_x + i, u);
      cv::v_store(out.map_y + i, v);
    } else {
      cv::v_store(x, u);
      cv::v_store(y, v);
      for (std::size_t k = 0; k < count; ++k) out.map_x[i + k] = x[k], out.map_y[i + k] = y[k];
    }
    cv::v_store(in, inside);
    for (std::size_t k = 0; k < count; ++k) {
      const bool ok = in[k] != 0;  // all-ones bits (NaN) or zero
      if constexpr (!kSampling) out.valid[i + k] = ok;
      invalid += !ok;
    }
  }
  return invalid;
}

template <DepthPrior kPrior, bool kInsideSphere, bool kSampling>
RangeKernel kernel_for_kind(SourceParams::Kind kind) {
  switch (kind) {
    case SourceParams::Kind::polynomial:
      return warp_range<kPrior, kInsideSphere, SourceParams::Kind::polynomial, kSampling>;
    case SourceParams::Kind::unified:
      return warp_range<kPrior, kInsideSphere, SourceParams::Kind::unified, kSampling>;
  }
  return nullptr;
}

template <bool kSampling>
RangeKernel kernel_for(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind) {
  switch (prior) {
    case DepthPrior::infinity: return kernel_for_kind<DepthPrior::infinity, true, kSampling>(kind);
    case DepthPrior::target_sphere: return kernel_for_kind<DepthPrior::target_sphere, true, kSampling>(kind);
    case DepthPrior::source_sphere:
      return inside_sphere ? kernel_for_kind<DepthPrior::source_sphere, true, kSampling>(kind)
                           : kernel_for_kind<DepthPrior::source_sphere, false, kSampling>(kind);
  }
  return nullptr;
}

// One dispatch per map: prior x (inside the sphere or not) x source model kind x output.
inline RangeKernel select_kernel(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  return sampling ? kernel_for<true>(prior, inside_sphere, kind) : kernel_for<false>(prior, inside_sphere, kind);
}

}  // namespace fishcam::detail::FISHCAM_KERNEL_ISA
