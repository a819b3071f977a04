#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include "fishcam/error.hpp"
#include "fishcam/testing.hpp"

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
                                  std::uint64_t seed) {
  check_board(board);
  if (count < 1 || !(noise_px >= 0 && noise_px <= 100)) {
    throw Error("synthesize_boards: needs >= 1 board and a noise sigma in [0, 100] px");
  }
  Random random{std::mt19937_64(seed)};
  const auto points = board_points(board);
  const Eigen::Vector3d middle((board.cols - 1) * board.spacing / 2, (board.rows - 1) * board.spacing / 2, 0);
  const double extent = std::max(board.cols - 1, board.rows - 1) * board.spacing;
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
      BoardObservation o{std::string("synth-") + std::to_string(1000 + b).substr(1) + ".png", {}};
      bool inside = true;
      for (const auto& p : points) {
        Eigen::Vector2d q;
        inside = inside && camera.project(pose.rotation * p + pose.translation, &q) && q.x() > 2 && q.y() > 2 &&
                 q.x() < camera.width() - 3 && q.y() < camera.height() - 3;
        o.corners.push_back(q);
      }
      if (!inside) continue;
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
