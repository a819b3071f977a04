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
#include <string>
#include <vector>

#include "grid_warp.hpp"
#include "kernel_source.hpp"
#include "warp_kernel.hpp"

namespace fishcam {
namespace {

// Whether two matrices' buffers overlap (an output given its own input).
bool shares_memory(const cv::Mat& a, const cv::Mat& b) {
  return !a.empty() && !b.empty() && a.datastart < b.dataend && b.datastart < a.dataend;
}

using detail::float_kernel_agrees;
using detail::float_source_params;
using detail::KernelSource;
using detail::pose_params;
using detail::PoseParams;
using detail::select_kernel_for_cpu;
using detail::SourceParams;
static_assert(detail::kOutside == kOutsideSource);

// cv::remap's own limit on image sizes (it asserts otherwise).
constexpr int kRemapSizeLimit = 32767;

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

std::optional<Eigen::Vector3d> source_point(const Eigen::Vector3d& d, const RigidMotion& change, DepthPrior prior) {
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

void ViewpointWarp::compute_grid(const RigidMotion& change, DepthPrior prior, WarpMaps* maps) const {
  check_change(change);
  if (grid_ && detail::grid_maps(*grid_, *kernel_source_, rays_, target_, change, prior, maps)) return;
  compute(change, prior, maps, MapKind::geometric);
}

int ViewpointWarp::grid_spacing() const { return grid_ ? grid_->spacing : 0; }
double ViewpointWarp::grid_error_px() const { return grid_ ? grid_->measured_error_px : 0; }

void ViewpointWarp::forward(const RigidMotion& change, const DepthSource& depth,
                            std::span<const Eigen::Vector2d> source_pixels, std::span<Eigen::Vector2d> pixels,
                            std::span<std::uint8_t> visible) const {
  check_change(change);
  if (pixels.size() != source_pixels.size() || visible.size() != source_pixels.size()) {
    throw Error("ViewpointWarp::forward: outputs of the wrong size");
  }
  if (const auto* map = std::get_if<DepthMap>(&depth))
    return forward_from_map(change, *map, source_pixels, pixels, visible);
  const DepthPrior prior = std::get<DepthPrior>(depth);
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

void ViewpointWarp::warp_depth(const RigidMotion& change, const DepthSource& source, const cv::Mat& depth,
                               DepthValues values, cv::Mat* out, float fill) const {
  if (depth.type() != CV_32FC1) throw Error("warp_depth: expected a float32 single-channel depth map");
  if (depth.cols != source_.width() || depth.rows != source_.height()) {
    throw Error("warp_depth: the depth map is " + std::to_string(depth.cols) + "x" + std::to_string(depth.rows) +
                " but the camera is " + std::to_string(source_.width()) + "x" + std::to_string(source_.height()));
  }
  if (const auto* map = std::get_if<DepthMap>(&source)) {
    return warp_depth_from_map(change, *map, depth, values, out, fill);
  }
  const DepthPrior prior = std::get<DepthPrior>(source);
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

namespace detail {

void check_image_planes(const AugmentIO& io) {
  const auto count = io.image_planes.size();
  if (io.image) throw Error("augment: an image and image planes given together");
  if (count > 4) throw Error("image: expected 1 to 4 planes, got " + std::to_string(count));
  if (io.out_image_planes.size() != count) {
    throw Error("augment: " + std::to_string(count) + " image planes but " +
                std::to_string(io.out_image_planes.size()) + " output planes");
  }
  for (std::size_t c = 0; c < count; ++c) {
    const cv::Mat &plane = io.image_planes[c], &out = io.out_image_planes[c];
    if (plane.channels() != 1 || plane.type() != io.image_planes[0].type() ||
        plane.size() != io.image_planes[0].size()) {
      throw Error("image: plane " + std::to_string(c) + " is not a single channel of the first plane's size and type");
    }
    if (out.type() != plane.type() || out.size() != io.out_image_planes[0].size()) {
      throw Error("augment: output plane " + std::to_string(c) +
                  " is not of the input planes' type and the first output plane's size");
    }
  }
}

void augment_through_interleaved(const AugmentIO& io, const std::function<void(const AugmentIO&)>& apply) {
  if (io.image_planes.empty()) return apply(io);
  check_image_planes(io);
  const auto count = io.image_planes.size();
  cv::Mat interleaved, out;
  cv::merge(io.image_planes.data(), count, interleaved);
  AugmentIO copy = io;
  copy.image_planes = {}, copy.out_image_planes = {};
  copy.image = &interleaved, copy.out_image = &out;
  apply(copy);
  if (io.out_image_planes[0].size() != out.size()) {
    throw Error("augment: the output planes are " + std::to_string(io.out_image_planes[0].cols) + "x" +
                std::to_string(io.out_image_planes[0].rows) + ", the output " + std::to_string(out.cols) + "x" +
                std::to_string(out.rows));
  }
  cv::split(out, io.out_image_planes.data());  // into the planes where they lie (their size and type)
}

}  // namespace detail

void ViewpointWarp::augment(const RigidMotion& change, const DepthSource& depth, const AugmentIO& io,
                            Sampling sampling) const {
  check_change(change);
  const DepthPrior* prior = std::get_if<DepthPrior>(&depth);
  const cv::Size source(source_.width(), source_.height());
  if (io.image) check_image_input(*io.image, source, io.fill, "image");
  if (io.labels) check_label_input(*io.labels, source, io.label_fill, "labels");
  if ((io.image && !io.out_image) || (io.labels && !io.out_labels)) throw Error("augment: an input without its output");
  bool planes_share_memory = false;
  if (!io.image_planes.empty()) {
    detail::check_image_planes(io);
    check_image_input(io.image_planes[0], source, io.fill, "image");
    if (io.out_image_planes[0].size() != cv::Size(target_.width(), target_.height())) {
      throw Error("augment: the output planes are " + std::to_string(io.out_image_planes[0].cols) + "x" +
                  std::to_string(io.out_image_planes[0].rows) + " but the target camera is " +
                  std::to_string(target_.width()) + "x" + std::to_string(target_.height()));
    }
    for (const cv::Mat& in : io.image_planes) {
      for (const cv::Mat& out : io.out_image_planes) planes_share_memory |= shares_memory(in, out);
    }
  }
  // An output in the memory of its input would be read while it is written: sample a copy.
  AugmentIO safe = io;
  cv::Mat image_copy, labels_copy;
  if (io.image && shares_memory(*io.image, *io.out_image)) safe.image = &(image_copy = io.image->clone());
  if (io.labels && shares_memory(*io.labels, *io.out_labels)) safe.labels = &(labels_copy = io.labels->clone());
  if (!planes_share_memory && prior && sampling == Sampling::grid && grid_ &&
      detail::grid_augment(*grid_, *kernel_source_, rays_, target_, change, *prior, safe)) {
    return;
  }
  if (!safe.image_planes.empty()) {  // planes the grid path did not sample: an interleaved copy (merged: no overlap)
    return detail::augment_through_interleaved(
        safe, [&](const AugmentIO& interleaved) { augment(change, depth, interleaved, sampling); });
  }
  WarpMaps maps;
  compute(change, depth, &maps);
  if (safe.image) warp_image(*safe.image, maps, safe.out_image, safe.fill);
  if (safe.labels) warp_labels(*safe.labels, maps, safe.label_fill, safe.out_labels);
  if (safe.valid) maps.validity().copyTo(*safe.valid);
}

void ViewpointWarp::compute(const RigidMotion& change, const DepthSource& depth, WarpMaps* maps, MapKind kind) const {
  check_change(change);
  if (const auto* map = std::get_if<DepthMap>(&depth)) return compute_from_map(change, *map, maps, kind);
  const DepthPrior prior = std::get<DepthPrior>(depth);
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

void ViewpointWarp::compute_exact(const RigidMotion& change, DepthPrior prior, WarpMaps* maps) const {
  check_change(change);
  compute_double(change, prior, maps, MapKind::geometric);
}

void ViewpointWarp::compute_double(const RigidMotion& change, DepthPrior prior, WarpMaps* maps, MapKind kind) const {
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
