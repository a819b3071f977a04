#include "fishcam/augment/affine.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>

#include "fishcam/augment/viewpoint.hpp"
#include "fishcam/core/error.hpp"

namespace fishcam {

void check_affine(const AffineChange& change) {
  if (!std::isfinite(change.rotation_deg) || !change.translation.allFinite() || !std::isfinite(change.scale)) {
    throw Error("affine change: rotation, translation and scale must be finite");
  }
  if (!(change.scale > 0)) throw Error("affine change: scale must be positive");
}

const std::array<AffinePreset, 4>& affine_presets() {
  static const std::array<AffinePreset, 4> presets = {{
      {"small", 10, 0.1, 1 - 0.5 / 3, 1 + 0.5 / 3},
      {"medium", 20, 0.2, 1 - 1.0 / 3, 1 + 1.0 / 3},
      {"large", 30, 0.3, 0.5, 1.5},
      {"train", 30, 0.3, 0.5, 1.5},
  }};
  return presets;
}

std::optional<AffinePreset> find_affine_preset(std::string_view name) {
  for (const auto& p : affine_presets()) {
    if (p.name == name) return p;
  }
  return std::nullopt;
}

AffinePreset affine_preset(std::string_view name, std::string_view what) {
  if (const auto preset = find_affine_preset(name)) return *preset;
  std::vector<std::string> names;
  for (const auto& p : affine_presets()) names.emplace_back(p.name);
  throw Error(std::string(what) + ": unknown preset " + quoted_for_message(name) + " (expected " +
              choices_for_message(names) + ")");
}

AffineChange random_affine(const AffinePreset& preset, std::uint64_t seed) {
  SeededUniform uniform(seed);
  AffineChange change;
  change.rotation_deg = uniform.symmetric(preset.max_rotation_deg);
  change.translation.x() = uniform.symmetric(preset.max_translation);
  change.translation.y() = uniform.symmetric(preset.max_translation);
  change.scale = preset.min_scale + uniform.next() * (preset.max_scale - preset.min_scale);
  return change;
}

Eigen::Vector2d affine_forward(const AffineChange& change, cv::Size size, const Eigen::Vector2d& x) {
  const double angle = change.rotation_deg * std::numbers::pi / 180;
  const double cos_a = std::cos(angle) * change.scale, sin_a = std::sin(angle) * change.scale;
  const Eigen::Vector2d c((size.width - 1) / 2.0, (size.height - 1) / 2.0);
  const Eigen::Vector2d d = x - c;
  // The y-down counter-clockwise rotation [cos sin; -sin cos].
  return c + Eigen::Vector2d(cos_a * d.x() + sin_a * d.y(), -sin_a * d.x() + cos_a * d.y()) +
         Eigen::Vector2d(change.translation.x() * size.width, change.translation.y() * size.height);
}

void affine_maps(const AffineChange& change, cv::Size size, WarpMaps* maps) {
  check_affine(change);
  if (size.width < 1 || size.height < 1) throw Error("affine_maps: empty image size");
  maps->kind = MapKind::sampling;
  maps->source_size = size;
  maps->valid.release();
  maps->map_x.create(size, CV_32FC1);
  maps->map_y.create(size, CV_32FC1);
  // The inverse of x' = c + s R (x - c) + t: x = c + R^T (x' - c - t) / s.
  const double angle = change.rotation_deg * std::numbers::pi / 180;
  const double cos_a = std::cos(angle) / change.scale, sin_a = std::sin(angle) / change.scale;
  const double cx = (size.width - 1) / 2.0, cy = (size.height - 1) / 2.0;
  const double tx = change.translation.x() * size.width, ty = change.translation.y() * size.height;
  const double w = size.width - 0.5, h = size.height - 0.5;
  const float max_x = float(size.width - 1), max_y = float(size.height - 1);
  std::atomic<long> invalid{0};
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    long local = 0;
    for (int v = rows.start; v < rows.end; ++v) {
      float* out_x = maps->map_x.ptr<float>(v);
      float* out_y = maps->map_y.ptr<float>(v);
      const double dy = v - cy - ty;
      for (int u = 0; u < size.width; ++u) {
        const double dx = u - cx - tx;
        // R^T of the y-down counter-clockwise rotation [cos sin; -sin cos].
        const double x = cx + cos_a * dx - sin_a * dy, y = cy + sin_a * dx + cos_a * dy;
        const bool ok = x >= -0.5 && x < w && y >= -0.5 && y < h;
        local += !ok;
        out_x[u] = ok ? std::clamp(float(x), 0.0f, max_x) : kOutsideSource;
        out_y[u] = ok ? std::clamp(float(y), 0.0f, max_y) : kOutsideSource;
      }
    }
    invalid += local;
  });
  maps->invalid_count = invalid;
}

void affine_augment(const AffineChange& change, cv::Size size, const AugmentIO& io) {
  if (!io.image_planes.empty()) {
    return detail::augment_through_interleaved(
        io, [&](const AugmentIO& interleaved) { affine_augment(change, size, interleaved); });
  }
  WarpMaps maps;
  affine_maps(change, size, &maps);
  if (io.image) warp_image(*io.image, maps, io.out_image, io.fill);
  if (io.labels) warp_labels(*io.labels, maps, io.label_fill, io.out_labels);
  if (io.valid) maps.validity().copyTo(*io.valid);
}

}  // namespace fishcam
