// project(unproject(pixel)) on every pixel of the image for every model, including
// rays more than 90 deg off-axis, and unproject(project(ray)) on random rays.
#include <opencv2/core.hpp>

#include <cstring>
#include <vector>

#include "fishcam/testing/test_support.hpp"

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
  auto all = test::every_camera();
  // A fold inside the image: only the pixels inside the image circle are valid.
  all.emplace_back("polynomial_fold", test::with_model(test::woodscape_front(), Polynomial<double>({300, 0, 0, -40})));
  return all;
}

// How far off-axis random rays may go: off the open limits (where rho diverges) and
// off a fold (where theta(rho) is ill-conditioned: there the pixel round trip is the
// meaningful test).
double random_ray_limit(const ValidDomain& d) {
  return d.limited_by == ValidDomain::Limit::fold ? d.theta_max - 0.02 : d.closed ? d.theta_max : d.theta_max - 1e-3;
}

// Every model (and a polynomial whose fold lies inside the image), one test each.
class EveryModel : public ::testing::TestWithParam<test::ModelCase> {};

TEST_P(EveryModel, ProjectUnprojectEveryPixel) {
  const auto& [name, params] = GetParam();
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
  } else {  // the pixels inside the fold's circle, and only those
    const size_t inside = size_t(std::count_if(pixels.begin(), pixels.end(), [&](const Eigen::Vector2d& q) {
      return camera.rho_of_pixel(q) <= camera.domain().rho_max;
    }));
    EXPECT_NEAR(double(count), double(inside), 4.0) << "pixels unprojected vs inside the fold's circle";
    EXPECT_GT(count, pixels.size() / 10);
  }
  if (name.find("polynomial") == 0 && name != "polynomial_fold") {
    EXPECT_GT(widest, 110 * M_PI / 180) << name << ": the corners are > 90 deg off-axis";
  }
  std::printf("  %-22s %8zu pixels, widest %.2f deg, worst round trip %.2e px\n", name.c_str(), count,
              widest * 180 / M_PI, worst);
}

TEST_P(EveryModel, UnprojectProjectRandomRays) {
  const auto& [name, params] = GetParam();
  const Camera camera(params);
  const double theta_max = random_ray_limit(camera.domain());
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

// The camera of a flipped image (a mirrored pixel grid): every ray lands where the
// flipped image shows it, every such pixel unprojects to the same ray, the domain is
// the same, and flipping twice gives the camera back bit for bit.
TEST_P(EveryModel, MirroredCameraSeesTheFlippedImage) {
  const auto& [name, params] = GetParam();
  const Camera camera(params);
  const ValidDomain& d = camera.domain();
  const std::vector<Eigen::Vector3d> rays = test::random_rays(2000, random_ray_limit(d), 5);
  int flips = 0;
  for (const auto& [horizontal, vertical] : {std::pair{true, false}, {false, true}, {true, true}}) {
    SCOPED_TRACE(std::string(name) + (horizontal ? " horizontal" : "") + (vertical ? " vertical" : ""));
    const Camera flipped(mirrored(params, horizontal, vertical));
    EXPECT_TRUE(flipped.parameters().grid.is_mirrored());
    EXPECT_EQ(mirrored(flipped.parameters(), horizontal, vertical).grid, params.grid);
    EXPECT_EQ(flipped.domain().theta_max, d.theta_max);
    double worst_pixel = 0, worst_ray = 0;
    for (const Eigen::Vector3d& ray : rays) {
      Eigen::Vector2d pixel, seen;
      Eigen::Vector3d back;
      ASSERT_TRUE(camera.project(ray, &pixel));
      ASSERT_TRUE(flipped.project(ray, &seen));
      const Eigen::Vector2d expected(horizontal ? camera.width() - 1 - pixel.x() : pixel.x(),
                                     vertical ? camera.height() - 1 - pixel.y() : pixel.y());
      worst_pixel = std::max(worst_pixel, (seen - expected).norm());
      ASSERT_TRUE(flipped.unproject(seen, &back));
      worst_ray = std::max(worst_ray, test::angle_between(ray, back));
    }
    EXPECT_LE(worst_pixel, 1e-9);
    EXPECT_LE(worst_ray, name == "polynomial_fold" ? 1e-9 : 1e-11);
    ++flips;
  }
  EXPECT_EQ(flips, 3);
}

// The per-azimuth limit by its definition, written apart from the library's: sector
// j's angle holds within one sector's width of its centre, -180 + 15 (j + 0.5) deg;
// the largest of those that hold.
double independent_cap(const AzimuthSectors& limits, double azimuth) {
  const double step = 2 * M_PI / kAzimuthSectors;
  double cap = -1;
  for (int j = 0; j < kAzimuthSectors; ++j) {
    if (std::abs(std::remainder(azimuth - (-M_PI + (j + 0.5) * step), 2 * M_PI)) < step) {
      cap = std::max(cap, limits[size_t(j)]);
    }
  }
  return cap;
}

// A cap per azimuth sector (what --theta-limit data writes): project and unproject
// refuse exactly the directions past it, and agree with the unlimited camera elsewhere.
TEST_P(EveryModel, PerAzimuthLimitStopsProjectionAndUnprojection) {
  const auto& [name, params] = GetParam();
  const Camera camera(params);
  const double reach = random_ray_limit(camera.domain());
  CameraParameters p = params;
  AzimuthSectors& limits = p.theta_limit_by_azimuth.emplace();
  for (size_t k = 0; k < limits.size(); ++k) limits[k] = reach * (0.3 + 0.6 * double(k * 7 % 24) / 23);
  const Camera limited(p);
  int inside = 0, outside = 0;
  for (const Eigen::Vector3d& ray : test::random_rays(3000, reach, 11)) {
    const double theta = std::atan2(ray.head<2>().norm(), ray.z()),
                 cap = independent_cap(limits, std::atan2(ray.y(), ray.x()));
    if (std::abs(theta - cap) < 1e-9) continue;
    Eigen::Vector2d pixel, limited_pixel;
    Eigen::Vector3d back;
    ASSERT_TRUE(camera.project(ray, &pixel));
    const bool expected = theta < cap;
    ASSERT_EQ(limited.project(ray, &limited_pixel), expected) << name << " theta " << theta << " cap " << cap;
    if (!expected) {
      EXPECT_TRUE(limited_pixel.array().isNaN().all());
      EXPECT_FALSE(limited.unproject(pixel, &back)) << name;
      EXPECT_TRUE(back.array().isNaN().all());
      ++outside;
      continue;
    }
    EXPECT_EQ(limited_pixel, pixel);
    Eigen::Vector3d unlimited_back;
    if (!camera.unproject(pixel, &unlimited_back)) continue;  // a pixel past what doubles resolve (CAHVOR's rim)
    ASSERT_TRUE(limited.unproject(pixel, &back)) << name;
    EXPECT_EQ(back, unlimited_back);
    ++inside;
  }
  EXPECT_GE(inside, 500) << name;
  EXPECT_GE(outside, 500) << name;
}

INSTANTIATE_TEST_SUITE_P(RoundTrip, EveryModel, ::testing::ValuesIn(cameras()), test::model_case_name);

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
  // The planar form holds the same floats, and leaves what lies past W*H alone.
  const size_t n = pixels.size();
  std::vector<float> x(n + 5, 7.0f), y(n + 5, 7.0f), z(n + 5, 7.0f);
  camera.unproject_image(x, y, z);
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(std::memcmp(&x[i], &image[3 * i], sizeof(float)), 0) << i;
    ASSERT_EQ(std::memcmp(&y[i], &image[3 * i + 1], sizeof(float)), 0) << i;
    ASSERT_EQ(std::memcmp(&z[i], &image[3 * i + 2], sizeof(float)), 0) << i;
  }
  EXPECT_EQ(x[n + 4], 7.0f);
  EXPECT_EQ(z[n], 7.0f);
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
  const size_t n = size_t(camera.width()) * size_t(camera.height());
  std::vector<float> plane(n), short_plane(n - 1);
  EXPECT_THROW(camera.unproject_image(plane, plane, short_plane), Error);
}

}  // namespace
}  // namespace fishcam

namespace fishcam {
namespace {

// A point projected exactly at theta_max (closed domains) unprojects, whatever
// rounding does to its radius; also under a user limit on theta.
TEST_P(EveryModel, PointsAtThetaMaxUnproject) {
  for (const double limit : {0.0, 1.3}) {
    CameraParameters p = GetParam().second;
    if (limit > 0) p.theta_limit = limit;
    const Camera camera(p);
    if (!camera.domain().closed) continue;
    const double t = camera.domain().theta_max;
    int projected = 0;
    for (int k = 0; k < 360; ++k) {
      const double phi = k * M_PI / 180 + 0.001;
      const Eigen::Vector3d ray(std::sin(t) * std::cos(phi), std::sin(t) * std::sin(phi), std::cos(t));
      Eigen::Vector2d pixel;
      if (!camera.project(ray, &pixel)) continue;  // rounding put the ray itself past theta_max
      ++projected;
      // CAHVOR's rim is where its tilted pinhole runs off to infinity: rim pixels 1e7 px and
      // more out, where libmrcal's projection is good to 1e-12 relative only (its p'_z
      // cancels), which the 1e-7 px reprojection check does not accept. No image is there.
      if ((pixel - camera.principal_point()).norm() > 1e6) continue;
      Eigen::Vector3d back;
      EXPECT_TRUE(camera.unproject(pixel, &back)) << "limit " << limit << " phi " << phi;
    }
    EXPECT_GE(projected, 288) << "limit " << limit << ": at least 80 % of the rays at theta_max project";
  }
}

// Only the direction of a point matters: scaled by 1e-300 ... 1e300 it projects
// to the same pixel (bit for bit: the scaling inside is by powers of two), with
// the Jacobian scaled by 1/s.
TEST_P(EveryModel, ProjectionIsScaleInvariantOverTheWholeDoubleRange) {
  const Camera camera(GetParam().second);
  int checked = 0;
  for (const Eigen::Vector3d& ray : test::random_rays(50, std::min(camera.domain().theta_max, 1.5), 3)) {
    Eigen::Vector2d reference;
    Eigen::Matrix<double, 2, 3> reference_jacobian;
    ASSERT_TRUE(camera.project(ray, &reference, &reference_jacobian));
    for (double scale : {1e-300, 1e-170, 1e-160, 1e-20, 1e20, 1e160, 1e170, 1e300}) {
      Eigen::Vector2d pixel;
      Eigen::Matrix<double, 2, 3> jacobian;
      ASSERT_TRUE(camera.project(ray * scale, &pixel, &jacobian)) << scale;
      EXPECT_LE((pixel - reference).norm(), 1e-9) << scale;
      EXPECT_LE((jacobian * scale - reference_jacobian).norm(), 1e-9 * reference_jacobian.norm()) << scale;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 400);
}

}  // namespace
}  // namespace fishcam
