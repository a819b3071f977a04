// Built against an installed fishcam: one round trip through the public API.
#include <cmath>
#include <cstdio>
#include <fishcam/core/camera.hpp>

int main() {
  fishcam::CameraParameters p;
  p.width = 1280, p.height = 966;
  p.grid.principal_point = {643.442, 479.407};
  p.model = fishcam::Polynomial<double>({339.749, -31.988, 48.275, -7.201});
  const fishcam::Camera camera(p);
  Eigen::Vector3d ray;
  Eigen::Vector2d pixel;
  if (!camera.unproject({10.0, 20.0}, &ray) || !camera.project(ray, &pixel)) return 1;
  const double error = (pixel - Eigen::Vector2d(10.0, 20.0)).norm();
  std::printf("consumer: theta_max %.3f rad, round trip error %.3g px\n", camera.domain().theta_max, error);
  return error < 1e-9 ? 0 : 1;
}
