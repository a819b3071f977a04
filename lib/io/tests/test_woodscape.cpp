// The bundled WoodScape front camera against values worked out by hand from the
// WoodScape formula, and its extrinsics against the vehicle frame.
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

struct Worked {
  Eigen::Vector3d point;
  double theta, rho, u, v;
};

// Working (k = 339.749, -31.988, 48.275, -7.201; cx = 1280/2 + 3.942 - 0.5 = 643.442,
// cy = 966/2 - 3.093 - 0.5 = 479.407; aspect 1):
//  P = (1, 0.5, 2):   chi = sqrt(1.25) = 1.1180339887, theta = atan2(chi, 2) = 0.5097396788 rad (29.2 deg)
//                     rho = 339.749 t - 31.988 t^2 + 48.275 t^3 - 7.201 t^4 = 173.1832 - 8.3116 + 6.3939 - 0.4858
//                         = 170.7797166 px; u = cx + rho * 1 / chi = 796.1920222, v = cy + rho * 0.5 / chi =
//                         555.7820111
//  P = (1, -1, -0.5): behind the camera: chi = sqrt(2), theta = atan2(1.41421, -0.5) = 1.9106332362 rad (109.5 deg)
//                     rho = 649.1417 - 116.7717 + 336.7167 - 95.9780 = 773.1089370 px
//                     u = cx + rho / sqrt(2) = 1190.1125720, v = cy - rho / sqrt(2) = -67.2635720 (above the image)
//  P = (0, 0.3, 1):   theta = atan(0.3) = 0.2914567945, rho = 97.4481171, u = cx, v = cy + rho = 576.8551171
// (digits from an independent evaluation of the same formula in Python.)
const Worked kWorked[] = {
    {{1, 0.5, 2}, 0.50973967883150695, 170.77971663861902, 796.19202223284162, 555.78201111642079},
    {{1, -1, -0.5}, 1.9106332362490186, 773.10893702286171, 1190.1125719647889, -67.263571964789037},
    {{0, 0.3, 1}, 0.2914567944778671, 97.448117070006489, 643.442, 576.85511707000649},
};

TEST(WoodScape, BundledFrontCameraMatchesTheWorkedValues) {
  const Camera camera = read_camera(test::data_path("woodscape_front.json"));
  EXPECT_NEAR(camera.principal_point().x(), 643.442, 1e-12);
  EXPECT_NEAR(camera.principal_point().y(), 479.407, 1e-12);
  for (const Worked& w : kWorked) {
    EXPECT_NEAR(camera.rho(w.theta), w.rho, 1e-10);
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera.project(w.point, &pixel));
    EXPECT_NEAR(pixel.x(), w.u, 1e-9) << w.point.transpose();
    EXPECT_NEAR(pixel.y(), w.v, 1e-9) << w.point.transpose();
    // And back: the pixel's ray is the point's direction, and its theta the worked one.
    Eigen::Vector3d ray;
    ASSERT_TRUE(camera.unproject({w.u, w.v}, &ray));
    EXPECT_LT(test::angle_between(ray, w.point.normalized()), 1e-12);
    EXPECT_NEAR(camera.theta_from_rho(w.rho), w.theta, 1e-12);
  }
}

TEST(WoodScape, FieldOfViewIsAbout190DegreesHorizontally) {
  const Camera camera = read_camera(test::data_path("woodscape_front.json"));
  const auto fov = camera.field_of_view_deg();
  EXPECT_NEAR(fov.horizontal, 190, 1.0);
  EXPECT_GT(fov.diagonal, fov.horizontal);
  EXPECT_GT(fov.horizontal, fov.vertical);
}

TEST(WoodScape, ExtrinsicsAreCameraToVehicle) {
  // Camera frame x right, y down, z forward; vehicle ISO 8855 x forward, y left, z up.
  // The front camera looks forward and somewhat down; its x axis points to the
  // vehicle's right (-y); it sits 3.75 m ahead of the rear axle, 0.66 m up.
  const Camera camera = read_camera(test::data_path("woodscape_front.json"));
  ASSERT_TRUE(camera.parameters().pose.has_value());
  const Pose& pose = *camera.parameters().pose;
  const Eigen::Vector3d optical_axis = pose.rotation * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d right = pose.rotation * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d down = pose.rotation * Eigen::Vector3d::UnitY();
  EXPECT_GT(optical_axis.x(), 0.9);
  EXPECT_LT(optical_axis.z(), -0.3);  // pitched down ~23 deg
  EXPECT_LT(right.y(), -0.99);
  EXPECT_LT(down.z(), -0.9);
  EXPECT_EQ(pose.translation, Eigen::Vector3d(3.7484, 0, 0.66017));
}

TEST(WoodScape, SharedCalibrationMatchesTheBundledOne) {
  const std::filesystem::path shared = test::shared_path("data/woodscape/front.json");
  if (!std::filesystem::exists(shared)) GTEST_SKIP() << "no ../shared checkout";
  const Camera a = read_camera(shared), b = read_camera(test::data_path("woodscape_front.json"));
  EXPECT_EQ(model_params(a.model()), model_params(b.model()));
  EXPECT_EQ(a.principal_point(), b.principal_point());
  EXPECT_LT((a.parameters().pose->translation - b.parameters().pose->translation).norm(), 1e-12);
}

}  // namespace
}  // namespace fishcam
