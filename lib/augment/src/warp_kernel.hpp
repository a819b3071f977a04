// The per-pixel kernel of ViewpointWarp::compute, compiled once per instruction set
// (warp_kernel_baseline.cpp, warp_kernel_avx2.cpp) from warp_kernel_impl.hpp and
// chosen at run time. Kept free of OpenCV's Mat and of the standard library's
// out-of-line templates, so the ISA-specific objects share no inline code.
#pragma once

#include <cstddef>

#include "fishcam/augment/depth_prior.hpp"

namespace fishcam::detail {

// The source camera as the float kernel needs it: the float forms of its parts
// (docs/architecture.md, "A camera is a chain of parts"), each filled by the part's
// kernel form in augmentation.cpp. Which cameras the kernel can evaluate accurately
// is decided in one place, float_source_params() there; the others take the exact path.

// The radial model. polynomial: rho(theta) as a polynomial; unified: the
// unified-camera form (fishcam::UnifiedForm: pinhole, stereographic, unified,
// extended-unified, double-sphere, mei, opencv); ray_polynomial: rho the root of
// rho Pz + chi P(rho) (ocam: the ray (rho, -P(rho))), three Newton steps from a
// polynomial start in theta.
struct RadialForm {
  enum class Kind { polynomial, unified, ray_polynomial };
  // Polynomials up to this degree are evaluated in float (16 coefficients: its
  // fixed array); higher ones take the exact path.
  static constexpr int kMaxDegree = 15;
  Kind kind = Kind::polynomial;
  float c[kMaxDegree + 1] = {};  // rho = c[1] theta + ... + c[n] theta^n, 1 <= n <= kMaxDegree
  int n = 0;
  float f = 0, xi = 0, alpha = 0, beta = 1, k1 = 0, k2 = 0, k3 = 0, k4 = 0, k5 = 0, k6 = 0;  // unified
  // ray_polynomial: P's a0..a4, the start c[] (n) fitted on [0, theta_fit], past which
  // rho is at least rho_fit (beyond the source image: no Newton start is trusted there).
  float a[5] = {};
  float theta_fit = 0, rho_fit = 0;
};

// The plane distortion, on the plane m = P_xy / D of the unified form with alpha = 0.
struct PlaneForm {
  // Tangential and thin-prism terms.
  bool tangential = false;
  float p1 = 0, p2 = 0, s1 = 0, s2 = 0, s3 = 0, s4 = 0;
  // An mrcal lens (fishcam/core/mrcal_lens.hpp) on a stereographic or pinhole camera
  // (xi = 1 or 0): f delta_u per cell, cell coordinates
  // g = m * lens_scale + lens_origin (the plane u = m * lens_scale /
  // cells_per_u); per cell 32 floats, x's then y's bicubic in (t, s) = g - cell - 1/2
  // (about the cell's centre, in pixels before a): coefficient of t^i s^j at 4 j + i;
  // NaN cells have no projection. mrcal's spline (its polynomial cells,
  // MrcalLens::polynomial_cells): the cell index clamped to the nx x ny grid (mrcal
  // extrapolates its outer cells). The other lenses (lens_bounded): a table over the
  // plane around the source image; for g outside [0, nx] x [0, ny] the offset of the
  // table's nearest edge, and no source in the image. Null: none.
  const float* lens_cells = nullptr;
  int lens_nx = 0, lens_ny = 0;
  bool lens_bounded = false;
  float lens_scale = 0, lens_origin_x = 0, lens_origin_y = 0;

  bool any() const { return tangential || lens_cells; }
};

// The pixel grid: pixel = c + a (.) ([1 xy; yx 1] q) (CameraParameters::skew), and the image's size.
struct GridForm {
  bool skewed = false;
  float xy = 0, yx = 0;
  float cx = 0, cy = 0, ax = 1, ay = 1;
  float width = 0, height = 0;
};

// The valid domain: theta <= theta_max (closed) or < theta_max.
struct DomainForm {
  float cos_theta_max = -1;
  bool closed = true;
};

struct SourceParams {
  using Kind = RadialForm::Kind;
  RadialForm radial;
  PlaneForm plane;
  GridForm grid;
  DomainForm domain;
};

struct PoseParams {
  float rt[9];  // R transposed, row-major: P = R^T q
  float t[3];
  float c;  // |t|^2 - 1
};

// Where the sampling maps send pixels without a source inside the source image:
// far enough outside that bilinear sampling sees only the border value.
constexpr float kOutside = -100000.0f;

struct KernelOutput {
  float* map_x;
  float* map_y;
  unsigned char* valid;  // geometric maps only
};

// Output pixels [begin, end) of the flat image; returns how many have no source
// inside the source image. Geometric maps: raw source coordinates, NaN without a
// source, and `valid`. Sampling maps: coordinates clamped into the image, kOutside
// without a source inside it.
using RangeKernel = long (*)(const float* rx, const float* ry, const float* rz, std::size_t begin, std::size_t end,
                             const PoseParams& pose, const SourceParams& source, const KernelOutput& out);

RangeKernel select_kernel_baseline(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling);
RangeKernel select_kernel_avx2(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling);

// The grid path's row loops (grid_warp.cpp), per instruction set like the kernel.
// Where pixels without a source inside the source image point in the fixed-point
// maps: far enough outside for all four bilinear taps to read the border value.
constexpr short kOutsideFixed = -16384;
// An 8-bit source image for GridRowLoops::bilinear_8u.
struct BilinearSource {
  const unsigned char* data;  // first row
  const unsigned char* end;   // one past the last byte of the last row (reads stay before it)
  std::size_t step;           // bytes per row
  int width, height, channels;
  unsigned char fill[4];  // the border value per channel
};
struct GridRowLoops {
  // Spacing 4: pixels 4i .. 4i+3 from the node columns interpolated to the row,
  // column[i] + a (column[i+1] - column[i]) / 4 for a = 0..3, cells [0, cells)
  // rounded up to whole vectors (the outputs have room past the row).
  void (*interpolate4)(const float* column_x, const float* column_y, int cells, float* x, float* y);
  // A row of source coordinates in cv::remap's fixed-point form (see grid_warp.cpp);
  // valid may be null.
  void (*to_fixed_point)(const float* x, const float* y, int w, float limit_x, float limit_y, float max_x, float max_y,
                         short* fixed, unsigned short* fractions, short* nearest, unsigned char* valid);
  // cv::remap's INTER_LINEAR + BORDER_CONSTANT of an 8-bit image with 1 to 4
  // channels from one row of those maps, byte for byte; null where the instruction
  // set has no fast form (the caller then calls cv::remap). The image is smaller
  // than 2 GiB; the maps can be read 7 pixels past the row (those values are unused).
  void (*bilinear_8u)(const BilinearSource& source, const short* fixed, const unsigned short* fractions, int w,
                      unsigned char* out);
  // The same with channel c written to out[c] (a channels-first output's row of
  // plane c); null where bilinear_8u is.
  void (*bilinear_8u_to_planes)(const BilinearSource& source, const short* fixed, const unsigned short* fractions,
                                int w, unsigned char* const* out);
};
GridRowLoops grid_row_loops_baseline();
GridRowLoops grid_row_loops_avx2();

}  // namespace fishcam::detail
