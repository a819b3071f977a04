// Kannala-Brandt agrees with OpenCV's cv::fisheye (which goes through the pinhole
// plane and so only sees theta < 90 deg).
#include <opencv2/calib3d.hpp>

#include "test_support.hpp"

namespace fishcam {
namespace {

TEST(OpenCVFisheye, ProjectionAgreesWithProjectPoints) {
  const Camera camera = read_camera(test::data_path("kannala_brandt.yaml"));
  const auto& p = camera.parameters();
  const auto params = model_params(p.model);
  // Make fx != fy to exercise the a_y mapping.
  CameraParameters q = p;
  q.pixel_scale = {1.0, 1.0125};
  const Camera stretched(q);
  const double fx = params[0], fy = params[0] * 1.0125;
  const cv::Matx33d K(fx, 0, p.principal_point.x(), 0, fy, p.principal_point.y(), 0, 0, 1);
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
  const cv::Matx33d K(params[0], 0, p.principal_point.x(), 0, params[0], p.principal_point.y(), 0, 0, 1);
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

}  // namespace
}  // namespace fishcam
