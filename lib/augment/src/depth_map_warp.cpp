// ViewpointWarp under a depth map (DepthMap): the maps by forward rasterisation of the
// source image's pixel grid (augmentation.hpp), and the points and depths they move.
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "fishcam/augment/augmentation.hpp"

namespace fishcam {
namespace {

// A source pixel's scene point after the change: where it lands in the output and
// its range there (inf: a direction, the sky).
struct Landing {
  float x = 0, y = 0, range = 0;
  bool ok = false;
};

// 1. Every source pixel's landing in the target camera: where its scene point (at its
// depth value, moved by the change) projects, and its distance from the moved camera.
std::vector<Landing> source_landings(const Camera& source, const Camera& target, const RigidMotion& change,
                                     const cv::Mat& depth, DepthValues values) {
  const int sw = source.width(), sh = source.height();
  const Eigen::Matrix3d& r = change.rotation;
  const Eigen::Vector3d t = change.translation;
  std::vector<float> rays(3 * size_t(sw) * size_t(sh));
  source.unproject_image(rays, InversePath::table);
  std::vector<Landing> landing(size_t(sw) * size_t(sh));
  cv::parallel_for_(cv::Range(0, sh), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v) {
      for (int u = 0; u < sw; ++u) {
        const size_t i = size_t(v) * size_t(sw) + size_t(u);
        const Eigen::Vector3d d(rays[3 * i], rays[3 * i + 1], rays[3 * i + 2]);
        const double value = depth.at<float>(v, u);
        if (!d.allFinite() || !(value > 0)) continue;  // no ray, no depth (NaN, 0, negative)
        Eigen::Vector3d moved;
        double distance;
        if (std::isinf(value)) {
          moved = r * d, distance = std::numeric_limits<double>::infinity();
        } else {
          const double along = values == DepthValues::range ? value : value / d.z();
          if (!(along > 0) || !std::isfinite(along)) continue;  // z on a ray at or past 90 degrees
          moved = r * (along * d) + t, distance = moved.norm();
        }
        Eigen::Vector2d q;
        if (!target.project(moved, &q)) continue;
        landing[i] = {float(q.x()), float(q.y()), float(distance), true};
      }
    }
  });
  return landing;
}

// 2. Triangles of landed source pixels rasterised into the target with a z-buffer: each
// output pixel keeps the source coordinates of the nearest surface.
struct LandingRaster {
  static constexpr float kMaxExtent = 64;  // px: a one-pixel triangle stretched further spans a fold or wrap
  const std::vector<Landing>& landing;
  double edge_ratio;
  int tw, th;
  cv::Mat map_x = cv::Mat(th, tw, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  cv::Mat map_y = cv::Mat(th, tw, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  cv::Mat nearest = cv::Mat(th, tw, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  cv::Mat written = cv::Mat(th, tw, CV_8UC1, cv::Scalar(0));

  // The triangle of source pixels a, b, c (at source coordinates su, sv), unless it spans a depth edge.
  void draw(int a, int b, int c, const int (&su)[3], const int (&sv)[3]) {
    const Landing* l[3] = {&landing[size_t(a)], &landing[size_t(b)], &landing[size_t(c)]};
    if (!l[0]->ok || !l[1]->ok || !l[2]->ok) return;
    const float near = std::min({l[0]->range, l[1]->range, l[2]->range});
    const float far = std::max({l[0]->range, l[1]->range, l[2]->range});
    if (std::isinf(far) != std::isinf(near) || (std::isfinite(far) && far > edge_ratio * near)) return;  // a depth edge
    const float x0 = std::min({l[0]->x, l[1]->x, l[2]->x}), x1 = std::max({l[0]->x, l[1]->x, l[2]->x});
    const float y0 = std::min({l[0]->y, l[1]->y, l[2]->y}), y1 = std::max({l[0]->y, l[1]->y, l[2]->y});
    if (x1 - x0 > kMaxExtent || y1 - y0 > kMaxExtent) return;
    const double area =
        double(l[1]->x - l[0]->x) * (l[2]->y - l[0]->y) - double(l[2]->x - l[0]->x) * (l[1]->y - l[0]->y);
    if (area == 0) return;
    for (int y = std::max(0, int(std::ceil(y0))); y <= std::min(th - 1, int(std::floor(y1))); ++y) {
      for (int x = std::max(0, int(std::ceil(x0))); x <= std::min(tw - 1, int(std::floor(x1))); ++x) {
        // Barycentric weights of the output pixel centre (x, y).
        const double w1 =
            ((x - l[0]->x) * double(l[2]->y - l[0]->y) - double(l[2]->x - l[0]->x) * (y - l[0]->y)) / area;
        const double w2 =
            (double(l[1]->x - l[0]->x) * (y - l[0]->y) - (x - l[0]->x) * double(l[1]->y - l[0]->y)) / area;
        const double w0 = 1 - w1 - w2;
        constexpr double kEdge = -1e-6;  // pixel centres on a shared edge belong to both triangles
        if (w0 < kEdge || w1 < kEdge || w2 < kEdge) continue;
        const float range = std::isinf(far) ? far : float(w0 * l[0]->range + w1 * l[1]->range + w2 * l[2]->range);
        if (written.at<uchar>(y, x) && !(range < nearest.at<float>(y, x))) continue;
        written.at<uchar>(y, x) = 1, nearest.at<float>(y, x) = range;
        map_x.at<float>(y, x) = float(w0 * su[0] + w1 * su[1] + w2 * su[2]);
        map_y.at<float>(y, x) = float(w0 * sv[0] + w1 * sv[1] + w2 * sv[2]);
      }
    }
  }
};

}  // namespace

void ViewpointWarp::compute_from_map(const RigidMotion& change, const DepthMap& map, WarpMaps* maps,
                                     MapKind kind) const {
  check_change(change);
  const cv::Mat& depth = map.depth;
  if (depth.type() != CV_32FC1) throw Error("depth map: expected a float32 single-channel depth map");
  const int sw = source_.width(), sh = source_.height();
  if (depth.cols != sw || depth.rows != sh) {
    throw Error("depth map: it is " + std::to_string(depth.cols) + "x" + std::to_string(depth.rows) +
                " but the source camera is " + std::to_string(sw) + "x" + std::to_string(sh));
  }
  if (!(map.edge_ratio > 1)) throw Error("depth map: edge_ratio must be > 1");
  if (change.translation.isZero(0)) {
    // A rotation moves every point along with its direction, whatever its depth: the
    // priors' maps are exact and complete, where the triangles below would drop a
    // band at every depth edge.
    compute(change, DepthPrior::infinity, maps, kind);
    return;
  }
  const std::vector<Landing> landing = source_landings(source_, target_, change, depth, map.values);
  LandingRaster raster{.landing = landing, .edge_ratio = map.edge_ratio, .tw = target_.width(), .th = target_.height()};
  for (int v = 0; v + 1 < sh; ++v) {
    for (int u = 0; u + 1 < sw; ++u) {
      const int i = v * sw + u;
      raster.draw(i, i + 1, i + sw, {u, u + 1, u}, {v, v, v + 1});
      raster.draw(i + 1, i + sw + 1, i + sw, {u + 1, u + 1, u}, {v, v + 1, v + 1});
    }
  }
  // 3. In the maps' form (augmentation.hpp: MapKind).
  cv::Mat &map_x = raster.map_x, &map_y = raster.map_y, &written = raster.written;
  maps->kind = kind;
  maps->source_size = cv::Size(sw, sh);
  maps->invalid_count = long(written.total()) - cv::countNonZero(written);
  if (kind == MapKind::geometric) {
    maps->map_x = map_x, maps->map_y = map_y, maps->valid = written;
    return;
  }
  maps->valid.release();
  map_x.setTo(kOutsideSource, written == 0);
  map_y.setTo(kOutsideSource, written == 0);
  maps->map_x = map_x, maps->map_y = map_y;
}

namespace {

// The scene point of source pixel p (subpixel) at its depth value (range or z along the ray).
std::optional<Eigen::Vector3d> point_at(const Camera& source, const Eigen::Vector2d& p, double value,
                                        DepthValues values) {
  Eigen::Vector3d ray;
  if (!(value > 0) || !std::isfinite(value) || !source.unproject(p, &ray)) return std::nullopt;
  const double along = values == DepthValues::range ? value : value / ray.z();
  if (!(along > 0) || !std::isfinite(along)) return std::nullopt;
  return along * ray;
}

}  // namespace

void ViewpointWarp::forward_from_map(const RigidMotion& change, const DepthMap& map,
                                     std::span<const Eigen::Vector2d> source_pixels, std::span<Eigen::Vector2d> pixels,
                                     std::span<std::uint8_t> visible) const {
  const cv::Mat& depth = map.depth;
  const DepthValues values = map.values;
  WarpMaps maps;
  compute_from_map(change, map, &maps, MapKind::geometric);
  for (size_t i = 0; i < source_pixels.size(); ++i) {
    pixels[i] = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    visible[i] = 0;
    const Eigen::Vector2d& p = source_pixels[i];
    const long u = std::lround(p.x()), v = std::lround(p.y());
    if (!(u >= 0 && v >= 0 && u < depth.cols && v < depth.rows)) continue;
    const double value = depth.at<float>(int(v), int(u));
    Eigen::Vector3d moved;
    if (std::isinf(value) && value > 0) {  // the sky: a direction
      Eigen::Vector3d ray;
      if (!source_.unproject(p, &ray)) continue;
      moved = change.rotation * ray;
    } else {
      const auto point = point_at(source_, p, value, values);
      if (!point) continue;
      moved = change.rotation * *point + change.translation;
    }
    Eigen::Vector2d q;
    if (!target_.project(moved, &q)) continue;
    pixels[i] = q;
    const long x = std::lround(q.x()), y = std::lround(q.y());
    if (x < 0 || y < 0 || x >= maps.map_x.cols || y >= maps.map_x.rows || !maps.valid.at<uchar>(int(y), int(x)))
      continue;
    const Eigen::Vector2d sampled(maps.map_x.at<float>(int(y), int(x)), maps.map_y.at<float>(int(y), int(x)));
    visible[i] = (sampled - p).norm() <= 1.5;
  }
}

void ViewpointWarp::warp_depth_from_map(const RigidMotion& change, const DepthMap& map, const cv::Mat& depth,
                                        DepthValues values, cv::Mat* out, float fill) const {
  WarpMaps maps;
  compute_from_map(change, map, &maps, MapKind::geometric);
  out->create(maps.map_x.size(), CV_32FC1);
  cv::parallel_for_(cv::Range(0, out->rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      float* row = out->ptr<float>(y);
      for (int x = 0; x < out->cols; ++x) {
        row[x] = fill;
        if (!maps.valid.at<uchar>(y, x)) continue;
        const Eigen::Vector2d p(maps.map_x.at<float>(y, x), maps.map_y.at<float>(y, x));
        const int u = std::clamp(int(std::lround(p.x())), 0, depth.cols - 1);
        const int v = std::clamp(int(std::lround(p.y())), 0, depth.rows - 1);
        const double value = depth.at<float>(v, u);
        if (!(value > 0) || !std::isfinite(value)) {
          row[x] = float(value);  // no-depth markers and the sky's infinity as they are
          continue;
        }
        const auto point = point_at(source_, p, value, values);
        if (!point) {
          row[x] = std::numeric_limits<float>::quiet_NaN();
          continue;
        }
        const Eigen::Vector3d moved = change.rotation * *point + change.translation;
        row[x] = float(values == DepthValues::z ? moved.z() : moved.norm());
      }
    }
  });
}

}  // namespace fishcam
