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

// a * b + c rounded twice, on every instruction set: cv::v_fma fuses on AVX2 + FMA
// and not on SSE2, so inside/outside decisions and maps differed between machines
// (an augmented dataset then depended on the CPU). The kernel files are compiled
// with -ffp-contract=off so that the compiler does not fuse it either.
inline v_float32 mul_add(const v_float32& a, const v_float32& b, const v_float32& c) { return a * b + c; }

// atan2(y, x) for y >= 0: an odd minimax polynomial for atan on [0, 1] (abs error
// 4e-8 in exact arithmetic, 1.4e-7 rad in float) and the usual octant folding.
inline v_float32 atan2_nonnegative_y(const v_float32& y, const v_float32& x) {
  const v_float32 ax = cv::v_abs(x);
  const v_float32 lo = cv::v_min(y, ax), hi = cv::v_max(y, ax);
  const v_float32 r = lo / hi, r2 = r * r;
  v_float32 p = cv::vx_setall_f32(-0.0040545590806092685f);
  for (float k : {0.02186293012890829f, -0.05591228945515758f, 0.09642194826292869f, -0.13908628681826157f,
                  0.19946565506173233f, -0.33329860775184583f, 0.9999993355776432f}) {
    p = mul_add(p, r2, cv::vx_setall_f32(k));
  }
  v_float32 a = p * r;
  a = cv::v_select(y > ax, cv::vx_setall_f32(float(std::numbers::pi / 2)) - a, a);
  return cv::v_select(x < cv::vx_setzero_f32(), cv::vx_setall_f32(float(std::numbers::pi)) - a, a);
}

// The kernel's stages, one per part of the warp (docs/augmentation.md): the depth
// prior, the rotation into the source camera, its domain, its radial model, its plane
// distortion and its pixel grid. Each is evaluated as the whole formula was before
// the split (the maps are bit-identical: lib/augment/tests).
struct Vec3 {
  v_float32 x, y, z;
};
struct Vec2 {
  v_float32 x, y;
};

// The depth prior: the point the output ray d sees, relative to the source camera's
// centre (t: the target's position in the source frame). valid loses the rays that
// meet no point.
template <DepthPrior kPrior, bool kInsideSphere>
inline Vec3 prior_point(const Vec3& d, const PoseParams& pose, v_float32* valid) {
  const v_float32 zero = cv::vx_setzero_f32();
  const v_float32 tx = cv::vx_setall_f32(pose.t[0]), ty = cv::vx_setall_f32(pose.t[1]),
                  tz = cv::vx_setall_f32(pose.t[2]);
  if constexpr (kPrior == DepthPrior::target_sphere) {
    return {d.x - tx, d.y - ty, d.z - tz};
  } else if constexpr (kPrior == DepthPrior::source_sphere) {
    // |s d - t| = 1: s^2 - 2 b s + c = 0 with b = d.t, c = |t|^2 - 1 (docs/augmentation.md).
    const v_float32 c = cv::vx_setall_f32(pose.c);
    const v_float32 b = mul_add(d.x, tx, mul_add(d.y, ty, d.z * tz));
    const v_float32 disc = b * b - c;
    v_float32 s;
    if constexpr (kInsideSphere) {  // c < 0: one positive root; the form without cancellation
      const v_float32 sq = cv::v_sqrt(disc);
      s = cv::v_select(b >= zero, b + sq, (zero - c) / (sq - b));
    } else {  // c >= 0: the nearer of two positive roots, when the ray meets the sphere
      const v_float32 sq = cv::v_sqrt(cv::v_max(disc, zero));
      s = c / (b + sq);
      *valid = *valid & (disc >= zero) & (b > zero) & (s > zero);
    }
    return {mul_add(s, d.x, zero - tx), mul_add(s, d.y, zero - ty), mul_add(s, d.z, zero - tz)};
  } else {
    (void)tx, (void)ty, (void)tz, (void)valid;
    return d;
  }
}

// Into the source camera's frame: P = R^T q.
inline Vec3 rotated(const PoseParams& pose, const Vec3& q) {
  const float* r = pose.rt;
  return {mul_add(cv::vx_setall_f32(r[0]), q.x, mul_add(cv::vx_setall_f32(r[1]), q.y, cv::vx_setall_f32(r[2]) * q.z)),
          mul_add(cv::vx_setall_f32(r[3]), q.x, mul_add(cv::vx_setall_f32(r[4]), q.y, cv::vx_setall_f32(r[5]) * q.z)),
          mul_add(cv::vx_setall_f32(r[6]), q.x, mul_add(cv::vx_setall_f32(r[7]), q.y, cv::vx_setall_f32(r[8]) * q.z))};
}

// The source's valid domain (the direction of P is all that matters; the origin and
// the -z axis are outside).
inline v_float32 in_domain(const DomainForm& domain, const Vec3& p, const v_float32& chi2, const v_float32& norm) {
  const v_float32 zero = cv::vx_setzero_f32();
  const v_float32 cos_limit = cv::vx_setall_f32(domain.cos_theta_max) * norm;
  return (domain.closed ? p.z >= cos_limit : p.z > cos_limit) & ((chi2 > zero) | (p.z > zero));
}

// The unified form's rho(theta) / chi, and its denominator D (the plane is m = P_xy / D).
inline v_float32 unified_scale(const RadialForm& r, const Vec3& p, const v_float32& chi2, const v_float32& norm,
                               v_float32* denominator) {
  const v_float32 zero = cv::vx_setzero_f32();
  // w = xi |P| + Pz; behind the camera (Pz < 0, xi > 0) as
  // (xi^2 chi^2 + (xi^2 - 1) Pz^2) / (xi |P| - Pz), without the cancellation
  // (stereographic, xi = 1: chi^2 / (|P| - Pz)).
  const v_float32 xi = cv::vx_setall_f32(r.xi);
  v_float32 w = mul_add(xi, norm, p.z);
  if (r.xi > 0) {
    const v_float32 numerator =
        r.xi == 1 ? chi2
                  : mul_add(cv::vx_setall_f32(r.xi * r.xi), chi2, cv::vx_setall_f32(r.xi * r.xi - 1) * p.z * p.z);
    w = cv::v_select(p.z >= zero, w, numerator / mul_add(xi, norm, zero - p.z));
  }
  v_float32 d = w;
  if (r.alpha != 0) {
    const v_float32 alpha = cv::vx_setall_f32(r.alpha);
    const v_float32 root = cv::v_sqrt(mul_add(cv::vx_setall_f32(r.beta), chi2, w * w));
    d = mul_add(alpha, root, (cv::vx_setall_f32(1.0f) - alpha) * w);
  }
  v_float32 scale = cv::vx_setall_f32(r.f) / d;
  const bool numerator = r.k1 != 0 || r.k2 != 0 || r.k3 != 0;
  const bool denominator_terms = r.k4 != 0 || r.k5 != 0 || r.k6 != 0;
  if (numerator || denominator_terms) {  // mei, opencv: radial distortion of r = chi / D
    const v_float32 r2 = chi2 / (d * d);
    if (numerator) {
      v_float32 inner = cv::vx_setall_f32(r.k2);
      if (r.k3 != 0) inner = mul_add(r2, cv::vx_setall_f32(r.k3), inner);
      scale = scale * mul_add(r2, mul_add(r2, inner, cv::vx_setall_f32(r.k1)), cv::vx_setall_f32(1.0f));
    }
    if (denominator_terms) {  // opencv's rational denominator
      const v_float32 k6_term = mul_add(r2, cv::vx_setall_f32(r.k6), cv::vx_setall_f32(r.k5));
      scale = scale / mul_add(r2, mul_add(r2, k6_term, cv::vx_setall_f32(r.k4)), cv::vx_setall_f32(1.0f));
    }
  }
  *denominator = d;
  return scale;
}

// A polynomial rho(theta) (or an ocam ray polynomial's root) over chi.
template <SourceParams::Kind kKind>
inline v_float32 polynomial_scale(const RadialForm& r, const Vec3& p, const v_float32& chi2) {
  const v_float32 zero = cv::vx_setzero_f32();
  const v_float32 chi = cv::v_sqrt(chi2);
  const v_float32 ray_theta = atan2_nonnegative_y(chi, p.z);
  v_float32 theta = ray_theta;
  if constexpr (kKind == SourceParams::Kind::ray_polynomial) theta = cv::v_min(theta, cv::vx_setall_f32(r.theta_fit));
  v_float32 rho = cv::vx_setall_f32(r.c[r.n]);
  for (int i = r.n - 1; i >= 1; --i) rho = mul_add(rho, theta, cv::vx_setall_f32(r.c[i]));
  rho = rho * theta;
  v_float32 slope0 = cv::vx_setall_f32(r.c[1]);  // rho'(0)
  if constexpr (kKind == SourceParams::Kind::ray_polynomial) {
    // Newton on g(rho) = rho Pz + chi P(rho) (zero where the ray (rho, -P(rho)) has P's direction).
    for (int step = 0; step < 3; ++step) {  // from a start within a few px: float precision
      v_float32 poly = cv::vx_setall_f32(r.a[4]), dpoly = zero;
      for (int i = 3; i >= 0; --i) {
        dpoly = mul_add(dpoly, rho, poly), poly = mul_add(poly, rho, cv::vx_setall_f32(r.a[i]));
      }
      rho = rho - mul_add(chi, poly, rho * p.z) / mul_add(chi, dpoly, p.z);
    }
    // Past theta_fit the start is not trusted; the root lies beyond rho_fit, outside the image.
    rho = cv::v_select(ray_theta > cv::vx_setall_f32(r.theta_fit), cv::v_max(rho, cv::vx_setall_f32(r.rho_fit)), rho);
    slope0 = cv::vx_setall_f32(-r.a[0]);
  }
  // On the axis rho / chi -> rho'(0) / Pz.
  return cv::v_select(chi > zero, rho / chi, slope0 / p.z);
}

// f T(m): OpenCV's tangential and thin-prism terms (fishcam/core/tangential.hpp).
inline Vec2 tangential_offset(const PlaneForm& plane, float focal, const Vec2& m) {
  const v_float32 r2 = mul_add(m.x, m.x, m.y * m.y), mxy2 = cv::vx_setall_f32(2.0f) * m.x * m.y;
  const v_float32 p1 = cv::vx_setall_f32(plane.p1), p2 = cv::vx_setall_f32(plane.p2), f = cv::vx_setall_f32(focal);
  // T_x = 2 p1 x y + p2 (r2 + 2 x^2) + (s1 + s2 r2) r2, T_y = p1 (r2 + 2 y^2) + 2 p2 x y + (s3 + s4 r2) r2
  const v_float32 prism_x = mul_add(cv::vx_setall_f32(plane.s2), r2, cv::vx_setall_f32(plane.s1)) * r2;
  const v_float32 prism_y = mul_add(cv::vx_setall_f32(plane.s4), r2, cv::vx_setall_f32(plane.s3)) * r2;
  return {f * mul_add(p1, mxy2, mul_add(p2, mul_add(cv::vx_setall_f32(2.0f) * m.x, m.x, r2), prism_x)),
          f * mul_add(p2, mxy2, mul_add(p1, mul_add(cv::vx_setall_f32(2.0f) * m.y, m.y, r2), prism_y))};
}

// f delta_u of an mrcal lens, from its bicubic cells (PlaneForm). on_table: for a
// bounded table, whether g lies on it.
inline Vec2 lens_offset(const PlaneForm& plane, const Vec2& m, v_float32* on_table) {
  const v_float32 zero = cv::vx_setzero_f32();
  const v_float32 scale_g = cv::vx_setall_f32(plane.lens_scale);
  v_float32 gx = mul_add(m.x, scale_g, cv::vx_setall_f32(plane.lens_origin_x));
  v_float32 gy = mul_add(m.y, scale_g, cv::vx_setall_f32(plane.lens_origin_y));
  if (plane.lens_bounded) {
    // A table: past it the offset is its nearest edge's (NaN g: a corner's), and the
    // source outside the image (finish()); the coordinates stay continuous for the grid.
    const v_float32 cx = cv::v_min(cv::v_max(gx, zero), cv::vx_setall_f32(float(plane.lens_nx)));
    const v_float32 cy = cv::v_min(cv::v_max(gy, zero), cv::vx_setall_f32(float(plane.lens_ny)));
    *on_table = (cx == gx) & (cy == gy);
    gx = cx, gy = cy;
  }
  // The cell: g clamped into the grid before the floor (so any g, huge or NaN, gives
  // an index in it; max and min return their second operand for NaN).
  const v_float32 fx =
      cv::v_cvt_f32(cv::v_floor(cv::v_min(cv::v_max(gx, zero), cv::vx_setall_f32(float(plane.lens_nx - 1)))));
  const v_float32 fy =
      cv::v_cvt_f32(cv::v_floor(cv::v_min(cv::v_max(gy, zero), cv::vx_setall_f32(float(plane.lens_ny - 1)))));
  const v_float32 half = cv::vx_setall_f32(0.5f), t = gx - fx - half, s = gy - fy - half;
  // 32 (ny nx) < 2^24: the cell's first coefficient's index is exact in float.
  const cv::v_int32 first =
      cv::v_round(mul_add(fy, cv::vx_setall_f32(float(plane.lens_nx)), fx) * cv::vx_setall_f32(32.0f));
  // Neighbouring pixels mostly share a cell: then its coefficients are broadcast,
  // else gathered per lane (the same values either way).
  alignas(64) int firsts[cv::v_int32::nlanes];
  cv::v_store_aligned(firsts, first);
  const bool one_cell = cv::v_check_all(first == cv::vx_setall_s32(firsts[0]));
  const auto coefficient = [&](const float* at) {
    return one_cell ? cv::vx_setall_f32(at[firsts[0]]) : cv::v_lut(at, first);
  };
  Vec2 offset{zero, zero};
  v_float32* outputs[2] = {&offset.x, &offset.y};
  for (int k = 0; k < 2; ++k) {
    const float* cells = plane.lens_cells + 16 * k;
    v_float32 value = zero;
    for (int j = 3; j >= 0; --j) {
      v_float32 row = coefficient(cells + 4 * j + 3);
      for (int i = 2; i >= 0; --i) row = mul_add(row, t, coefficient(cells + 4 * j + i));
      value = mul_add(value, s, row);
    }
    *outputs[k] = value;
  }
  return offset;
}

// The pixel grid: pixel = c + a (.) (S (scale P_xy + offset)), the offset (with_offset)
// added before c: one rounding at the image's scale.
inline Vec2 grid_pixel(const GridForm& grid, const v_float32& scale, const Vec3& p, const Vec2& offset,
                       bool with_offset) {
  if (grid.skewed) {  // pixel = c + a (.) (S q)
    v_float32 qx = scale * p.x, qy = scale * p.y;
    if (with_offset) qx = qx + offset.x, qy = qy + offset.y;
    return {
        mul_add(cv::vx_setall_f32(grid.ax), mul_add(cv::vx_setall_f32(grid.xy), qy, qx), cv::vx_setall_f32(grid.cx)),
        mul_add(cv::vx_setall_f32(grid.ay), mul_add(cv::vx_setall_f32(grid.yx), qx, qy), cv::vx_setall_f32(grid.cy))};
  }
  if (with_offset) {
    return {mul_add(cv::vx_setall_f32(grid.ax), mul_add(scale, p.x, offset.x), cv::vx_setall_f32(grid.cx)),
            mul_add(cv::vx_setall_f32(grid.ay), mul_add(scale, p.y, offset.y), cv::vx_setall_f32(grid.cy))};
  }
  return {mul_add(cv::vx_setall_f32(grid.ax) * scale, p.x, cv::vx_setall_f32(grid.cx)),
          mul_add(cv::vx_setall_f32(grid.ay) * scale, p.y, cv::vx_setall_f32(grid.cy))};
}

// One vector of output pixels: rays d -> source pixel (x, y) and the inside mask.
template <DepthPrior kPrior, bool kInsideSphere, SourceParams::Kind kKind>
inline void warp_vector(const v_float32& dx, const v_float32& dy, const v_float32& dz, const PoseParams& pose,
                        const SourceParams& src, v_float32* out_x, v_float32* out_y, v_float32* inside) {
  const v_float32 zero = cv::vx_setzero_f32();
  v_float32 valid = dz == dz;  // false for the NaN rays of invalid output pixels
  const Vec3 p = rotated(pose, prior_point<kPrior, kInsideSphere>({dx, dy, dz}, pose, &valid));
  const v_float32 chi2 = mul_add(p.x, p.x, p.y * p.y);
  const v_float32 norm = cv::v_sqrt(mul_add(p.z, p.z, chi2));
  valid = valid & in_domain(src.domain, p, chi2, norm);
  if (!cv::v_check_any(valid)) {  // no ray in the domain (a view turned away from a narrow source): nothing to project
    *out_x = *out_y = cv::vx_setall_f32(kNaNf);
    *inside = zero;
    return;
  }
  v_float32 scale;                    // rho(theta) / chi
  Vec2 offset{zero, zero};            // the plane distortion's f T(m) or f delta_u, added before a and the skew
  v_float32 on_table = zero == zero;  // a lens table (lens_bounded): whether g lies on it
  bool with_offset = false;
  if constexpr (kKind == SourceParams::Kind::unified) {
    v_float32 d;
    scale = unified_scale(src.radial, p, chi2, norm, &d);
    if (src.plane.any()) {  // the plane is m = P_xy / D (alpha = 0: D = w)
      const v_float32 inverse = cv::vx_setall_f32(1.0f) / d;
      const Vec2 m{p.x * inverse, p.y * inverse};
      offset =
          src.plane.tangential ? tangential_offset(src.plane, src.radial.f, m) : lens_offset(src.plane, m, &on_table);
      with_offset = true;
    }
  } else {
    scale = polynomial_scale<kKind>(src.radial, p, chi2);
  }
  const Vec2 pixel = grid_pixel(src.grid, scale, p, offset, with_offset);
  valid = valid & (pixel.x == pixel.x) & (pixel.y == pixel.y);
  const v_float32 half = cv::vx_setall_f32(-0.5f);
  v_float32 in_image = valid & (pixel.x >= half) & (pixel.y >= half) &
                       (pixel.x < cv::vx_setall_f32(src.grid.width - 0.5f)) &
                       (pixel.y < cv::vx_setall_f32(src.grid.height - 0.5f));
  if (kKind == SourceParams::Kind::unified && src.plane.lens_bounded) {
    // Past the table the ray lands outside the image and its margin: coordinates that
    // say otherwise are none.
    valid = valid & (on_table | ~in_image);
    in_image = in_image & on_table;
  }
  const v_float32 nan = cv::vx_setall_f32(kNaNf);
  *out_x = cv::v_select(valid, pixel.x, nan);
  *out_y = cv::v_select(valid, pixel.y, nan);
  *inside = in_image;
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
  const v_float32 max_x = cv::vx_setall_f32(src.grid.width - 1), max_y = cv::vx_setall_f32(src.grid.height - 1);
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
    case SourceParams::Kind::ray_polynomial:
      return warp_range<kPrior, kInsideSphere, SourceParams::Kind::ray_polynomial, kSampling>;
  }
  return nullptr;
}

template <bool kSampling>
RangeKernel kernel_for(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind) {
  switch (prior) {
    case DepthPrior::infinity:
      return kernel_for_kind<DepthPrior::infinity, true, kSampling>(kind);
    case DepthPrior::target_sphere:
      return kernel_for_kind<DepthPrior::target_sphere, true, kSampling>(kind);
    case DepthPrior::source_sphere:
      return inside_sphere ? kernel_for_kind<DepthPrior::source_sphere, true, kSampling>(kind)
                           : kernel_for_kind<DepthPrior::source_sphere, false, kSampling>(kind);
  }
  return nullptr;
}

// Spacing 4: the four offsets of each cell interleaved, so 4 vectors of cells
// become the 4 x nlanes consecutive pixels of those cells.
inline void interpolate4(const float* column_x, const float* column_y, int cells, float* x, float* y) {
  constexpr int kLanes = v_float32::nlanes;
  const v_float32 quarter = cv::vx_setall_f32(0.25f);
  for (int i = 0; i < cells; i += kLanes) {
    for (int k = 0; k < 2; ++k) {
      const float* column = k == 0 ? column_x : column_y;
      float* out = k == 0 ? x : y;
      const v_float32 c = cv::vx_load(column + i), d = (cv::vx_load(column + i + 1) - c) * quarter;
      const v_float32 r1 = c + d, r2 = r1 + d, r3 = r2 + d;
      cv::v_store_interleave(out + 4 * i, c, r1, r2, r3);
    }
  }
}

// As cv::remap converts float maps itself: clamped onto the outer pixel centres,
// rounded to 1/32 px (integer part and the interpolation table's index), and
// rounded to the nearest pixel for labels; outside the image (or NaN): far outside.
inline void to_fixed_point(const float* x, const float* y, int w, float limit_x, float limit_y, float max_x,
                           float max_y, short* fixed, unsigned short* fractions, short* nearest, unsigned char* valid) {
  constexpr int kLanes = v_float32::nlanes;
  constexpr int kBits = 5, kSteps = 1 << kBits;  // cv::INTER_BITS
  int u = 0;
  const v_float32 low = cv::vx_setall_f32(-0.5f), lx = cv::vx_setall_f32(limit_x), ly = cv::vx_setall_f32(limit_y);
  const v_float32 zero = cv::vx_setzero_f32(), mx = cv::vx_setall_f32(max_x), my = cv::vx_setall_f32(max_y);
  const v_float32 scale = cv::vx_setall_f32(float(kSteps));
  const cv::v_int32 outside = cv::vx_setall_s32(kOutsideFixed), mask = cv::vx_setall_s32(kSteps - 1);
  for (; u + 2 * kLanes <= w; u += 2 * kLanes) {
    cv::v_int32 fx[2], fy[2], fr[2], nx[2], ny[2], in[2];
    for (int h = 0; h < 2; ++h) {
      const v_float32 sx = cv::vx_load(x + u + kLanes * h), sy = cv::vx_load(y + u + kLanes * h);
      in[h] = cv::v_reinterpret_as_s32((sx >= low) & (sx < lx) & (sy >= low) & (sy < ly));  // NaN: false
      const v_float32 cx = cv::v_min(cv::v_max(sx, zero), mx), cy = cv::v_min(cv::v_max(sy, zero), my);
      const cv::v_int32 ix = cv::v_round(cx * scale), iy = cv::v_round(cy * scale);
      fx[h] = cv::v_select(in[h], ix >> kBits, outside);
      fy[h] = cv::v_select(in[h], iy >> kBits, outside);
      fr[h] = cv::v_select(in[h], ((iy & mask) << kBits) | (ix & mask), cv::vx_setzero_s32());
      nx[h] = cv::v_select(in[h], cv::v_round(cx), outside);
      ny[h] = cv::v_select(in[h], cv::v_round(cy), outside);
    }
    cv::v_store_interleave(fixed + 2 * u, cv::v_pack(fx[0], fx[1]), cv::v_pack(fy[0], fy[1]));
    cv::v_store_interleave(nearest + 2 * u, cv::v_pack(nx[0], nx[1]), cv::v_pack(ny[0], ny[1]));
    cv::v_store(fractions + u, cv::v_pack_u(fr[0], fr[1]));
    if (valid) {
      const cv::v_int16 both = cv::v_pack(in[0], in[1]);  // -1 or 0
      cv::v_pack_store(valid + u, cv::v_reinterpret_as_u16(both & cv::vx_setall_s16(1)));
    }
  }
  for (; u < w; ++u) {
    const float sx = x[u], sy = y[u];
    const bool inside = sx >= -0.5f && sx < limit_x && sy >= -0.5f && sy < limit_y;
    if (valid) valid[u] = inside;
    if (!inside) {
      fixed[2 * u] = fixed[2 * u + 1] = nearest[2 * u] = nearest[2 * u + 1] = kOutsideFixed;
      fractions[u] = 0;
      continue;
    }
    const float cx = sx < 0 ? 0.0f : sx > max_x ? max_x : sx, cy = sy < 0 ? 0.0f : sy > max_y ? max_y : sy;
    const int ix = cvRound(cx * kSteps), iy = cvRound(cy * kSteps);
    fixed[2 * u] = short(ix >> kBits);
    fixed[2 * u + 1] = short(iy >> kBits);
    fractions[u] = static_cast<unsigned short>((iy & (kSteps - 1)) * kSteps + (ix & (kSteps - 1)));
    nearest[2 * u] = short(cvRound(cx));
    nearest[2 * u + 1] = short(cvRound(cy));
  }
}

// One dispatch per map: prior x (inside the sphere or not) x source model kind x output.
inline RangeKernel select_kernel(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  return sampling ? kernel_for<true>(prior, inside_sphere, kind) : kernel_for<false>(prior, inside_sphere, kind);
}

}  // namespace fishcam::detail::FISHCAM_KERNEL_ISA
