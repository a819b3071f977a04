// Viewpoint augmentation as an exact inverse warp (docs/augmentation.md): for each
// output pixel, its ray d, the source point P with R P + t = s d under a depth
// prior, and P projected by the source camera.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "fishcam/augment/viewpoint.hpp"
#include "fishcam/core/camera.hpp"

namespace fishcam {
namespace detail {
struct SourceParams;
struct GridPlan;
}  // namespace detail

// What the maps hold.
enum class MapKind {
  // For resampling (what augment uses): where a pixel has a source inside the
  // source image, its coordinates (clamped onto the outer pixel centres, which
  // moves them by at most half a pixel); elsewhere kOutsideSource, so that
  // cv::remap with BORDER_CONSTANT yields exactly the fill value there.
  sampling,
  // For inspection and export (`fishcam map`, the mrcal check): the source
  // coordinates as computed, also outside the source image (a source with a
  // tabulated mrcal lens: approximate past ~16 px outside, docs/augmentation.md);
  // NaN where there is no valid source; plus `valid`.
  geometric,
};

std::optional<MapKind> parse_map_kind(std::string_view name);  // "sampling" | "geometric"
const std::vector<std::string>& map_kind_names();              // Python's choices, messages
std::string_view to_string(MapKind kind);

// The sampling maps' coordinate for pixels without a source inside the source image.
constexpr float kOutsideSource = -100000.0f;

// Where each output pixel samples the source image.
struct WarpMaps {
  MapKind kind = MapKind::sampling;
  cv::Mat map_x, map_y;    // CV_32FC1, output size (see MapKind)
  cv::Mat valid;           // geometric maps: CV_8UC1, 1 where the source pixel lies inside the
                           // source image ([-0.5, W - 0.5) x [-0.5, H - 0.5)); empty for sampling maps
  long invalid_count = 0;  // output pixels without a source inside the source image
  cv::Size source_size;    // the source image size the maps sample

  // 1 where the output pixel has a source inside the source image (either kind).
  cv::Mat validity() const;
};

// How ViewpointWarp::augment resamples.
enum class Sampling {
  // The map at grid nodes every grid_spacing() px (float kernel), interpolated per
  // tile of rows straight into cv::remap's fixed-point maps, remapped per tile: at
  // most 1/32 px (cv::remap's own fixed-point step) from the per-pixel map, measured
  // when the warp is built. Cells without a source at every corner, or next to a
  // fold, are computed per pixel; the inside/outside decision is per pixel. Changes
  // wider than the measured ones (the `large` preset's extremes) take the exact path.
  grid,
  // compute()'s per-pixel maps, then warp_image / warp_labels.
  exact,
};
std::optional<Sampling> parse_sampling(std::string_view name);  // "grid" | "exact"
const std::vector<std::string>& sampling_names();               // the CLI's choices, Python, messages
std::string_view to_string(Sampling sampling);

// What a depth map's values are: the range (distance from the camera centre along
// the pixel's ray) or z (distance along the optical axis).
enum class DepthValues { range, z };
std::optional<DepthValues> parse_depth_values(std::string_view name);  // "range" | "z"
const std::vector<std::string>& depth_values_names();                  // the choices, Python, messages
std::string_view to_string(DepthValues values);

// A depth map of the source image in place of a prior (the paper's future work):
// `depth` (CV_32FC1, source size; range or z per `values`, in the units of the
// change's translation) along each source pixel's ray. A triangle of neighbouring
// source pixels whose corners' depths differ by more than `edge_ratio` (a depth
// edge) is not drawn (ViewpointWarp::compute).
struct DepthMap {
  cv::Mat depth;
  DepthValues values = DepthValues::range;
  double edge_ratio = 1.1;
};
// Where a source pixel's scene point lies: on a prior's surface (depth_prior.hpp) or
// at a depth map's value. Every ViewpointWarp operation takes either.
using DepthSource = std::variant<DepthPrior, DepthMap>;

// One sample to augment: any of the image and the labels (with their outputs),
// and optionally where the output has a source.
struct AugmentIO {
  const cv::Mat* image = nullptr;  // source size; 8/16-bit or float32, 1-4 channels; bilinear
  cv::Mat* out_image = nullptr;
  double fill = 0;                  // where there is no source (saturated to the image's type)
  const cv::Mat* labels = nullptr;  // source size; CV_8UC1 or CV_16UC1; nearest neighbour
  cv::Mat* out_labels = nullptr;
  int label_fill = 0;
  cv::Mat* valid = nullptr;  // CV_8UC1, 1 where the output pixel has a source inside the source image
  // A channels-first image in place of `image` / `out_image`: its planes (1 to 4,
  // one channel each, the source's size, one type) and the output's planes (the
  // target's size and that type, allocated by the caller: written where they lie).
  // On the grid path with AVX2, 8-bit planes (more than one) are interleaved into a
  // buffer the calling thread keeps, one plane is read where it lies, and the output
  // planes are written directly; other paths take them through an interleaved copy
  // whose output is split into the planes.
  std::span<const cv::Mat> image_planes = {};
  std::span<cv::Mat> out_image_planes = {};
};

namespace detail {
// `apply` run on an interleaved copy of io's channels-first image (image_planes),
// its output split back into out_image_planes: how a path without a planar form
// takes one. Checks the planes (Error naming what is wrong).
void check_image_planes(const AugmentIO& io);
void augment_through_interleaved(const AugmentIO& io, const std::function<void(const AugmentIO&)>& apply);
}  // namespace detail

// The source point on the unit sphere (source camera frame) seen along the output
// ray d (unit) after the viewpoint change, under the depth prior; nullopt where
// there is none (|t| >= 1 and the ray misses or only grazes the sphere).
std::optional<Eigen::Vector3d> source_point(const Eigen::Vector3d& d, const RigidMotion& change, DepthPrior prior);

class ViewpointWarp {
 public:
  // Caches the output camera's rays (all that depends on it alone): each pose then
  // costs only rotate / intersect / project per pixel. Throws Error for images
  // 32767 px or more wide or tall (cv::remap takes fewer).
  ViewpointWarp(Camera source, Camera target);
  explicit ViewpointWarp(const Camera& camera) : ViewpointWarp(camera, camera) {}

  const Camera& source() const { return source_; }
  const Camera& target() const { return target_; }

  // The maps. Under a prior: in float with SIMD (OpenCV universal intrinsics; AVX2
  // where the CPU has it) on OpenCV's threads; accuracy against compute_exact:
  // <= 1e-3 px. Where float cannot promise that (float_kernel() false: models without
  // a float form, polynomials past degree 15, coordinates past 8192 px, parameters
  // outside float's range, or a failed check of the kernel against Camera::project
  // over the source's valid domain at construction), the maps come from the exact
  // path.
  // Under a depth map: every source pixel's scene point moves by the change;
  // neighbouring source pixels form triangles, each rasterised into the output with
  // a z-buffer (the nearest surface wins) and its source coordinates interpolated. A
  // triangle across a depth edge (DepthMap::edge_ratio) or with a corner without
  // depth is not drawn, so pixels that nothing lands on (disocclusions) have no
  // source: never invented. Infinite depths (the sky) move as directions. A pure
  // rotation needs no depth: its maps are the priors' (exact, and without the bands
  // the triangles lose at depth edges).
  // Throws Error for a non-finite or non-rotation change, and for a depth map of the
  // wrong type or size.
  void compute(const RigidMotion& change, const DepthSource& depth, WarpMaps* maps,
               MapKind kind = MapKind::sampling) const;
  // Geometric maps in double through Camera::project, pixel by pixel: the reference
  // (under a prior).
  void compute_exact(const RigidMotion& change, DepthPrior prior, WarpMaps* maps) const;
  // Whether compute() uses the float kernel (decided once, at construction).
  bool float_kernel() const { return kernel_source_ != nullptr; }

  // One augmented sample (what `fishcam augment` writes). Under a prior:
  // Sampling::grid by default, Sampling::exact for compute()'s maps; under a depth
  // map, compute()'s maps whatever the sampling. Outputs are written in place when
  // they already have the output size and the input's type. Throws Error for bad
  // inputs (as warp_image / warp_labels) and non-finite changes.
  void augment(const RigidMotion& change, const DepthSource& depth, const AugmentIO& io,
               Sampling sampling = Sampling::grid) const;
  // The forward direction, for points (keypoints, polygon vertices, box outlines):
  // where the scene point of each source pixel appears in the output, exactly
  // (double; the maps' inverse). Under a prior, the point on its ray at the prior's
  // distance, visible[i] 1 where the output pixel lies inside the output image and
  // its own source point is this one (0 where the point left the view or is hidden:
  // the far side of the prior's sphere). Under a depth map, the point at the depth of
  // its nearest source pixel, visible where it lands inside the output and the output
  // pixel there samples it (within 1.5 px), not a nearer surface. NaN where the
  // source pixel has no ray or the moved point no projection. Throws Error for a
  // non-finite change.
  void forward(const RigidMotion& change, const DepthSource& depth, std::span<const Eigen::Vector2d> source_pixels,
               std::span<Eigen::Vector2d> pixels, std::span<std::uint8_t> visible) const;
  // A depth map (CV_32FC1, source size; `values`) seen from the moved camera: sampled
  // as the labels are (nearest neighbour, so never blended across depth edges), each
  // value re-expressed as the range or z of its scene point in the moved camera (the
  // point at that range or z along the source ray the output pixel samples, under
  // `depth`'s maps): exact for rotations; under a prior with a translation the point
  // is where the depth map says, but it is drawn at the pixel the prior puts it.
  // Values that are not finite and positive (no-depth markers, the sky's infinity)
  // are copied as they are; pixels without a source become `fill`. *out may be
  // preallocated (output size, CV_32FC1).
  void warp_depth(const RigidMotion& change, const DepthSource& depth, const cv::Mat& depth_map, DepthValues values,
                  cv::Mat* out, float fill = std::numeric_limits<float>::quiet_NaN()) const;

  // The grid's node spacing (px) and its measured worst interpolation error (px)
  // against the per-pixel float map; 0 and 0 where there is no grid (no float
  // kernel, or no spacing from 16 down to 2 px interpolates 80 % of the cells within
  // 1/32 px; docs/augmentation.md): augment() then samples per pixel whatever it is
  // asked, as it does for changes past the measured ones.
  int grid_spacing() const;
  double grid_error_px() const;
  // The grid path's source coordinates as geometric maps (float, before cv::remap's
  // fixed-point quantisation; for inspection and tests). Where augment() would not
  // use the grid, compute()'s geometric maps.
  void compute_grid(const RigidMotion& change, DepthPrior prior, WarpMaps* maps) const;

 private:
  void compute_double(const RigidMotion& change, DepthPrior prior, WarpMaps* maps, MapKind kind) const;
  // compute(), forward() and warp_depth() under a depth map (depth_map_warp.cpp).
  void compute_from_map(const RigidMotion& change, const DepthMap& map, WarpMaps* maps, MapKind kind) const;
  void forward_from_map(const RigidMotion& change, const DepthMap& map, std::span<const Eigen::Vector2d> source_pixels,
                        std::span<Eigen::Vector2d> pixels, std::span<std::uint8_t> visible) const;
  void warp_depth_from_map(const RigidMotion& change, const DepthMap& map, const cv::Mat& depth_map, DepthValues values,
                           cv::Mat* out, float fill) const;

  Camera source_, target_;
  // The source camera in the float kernel's form, decided once at construction;
  // null: the exact path. Immutable, so copies of the warp share it.
  std::shared_ptr<const detail::SourceParams> kernel_source_;
  std::shared_ptr<const detail::GridPlan> grid_;  // null: no grid
  cv::Mat rays_;  // 3 x (W*H) CV_32F planes x, y, z of the target's unit rays; NaN where invalid
};

// Bilinear resampling of an image (CV_8U, CV_16U or CV_32F, 1-4 channels, source
// size) with either kind of maps; pixels without a source inside the source image
// become `fill` (saturated to the image's type). *out may be preallocated (size of
// the maps, type of the image): it is then written in place.
void warp_image(const cv::Mat& image, const WarpMaps& maps, cv::Mat* out, double fill = 0);
// Nearest-neighbour resampling of a label image (CV_8UC1 or CV_16UC1): values are
// copied, never blended; pixels without a valid source become `fill`.
void warp_labels(const cv::Mat& labels, const WarpMaps& maps, int fill, cv::Mat* out);

}  // namespace fishcam
