// Viewpoint augmentation as an exact inverse warp (docs/augmentation.md): for each
// output pixel, its ray d, the source point P with R P + t = s d under a depth
// prior, and P projected by the source camera.
#pragma once

#include <opencv2/core.hpp>

#include <memory>
#include <optional>

#include "fishcam/camera.hpp"
#include "fishcam/viewpoint.hpp"

namespace fishcam {
namespace detail {
struct SourceParams;
}  // namespace detail

// What the maps hold.
enum class MapKind {
  // For resampling (what augment uses): where a pixel has a source inside the
  // source image, its coordinates (clamped onto the outer pixel centres, which
  // moves them by at most half a pixel); elsewhere kOutsideSource, so that
  // cv::remap with BORDER_CONSTANT yields exactly the fill value there.
  sampling,
  // For inspection and export (`fishcam map`, the mrcal check): the source
  // coordinates as computed, also outside the source image; NaN where there is
  // no valid source; plus `valid`.
  geometric,
};

// The sampling maps' coordinate for pixels without a source inside the source image.
constexpr float kOutsideSource = -100000.0f;

// Where each output pixel samples the source image.
struct WarpMaps {
  MapKind kind = MapKind::sampling;
  cv::Mat map_x, map_y;  // CV_32FC1, output size (see MapKind)
  cv::Mat valid;         // geometric maps: CV_8UC1, 1 where the source pixel lies inside the
                         // source image ([-0.5, W - 0.5) x [-0.5, H - 0.5)); empty for sampling maps
  long invalid_count = 0;  // output pixels without a source inside the source image
  cv::Size source_size;    // the source image size the maps sample

  // 1 where the output pixel has a source inside the source image (either kind).
  cv::Mat validity() const;
};

// The source point on the unit sphere (source camera frame) seen along the output
// ray d (unit) after the viewpoint change, under the depth prior; nullopt where
// there is none (|t| >= 1 and the ray misses or only grazes the sphere).
std::optional<Eigen::Vector3d> source_point(const Eigen::Vector3d& d, const ViewpointChange& change,
                                            DepthPrior prior);

class ViewpointWarp {
 public:
  // Caches the output camera's rays (all that depends on it alone): each pose then
  // costs only rotate / intersect / project per pixel. Throws Error for images
  // wider or taller than cv::remap's limit (32767).
  ViewpointWarp(Camera source, Camera target);
  explicit ViewpointWarp(const Camera& camera) : ViewpointWarp(camera, camera) {}

  const Camera& source() const { return source_; }
  const Camera& target() const { return target_; }

  // The maps, in float with SIMD (OpenCV universal intrinsics; AVX2 where the CPU
  // has it) on OpenCV's threads; accuracy against compute_exact: <= 1e-3 px. Where
  // float cannot promise that (float_kernel() false: models without a float form,
  // polynomials past degree 15, coordinates past 8192 px, parameters outside
  // float's range, or a failed check of the kernel against Camera::project over
  // the source's valid domain at construction), the maps come from the exact path.
  // Throws Error for a non-finite or non-rotation change.
  void compute(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps,
               MapKind kind = MapKind::sampling) const;
  // Geometric maps in double through Camera::project, pixel by pixel: the reference.
  void compute_exact(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps) const;
  // Whether compute() uses the float kernel (decided once, at construction).
  bool float_kernel() const { return kernel_source_ != nullptr; }

 private:
  void compute_double(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps, MapKind kind) const;

  Camera source_, target_;
  // The source camera in the float kernel's form, decided once at construction;
  // null: the exact path. Immutable, so copies of the warp share it.
  std::shared_ptr<const detail::SourceParams> kernel_source_;
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
