#include "fishcam/augmentation.hpp"

#include <opencv2/imgproc.hpp>

#include <atomic>
#include <cstdlib>
#include <cmath>

#include "warp_kernel.hpp"

namespace fishcam {
namespace {

using detail::PoseParams;
using detail::SourceParams;
static_assert(detail::kOutside == kOutsideSource);


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

PoseParams pose_params(const ViewpointChange& change) {
  PoseParams p;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) p.rt[3 * r + k] = float(change.rotation(k, r));
  }
  for (int k = 0; k < 3; ++k) p.t[k] = float(change.translation[k]);
  p.c = float(change.translation.squaredNorm() - 1);
  return p;
}

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

// The kernel for this CPU: AVX2 + FMA where available, else the build's baseline.
// FISHCAM_NO_AVX2 (set to anything) forces the baseline: how the tests cover it.
detail::RangeKernel select_kernel(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  static const bool avx2 = !std::getenv("FISHCAM_NO_AVX2") && cv::checkHardwareSupport(CV_CPU_AVX2) &&
                           cv::checkHardwareSupport(CV_CPU_FMA3);
  return avx2 ? detail::select_kernel_avx2(prior, inside_sphere, kind, sampling)
              : detail::select_kernel_baseline(prior, inside_sphere, kind, sampling);
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
  rays_.setTo(std::numeric_limits<float>::quiet_NaN());
  float* planes[3] = {rays_.ptr<float>(0), rays_.ptr<float>(1), rays_.ptr<float>(2)};
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) planes[k][i] = interleaved[3 * i + k];
  }
}

void ViewpointWarp::compute(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps, MapKind kind) const {
  allocate(source_, target_, kind, maps);
  const SourceParams src = source_params(source_);
  const PoseParams pose = pose_params(change);
  const bool sampling = kind == MapKind::sampling;
  const detail::RangeKernel kernel = select_kernel(prior, change.translation.squaredNorm() < 1, src.kind, sampling);
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

void ViewpointWarp::compute_exact(const ViewpointChange& change, DepthPrior prior, WarpMaps* maps) const {
  allocate(source_, target_, MapKind::geometric, maps);
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

cv::Mat WarpMaps::validity() const {
  if (kind == MapKind::geometric) return valid;
  cv::Mat inside = map_x != kOutsideSource;  // 0 or 255
  return inside & 1;
}

void warp_image(const cv::Mat& image, const WarpMaps& maps, cv::Mat* out) {
  check_input(image, maps, "warp_image");
  if (image.depth() != CV_8U && image.depth() != CV_16U) throw Error("warp_image: expected an 8- or 16-bit image");
  if (image.channels() < 1 || image.channels() > 4) throw Error("warp_image: expected 1 to 4 channels");
  if (maps.kind == MapKind::sampling) {
    // Sources inside the image were clamped onto it; the rest are far outside.
    cv::remap(image, *out, maps.map_x, maps.map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    return;
  }
  // Geometric maps: replicating the border only affects the outermost half pixel
  // (still inside the image); everything else is set by the mask, whatever remap
  // made of NaN coordinates.
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
  if (maps.kind == MapKind::geometric && maps.invalid_count > 0) out->setTo(cv::Scalar(fill), maps.valid == 0);
}

}  // namespace fishcam
