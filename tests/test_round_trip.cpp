// project(unproject(pixel)) on every pixel of the image for every model, including
// rays more than 90 deg off-axis, and unproject(project(ray)) on random rays.
#include <opencv2/core.hpp>

#include "test_support.hpp"

namespace fishcam {
namespace {

std::vector<Eigen::Vector2d> every_pixel(const Camera& camera) {
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(size_t(camera.width()) * camera.height());
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) pixels.emplace_back(u, v);
  }
  return pixels;
}

std::vector<std::pair<std::string, CameraParameters>> cameras() {
  auto all = test::every_model();
  // A fold inside the image: only the pixels inside the image circle are valid.
  all.emplace_back("polynomial_fold", test::with_model(test::woodscape_front(), Polynomial<double>({300, 0, 0, -40})));
  return all;
}

TEST(RoundTrip, ProjectUnprojectEveryPixel) {
  for (const auto& [name, params] : cameras()) {
    const Camera camera(params);
    const auto pixels = every_pixel(camera);
    std::vector<Eigen::Vector3d> rays(pixels.size());
    std::vector<std::uint8_t> valid(pixels.size());
    camera.unproject(pixels, rays, valid);
    std::vector<Eigen::Vector2d> back(pixels.size());
    std::vector<std::uint8_t> back_valid(pixels.size());
    camera.project(rays, back, back_valid);
    double worst = 0, widest = 0;
    size_t count = 0;
    for (size_t i = 0; i < pixels.size(); ++i) {
      if (!valid[i]) continue;
      ASSERT_TRUE(back_valid[i]) << name << " pixel " << pixels[i].transpose();
      worst = std::max(worst, (back[i] - pixels[i]).norm());
      widest = std::max(widest, std::acos(std::clamp(rays[i].z(), -1.0, 1.0)));
      ++count;
    }
    EXPECT_LE(worst, 1e-9) << name;
    if (name != "polynomial_fold") {
      EXPECT_EQ(count, pixels.size()) << name << ": every pixel of this image is in the valid domain";
    }
    if (name.find("polynomial") == 0 && name != "polynomial_fold") {
      EXPECT_GT(widest, 110 * M_PI / 180) << name << ": the corners are > 90 deg off-axis";
    }
    std::printf("  %-22s %8zu pixels, widest %.2f deg, worst round trip %.2e px\n", name.c_str(), count,
                widest * 180 / M_PI, worst);
  }
}

TEST(RoundTrip, UnprojectProjectRandomRays) {
  for (const auto& [name, params] : cameras()) {
    const Camera camera(params);
    const ValidDomain& d = camera.domain();
    // Stay off the open limits (where rho diverges) and off a fold (where theta(rho)
    // is ill-conditioned: there the pixel round trip above is the meaningful test).
    const double theta_max = d.limited_by == ValidDomain::Limit::fold ? d.theta_max - 0.02
                             : d.closed                                ? d.theta_max
                                                                       : d.theta_max - 1e-3;
    double worst = 0;
    for (const Eigen::Vector3d& ray : test::random_rays(100000, theta_max, 99)) {
      Eigen::Vector2d pixel;
      Eigen::Vector3d back;
      ASSERT_TRUE(camera.project(ray, &pixel)) << name << " " << ray.transpose();
      ASSERT_TRUE(camera.unproject(pixel, &back)) << name;
      EXPECT_NEAR(back.norm(), 1.0, 1e-15);
      worst = std::max(worst, test::angle_between(ray, back));
    }
    EXPECT_LE(worst, 1e-12) << name;
  }
}

TEST(RoundTrip, BatchesEqualSinglePointsAndThreadCountDoesNotMatter) {
  const Camera camera(test::woodscape_front());
  const auto pixels = every_pixel(camera);
  std::vector<Eigen::Vector3d> rays(pixels.size());
  cv::setNumThreads(2);
  camera.unproject(pixels, rays);
  for (size_t i = 0; i < pixels.size(); i += 97) {
    Eigen::Vector3d single;
    ASSERT_TRUE(camera.unproject(pixels[i], &single));
    ASSERT_EQ(single, rays[i]);
  }
  std::vector<float> image(3 * pixels.size()), image_one_thread(3 * pixels.size());
  camera.unproject_image(image);
  cv::setNumThreads(1);
  camera.unproject_image(image_one_thread);
  cv::setNumThreads(-1);
  EXPECT_EQ(image, image_one_thread);
  // The table path agrees with the exact rays to float precision.
  for (size_t i = 0; i < pixels.size(); i += 13) {
    const Eigen::Vector3d from_table(image[3 * i], image[3 * i + 1], image[3 * i + 2]);
    ASSERT_LT(test::angle_between(from_table.normalized(), rays[i]), 1e-6);
  }
}

TEST(RoundTrip, BatchSizeMismatchIsAnError) {
  const Camera camera(test::woodscape_front());
  std::vector<Eigen::Vector2d> pixels(10);
  std::vector<Eigen::Vector3d> rays(9);
  EXPECT_THROW(camera.unproject(pixels, rays), Error);
  std::vector<float> image(5);
  EXPECT_THROW(camera.unproject_image(image), Error);
}

}  // namespace
}  // namespace fishcam
