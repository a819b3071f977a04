// Built against an installed fishcam with the core layer only: a whole-image
// unprojection (the core's parallel loop, serial without fishcam_augment) and a
// round trip.
#include <cmath>
#include <cstdio>
#include <vector>

#include <fishcam/core/camera.hpp>

int main() {
  fishcam::CameraParameters p;
  p.width = 320, p.height = 240;
  p.grid.principal_point = {159.5, 119.5};
  p.model = fishcam::KannalaBrandt<double>(120, 0.01, -0.002, 0, 0);
  const fishcam::Camera camera(p);
  std::vector<float> rays(3 * 320 * 240);
  camera.unproject_image(rays);
  Eigen::Vector2d pixel;
  const Eigen::Vector3d ray(rays[3 * (10 * 320 + 20)], rays[3 * (10 * 320 + 20) + 1], rays[3 * (10 * 320 + 20) + 2]);
  if (!camera.project(ray, &pixel)) return 1;
  const double error = (pixel - Eigen::Vector2d(20.0, 10.0)).norm();
  std::printf("core consumer: round trip through a float ray %.3g px\n", error);
  return error < 1e-3 ? 0 : 1;
}
