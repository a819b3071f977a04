// Viewpoint augmentation as an exact inverse warp (docs/augmentation.md): for each
// output pixel, its ray d, the source point P with R P + t = s d under a depth
// prior, and P projected by the source camera.
#pragma once

#include <opencv2/core.hpp>

#include <optional>

#include "fishcam/camera.hpp"
#include "fishcam/viewpoint.hpp"

namespace fishcam {

// Where each output pixel samples the source image.
struct WarpMaps {
  cv::Mat map_x, map_y;  // CV_32FC1, output size: source pixel (x, y); NaN where there is no valid source
  cv::Mat valid;         // CV_8UC1: 1 where the source pixel lies inside the source image
                         // ([-0.5, W - 0.5) x [-0.5, H - 0.5)), else 0
  long invalid_count = 0;  // number of zeros in `valid`
  cv::Size source_size;    // the source image size the maps sample
};

// The source point on the unit sphere (source camera frame) seen along the output
// ray d (unit) after the viewpoint change, under the depth prior; nullopt where
// there is none (|t| >= 1 and the ray misses or only grazes the sphere).
std::optional<Eigen::Vector3d> source_point(const Eigen::Vector3d& d, const ViewpointChange& change,
                                            DepthPrior prior);

class ViewpointWarp {
 public:
  // Caches the output camera's rays (all that depends on it alone): each pose then
  // costs only rotate / intersect / project per pixel.
  ViewpointWarp(Camera source, Camera target);
  explicit ViewpointWarp(const Camera& camera) : ViewpointWarp(camera, camera) {}

  const Camera& source() const { return source_; }
  const Camera& target() const { return target_; }

  // The maps, in float with SIMD (OpenCV universal intrinsics) on OpenCV's threads.
  // Accuracy against compute_exact: a few 1e-4 px (float32 maps).
  void compute(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps) const;
  // The same in double through Camera::project, pixel by pixel: the reference.
  void compute_exact(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps) const;

 private:
  Camera source_, target_;
  cv::Mat rays_;  // 3 x (W*H) CV_32F planes x, y, z of the target's unit rays; NaN where invalid
};

// Bilinear resampling of an image (CV_8U or CV_16U, 1-4 channels, source size);
// pixels without a valid source become 0.
void warp_image(const cv::Mat& image, const WarpMaps& maps, cv::Mat* out);
// Nearest-neighbour resampling of a label image (CV_8UC1 or CV_16UC1): values are
// copied, never blended; pixels without a valid source become `fill`.
void warp_labels(const cv::Mat& labels, const WarpMaps& maps, int fill, cv::Mat* out);

}  // namespace fishcam
