// The grid sampling path of ViewpointWarp::augment (docs/augmentation.md, "Grid
// sampling"): the float kernel at grid nodes every S output pixels, bilinear
// interpolation per tile straight into cv::remap's fixed-point maps, remap per tile.
#pragma once

#include <opencv2/core.hpp>

#include <memory>

#include "fishcam/augment/augmentation.hpp"
#include "warp_kernel.hpp"

namespace fishcam::detail {

// The float kernel for this CPU (AVX2 + FMA where available; FISHCAM_NO_AVX2 forces the baseline).
RangeKernel select_kernel_for_cpu(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling);
GridRowLoops grid_row_loops_for_cpu();
PoseParams pose_params(const RigidMotion& change);

struct GridPlan {
  int spacing = 0;               // S (px)
  int nodes_u = 0, nodes_v = 0;  // nodes per row and column: at u = i S, v = j S (the last may lie past the image)
  cv::Mat node_rays;             // 3 x padded(nodes_u * nodes_v) CV_32F planes; NaN where the target has no ray
  double measured_error_px = 0;  // worst interpolation error against the per-pixel float map at construction
  // The changes the measurement covered: larger ones take the per-pixel path.
  double max_rotation_rad = 0, max_translation = 0;
  // Cells with a corner whose source radius (px, in the source's normalised
  // coordinates times its largest pixel scale) reaches this are computed per pixel:
  // next to a fold the map bends too fast for the grid. Infinity: no fold.
  float fold_guard_radius = 0;
};

// The plan for this warp, or null when no spacing from 16 down to 2 px keeps the
// interpolation error within 1/32 px - 1e-3 (the float kernel's own tolerance).
std::shared_ptr<const GridPlan> make_grid_plan(const Camera& source, const Camera& target, const SourceParams& src,
                                               const cv::Mat& pixel_rays);

// Augments one sample through the grid; false (nothing written) when the change
// lies outside what the plan measured, so the caller takes the per-pixel path.
bool grid_augment(const GridPlan& plan, const SourceParams& src, const cv::Mat& pixel_rays, const Camera& target,
                  const RigidMotion& change, DepthPrior prior, const AugmentIO& io);

// The grid's float map (geometric, before fixed-point quantisation); false as grid_augment.
bool grid_maps(const GridPlan& plan, const SourceParams& src, const cv::Mat& pixel_rays, const Camera& target,
               const RigidMotion& change, DepthPrior prior, WarpMaps* maps);

}  // namespace fishcam::detail
