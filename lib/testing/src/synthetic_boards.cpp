#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include "fishcam/core/error.hpp"
#include "fishcam/testing/testing.hpp"

namespace fishcam::testing {
namespace {

// Uniform [0, 1) and Gaussian draws from std::mt19937_64 by our own mapping, so a
// seed gives the same numbers with every standard library.
struct Random {
  std::mt19937_64 engine;
  double uniform() { return double(engine() >> 11) * 0x1.0p-53; }
  double normal() {  // Box-Muller
    const double u1 = 1 - uniform(), u2 = uniform();
    return std::sqrt(-2 * std::log(u1)) * std::cos(2 * std::numbers::pi * u2);
  }
};

}  // namespace

SyntheticBoards synthesize_boards(const Camera& camera, const BoardSpec& board, int count, double noise_px,
                                  std::uint64_t seed, bool partial) {
  check_board(board);
  if (count < 1 || !(noise_px >= 0 && noise_px <= 100)) {
    throw Error("synthesize_boards: needs >= 1 board and a noise sigma in [0, 100] px");
  }
  Random random{std::mt19937_64(seed)};
  const auto points = board_points(board);
  const Eigen::Vector3d middle(board.width() / 2, board.height() / 2, 0);
  const double extent = std::max(board.width(), board.height());
  SyntheticBoards out;
  for (int b = 0; b < count; ++b) {
    bool placed = false;
    for (int attempt = 0; attempt < 2000 && !placed; ++attempt) {
      // Aim at a random pixel (the whole image, rim included), at 1.2-3 board sizes.
      const Eigen::Vector2d target(random.uniform() * (camera.width() - 1), random.uniform() * (camera.height() - 1));
      Eigen::Vector3d m;
      if (!camera.unproject(target, &m)) continue;
      const double distance = extent * (1.2 + 1.8 * random.uniform());
      // Facing the camera, tilted up to 40 deg, turned in plane at random.
      const Eigen::Vector3d axis = Eigen::Vector3d(random.normal(), random.normal(), random.normal()).normalized();
      const Eigen::Matrix3d tilt = Eigen::AngleAxisd(0.7 * random.uniform(), axis).toRotationMatrix();
      const Eigen::Vector3d z = tilt * m;  // board normal pointing away from the camera
      Eigen::Vector3d x = z.unitOrthogonal();
      x = Eigen::AngleAxisd(2 * std::numbers::pi * random.uniform(), z) * x;
      Eigen::Matrix3d r;
      r << x, z.cross(x), z;
      const BoardPose pose{Eigen::Quaterniond(r), distance * m - r * middle};
      BoardObservation o{std::string("synth-") + std::to_string(1000 + b).substr(1) + ".png", {}, {}};
      bool inside = true;
      for (size_t id = 0; id < points.size(); ++id) {
        Eigen::Vector2d q;
        const bool seen = camera.project(pose.rotation * points[id] + pose.translation, &q) && q.x() > 2 && q.y() > 2 &&
                          q.x() < camera.width() - 3 && q.y() < camera.height() - 3;
        inside = inside && seen;
        if (seen || !partial) o.corners.push_back(q), o.ids.push_back(int(id));
      }
      if (partial && !inside) {
        // At least 40 % of the board, over 2 rows and 2 columns of it.
        std::vector<bool> column(size_t(board.cols)), row(size_t(board.rows));
        for (int id : o.ids) column[size_t(id % board.cols)] = true, row[size_t(id / board.cols)] = true;
        inside = 10 * o.ids.size() >= 4 * points.size() && std::count(column.begin(), column.end(), true) >= 2 &&
                 std::count(row.begin(), row.end(), true) >= 2;
      }
      if (!inside) continue;
      if (int(o.ids.size()) == board.corners()) o.ids.clear();
      for (auto& q : o.corners) q += noise_px * Eigen::Vector2d(random.normal(), random.normal());
      out.observations.push_back(std::move(o));
      out.poses.push_back(pose);
      placed = true;
    }
    if (!placed) throw Error("synthesize_boards: could not place board " + std::to_string(b) + " inside the image");
  }
  return out;
}

}  // namespace fishcam::testing

namespace fishcam::testing {

std::vector<std::uint8_t> render_board_image(const Camera& camera, const BoardSpec& board, const BoardPose& pose,
                                             int supersample, double blur_px, double noise_dn, std::uint64_t seed) {
  check_board(board);
  if (board.gap > 0) throw Error("render_board_image draws chessboards; a grid of tags: render_target_image");
  const double s = board.spacing;
  const auto chessboard = [&](double x_m, double y_m) {
    const double x = x_m / s, y = y_m / s;  // inner corners at integers 0..cols-1, 0..rows-1
    if (x >= -1 && y >= -1 && x < board.cols && y < board.rows) {
      return (int(std::floor(x)) + int(std::floor(y))) % 2 == 0 ? 20.0 : 235.0;
    }
    if (x >= -2 && y >= -2 && x < board.cols + 1 && y < board.rows + 1) return 235.0;  // the white margin
    return std::numeric_limits<double>::quiet_NaN();
  };
  return render_target_image(camera, chessboard, pose, supersample, blur_px, noise_dn, seed);
}

std::vector<std::uint8_t> render_target_image(const Camera& camera, const TargetPattern& pattern, const BoardPose& pose,
                                              int supersample, double blur_px, double noise_dn, std::uint64_t seed) {
  if (supersample < 1 || supersample > 8 || !(blur_px >= 0) || !(noise_dn >= 0)) {
    throw Error("render_target_image: supersample in [1, 8], blur and noise >= 0");
  }
  const int w = camera.width(), h = camera.height(), n = supersample;
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(size_t(w) * size_t(h) * size_t(n * n));
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) pixels.emplace_back(u - 0.5 + (i + 0.5) / n, v - 0.5 + (j + 0.5) / n);
      }
    }
  }
  std::vector<Eigen::Vector3d> rays(pixels.size());
  std::vector<std::uint8_t> valid(pixels.size());
  camera.unproject(pixels, rays, valid);
  const Eigen::Matrix3d r = pose.rotation.toRotationMatrix();
  const Eigen::Vector3d normal = r.col(2);
  const double offset = normal.dot(pose.translation);
  std::vector<double> grey(size_t(w) * size_t(h), 0.0);
  for (size_t k = 0; k < rays.size(); ++k) {
    double value = 128;  // background
    const double along = valid[k] ? normal.dot(rays[k]) : 0;
    const double distance = along != 0 ? offset / along : -1;
    if (distance > 0) {
      const Eigen::Vector3d p = r.transpose() * (distance * rays[k] - pose.translation);
      const double look = pattern(p.x(), p.y());
      if (!std::isnan(look)) value = look;
    }
    grey[k / size_t(n * n)] += value / (n * n);
  }
  // Separable Gaussian blur (clamped borders), then noise.
  if (blur_px > 0) {
    const int radius = int(std::ceil(3 * blur_px));
    std::vector<double> kernel(size_t(2 * radius + 1));
    double sum = 0;
    for (int i = -radius; i <= radius; ++i)
      sum += kernel[size_t(i + radius)] = std::exp(-0.5 * i * i / (blur_px * blur_px));
    for (double& k : kernel) k /= sum;
    std::vector<double> tmp(grey.size());
    for (int pass = 0; pass < 2; ++pass) {
      for (int v = 0; v < h; ++v) {
        for (int u = 0; u < w; ++u) {
          double acc = 0;
          for (int i = -radius; i <= radius; ++i) {
            const int uu = pass == 0 ? std::clamp(u + i, 0, w - 1) : u,
                      vv = pass == 1 ? std::clamp(v + i, 0, h - 1) : v;
            acc += kernel[size_t(i + radius)] * grey[size_t(vv) * size_t(w) + size_t(uu)];
          }
          tmp[size_t(v) * size_t(w) + size_t(u)] = acc;
        }
      }
      grey.swap(tmp);
    }
  }
  Random random{std::mt19937_64(seed)};
  std::vector<std::uint8_t> out(grey.size());
  for (size_t k = 0; k < grey.size(); ++k) {
    out[k] = std::uint8_t(std::clamp(std::lround(grey[k] + noise_dn * random.normal()), 0L, 255L));
  }
  return out;
}

}  // namespace fishcam::testing
