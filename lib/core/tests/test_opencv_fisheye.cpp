// Kannala-Brandt agrees with OpenCV's cv::fisheye (which goes through the pinhole
// plane and so only sees theta < 90 deg); the `opencv` model with cv::projectPoints.
#include <opencv2/calib3d.hpp>

#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

TEST(OpenCVFisheye, ProjectionAgreesWithProjectPoints) {
  const Camera camera = read_camera(test::data_path("kannala_brandt.yaml"));
  const auto& p = camera.parameters();
  const auto params = model_params(p.model);
  // Make fx != fy to exercise the a_y mapping.
  CameraParameters q = p;
  q.grid.pixel_scale = {1.0, 1.0125};
  const Camera stretched(q);
  const double fx = params[0], fy = params[0] * 1.0125;
  const cv::Matx33d K(fx, 0, p.grid.principal_point.x(), 0, fy, p.grid.principal_point.y(), 0, 0, 1);
  const cv::Vec4d D(params[1], params[2], params[3], params[4]);
  const auto rays = test::random_rays(20000, 89.5 * M_PI / 180, 4);
  std::vector<cv::Vec3d> points;
  for (size_t i = 0; i < rays.size(); ++i) {
    const Eigen::Vector3d pt = (1.0 + i % 5) * rays[i];
    points.emplace_back(pt.x(), pt.y(), pt.z());
  }
  std::vector<cv::Vec2d> expected;
  cv::fisheye::projectPoints(points, expected, cv::Vec3d::zeros(), cv::Vec3d::zeros(), K, D);
  double worst = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(stretched.project({points[i][0], points[i][1], points[i][2]}, &pixel));
    worst = std::max(worst, std::hypot(pixel.x() - expected[i][0], pixel.y() - expected[i][1]));
  }
  // OpenCV goes through atan(r) with r = |(X/Z, Y/Z)|: a few ulps of theta, ~1e-10 px near 90 deg.
  EXPECT_LE(worst, 1e-8);
  std::printf("  worst |fishcam - cv::fisheye::projectPoints| = %.2e px over %zu points\n", worst, points.size());
}

TEST(OpenCVFisheye, UnprojectionAgreesWithUndistortPointsWhereOpenCVConverges) {
  const Camera camera = read_camera(test::data_path("kannala_brandt.yaml"));
  const auto& p = camera.parameters();
  const auto params = model_params(p.model);
  const cv::Matx33d K(params[0], 0, p.grid.principal_point.x(), 0, params[0], p.grid.principal_point.y(), 0, 0, 1);
  const cv::Vec4d D(params[1], params[2], params[3], params[4]);
  std::vector<cv::Vec2d> pixels, normalized;
  for (const auto& ray : test::random_rays(2000, 60 * M_PI / 180, 8)) {
    Eigen::Vector2d q;
    ASSERT_TRUE(camera.project(ray, &q));
    pixels.emplace_back(q.x(), q.y());
  }
  cv::fisheye::undistortPoints(pixels, normalized, K, D, cv::noArray(), cv::noArray(),
                               cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-14));
  for (size_t i = 0; i < pixels.size(); ++i) {
    Eigen::Vector3d ray;
    ASSERT_TRUE(camera.unproject({pixels[i][0], pixels[i][1]}, &ray));
    const Eigen::Vector3d theirs = Eigen::Vector3d(normalized[i][0], normalized[i][1], 1).normalized();
    EXPECT_LT(test::angle_between(ray, theirs), 1e-9) << i;
  }
}

// The `opencv` model is cv::projectPoints with zero tangential and prism terms: a
// real OPENCV8 calibration's k1..k6 (../shared's mrcal_cam0.opencv8.cameramodel) and
// a strongly distorted one whose denominator has a pole, over the valid domain.
TEST(OpenCVRational, ProjectionAgreesWithProjectPoints) {
  struct Case {
    const char* name;
    OpenCV<double> model;
  };
  const std::vector<Case> cases = {
      {"mrcal_cam0", OpenCV<double>(1761.181055, -0.01266096516, 0.03590794372, 0.01968883397, 0.01482863541,
                                    -0.0562239888, 0.0500223357)},
      {"pole", OpenCV<double>(400.0, 0.3, 0.05, 0.0, -0.6, 0.05, 0.0)},  // 1 - 0.6 s + 0.05 s^2 = 0 at s = 2
  };
  int checked = 0;
  for (const Case& c : cases) {
    CameraParameters p;
    p.width = 3840, p.height = 2160, p.grid.principal_point = {1965.7, 1087.5}, p.grid.pixel_scale = {1.0, 1.00004};
    p.model = c.model;
    const Camera camera(p);
    const auto q = c.model.params();
    const cv::Matx33d K(q[0], 0, p.grid.principal_point.x(), 0, q[0] * p.grid.pixel_scale.y(),
                        p.grid.principal_point.y(), 0, 0, 1);
    const std::vector<double> D = {q[1], q[2], 0, 0, q[3], q[4], q[5], q[6]};
    // Up to just inside the valid domain (a pole or a fold of rho ends it).
    const auto rays = test::random_rays(20000, std::min(camera.domain().theta_max, 89.0 * M_PI / 180) * 0.999, 5);
    std::vector<cv::Vec3d> points;
    for (size_t i = 0; i < rays.size(); ++i) {
      const Eigen::Vector3d pt = (1.0 + i % 5) * rays[i];
      points.emplace_back(pt.x(), pt.y(), pt.z());
    }
    std::vector<cv::Vec2d> expected;
    cv::projectPoints(points, cv::Vec3d::zeros(), cv::Vec3d::zeros(), K, D, expected);
    double worst = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.project({points[i][0], points[i][1], points[i][2]}, &pixel)) << c.name << " " << i;
      worst = std::max(worst, std::hypot(pixel.x() - expected[i][0], pixel.y() - expected[i][1]));
      Eigen::Vector3d ray;
      ASSERT_TRUE(camera.unproject(pixel, &ray)) << c.name << " " << i;
      EXPECT_LT(test::angle_between(ray, rays[i]), 1e-9) << c.name << " " << i;
    }
    // OpenCV divides by Z and multiplies by the focal length: relative rounding of
    // ~1e-15 of radii up to ~1e5 px near the pole.
    EXPECT_LE(worst, 1e-7) << c.name;
    std::printf("  %s: theta_max %.3f deg (%s), worst |fishcam - cv::projectPoints| = %.2e px\n", c.name,
                camera.domain().theta_max * 180 / M_PI, to_string(camera.domain().limited_by), worst);
    ++checked;
  }
  EXPECT_EQ(checked, 2);
}

}  // namespace
}  // namespace fishcam
