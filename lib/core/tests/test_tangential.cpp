// Cameras with tangential (and thin-prism) terms, fishcam/core/tangential.hpp: projection
// against OpenCV's own code (cv::projectPoints for pinhole/opencv, cv::omnidir for
// mei), Jacobians against finite differences, unprojection that reprojects onto its
// pixel or says NaN, the valid domain where the distortion stops being one-to-one,
// and the refusals.
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>

#include "fishcam/fit/fit.hpp"
#include "fishcam/testing/reference_models.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

// OpenCV's projection of points through the camera (fx = f a_x, fy = f a_y).
std::vector<Eigen::Vector2d> opencv_projection(const CameraParameters& p, const std::vector<Eigen::Vector3d>& points) {
  const std::vector<double> q = model_params(p.model);
  const cv::Matx33d K(q[0] * p.grid.pixel_scale.x(), 0, p.grid.principal_point.x(), 0, q[0] * p.grid.pixel_scale.y(),
                      p.grid.principal_point.y(), 0, 0, 1);
  std::vector<cv::Point3d> in;
  for (const auto& x : points) in.emplace_back(x.x(), x.y(), x.z());
  std::vector<cv::Point2d> out;
  const TangentialTerms t = p.tangential_terms();
  const std::string_view name = model_name(p.model);
  if (name == "mei") {
    cv::omnidir::projectPoints(in, out, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, q[1],
                               cv::Vec4d(q[2], q[3], t.p1, t.p2));
  } else {
    std::vector<double> d = {0, 0, t.p1, t.p2, 0, 0, 0, 0, t.s[0], t.s[1], t.s[2], t.s[3]};
    if (name == "opencv") d[0] = q[1], d[1] = q[2], d[4] = q[3], d[5] = q[4], d[6] = q[5], d[7] = q[6];
    cv::projectPoints(in, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, d, out);
  }
  std::vector<Eigen::Vector2d> pixels;
  for (const auto& x : out) pixels.emplace_back(x.x, x.y);
  return pixels;
}

class EveryTangentialCamera : public ::testing::TestWithParam<test::ModelCase> {};

TEST_P(EveryTangentialCamera, ProjectionIsOpenCVsAndTheJacobianItsDerivative) {
  const auto& [name, params] = GetParam();
  const Camera camera(params);
  ASSERT_FALSE(camera.radial());
  const ValidDomain& d = camera.domain();
  // Up to just inside the domain, and below 89 deg for the pinhole models (OpenCV divides by z).
  const double limit =
      std::min(d.closed ? d.theta_max : d.theta_max - 1e-3, name.find("mei") == 0 ? M_PI : 89 * M_PI / 180);
  std::vector<Eigen::Vector3d> points;
  for (const auto& ray : test::random_rays(5000, limit, 7)) points.push_back((0.5 + double(points.size() % 9)) * ray);
  const std::vector<Eigen::Vector2d> expected = opencv_projection(params, points);
  double worst = 0, worst_jacobian = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d pixel;
    Eigen::Matrix<double, 2, 3> jacobian;
    ASSERT_TRUE(camera.project(points[i], &pixel, &jacobian)) << name << " " << points[i].transpose();
    const double scale = 1 + 1e-3 * (expected[i] - camera.principal_point()).norm();  // relative far out
    worst = std::max(worst, (pixel - expected[i]).norm() / scale);
    if (i % 10) continue;
    Eigen::Matrix<double, 2, 3> numeric;
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6 * points[i].norm();
      Eigen::Vector2d plus, minus;
      ASSERT_TRUE(camera.project(points[i] + h * Eigen::Vector3d::Unit(k), &plus));
      ASSERT_TRUE(camera.project(points[i] - h * Eigen::Vector3d::Unit(k), &minus));
      numeric.col(k) = (plus - minus) / (2 * h);
    }
    worst_jacobian =
        std::max(worst_jacobian, (numeric - jacobian).cwiseAbs().maxCoeff() / (1 + jacobian.cwiseAbs().maxCoeff()));
  }
  EXPECT_LE(worst, 1e-9) << name;
  EXPECT_LE(worst_jacobian, 1e-6) << name;
  std::printf("  %-28s up to %.1f deg: worst %.2e px against OpenCV, Jacobian %.2e (relative)\n", name.c_str(),
              limit * 180 / M_PI, worst, worst_jacobian);
}

// Unprojection reprojects onto its pixel (<= 1e-6 px) or gives NaN, over the image and
// far around it, and every ray of the domain comes back.
TEST_P(EveryTangentialCamera, UnprojectionReprojectsOntoItsPixelOrIsNaN) {
  const auto& [name, params] = GetParam();
  const Camera camera(params);
  long valid = 0, invalid = 0;
  double worst = 0;
  for (int v = -2 * camera.height(); v < 3 * camera.height(); v += 7) {
    for (int u = -2 * camera.width(); u < 3 * camera.width(); u += 7) {
      const Eigen::Vector2d pixel(u, v);
      Eigen::Vector3d ray;
      if (!camera.unproject(pixel, &ray)) {
        EXPECT_TRUE(ray.array().isNaN().all());
        ++invalid;
        continue;
      }
      ++valid;
      Eigen::Vector2d back;
      ASSERT_TRUE(camera.project(ray, &back)) << name << " " << pixel.transpose();
      worst = std::max(worst, (back - pixel).norm());
    }
  }
  EXPECT_LE(worst, 1e-6) << name;
  EXPECT_GT(valid, 0);
  const ValidDomain& d = camera.domain();
  int rays = 0;
  for (const auto& ray : test::random_rays(20000, d.closed ? d.theta_max : d.theta_max - 1e-3, 11)) {
    Eigen::Vector2d pixel;
    Eigen::Vector3d back;
    ASSERT_TRUE(camera.project(ray, &pixel));
    if (!pixel.allFinite() || (pixel - camera.principal_point()).norm() > 1e7) continue;  // past double's 1e-9 rad
    ASSERT_TRUE(camera.unproject(pixel, &back)) << name << " theta " << std::acos(ray.z()) * 180 / M_PI;
    EXPECT_LT(test::angle_between(ray, back), 1e-9) << name;
    ++rays;
  }
  EXPECT_GT(rays, 15000);
  std::printf("  %-28s %ld pixels with a ray, %ld without; worst reprojection %.2e px; %d rays back\n", name.c_str(),
              valid, invalid, worst, rays);
}

INSTANTIATE_TEST_SUITE_P(Tangential, EveryTangentialCamera, ::testing::ValuesIn(test::every_tangential_camera()),
                         test::model_case_name);

TEST(Tangential, EveryModelThatTakesTangentialTermsHasATangentialCase) {
  int planes = 0;
  ModelRegistry::for_each([&]<template <typename> class Model>() { planes += TakesTangentialTerms<Model<double>>; });
  EXPECT_EQ(planes, 3);  // pinhole, opencv, mei
  EXPECT_EQ(test::every_tangential_camera().size(), size_t(planes));
}

// Strong terms fold the distortion map inside the model's own domain: the camera's
// domain ends there (limited by the tangential fold), rays past it do not project and
// the pixels past it have no ray.
TEST(Tangential, TheDomainEndsWhereTheDistortionStopsBeingOneToOne) {
  CameraParameters p = test::woodscape_front();
  p.model = Pinhole<double>(400.0);
  p.distortion = TangentialDistortion{{0.05, -0.03, {}}};
  const Camera camera(p);
  const ValidDomain& d = camera.domain();
  EXPECT_EQ(d.limited_by, ValidDomain::Limit::distortion_fold);
  EXPECT_TRUE(d.closed);
  EXPECT_LT(d.theta_max, 80 * M_PI / 180);
  EXPECT_GT(d.theta_max, 10 * M_PI / 180);
  // Past theta_max: no pixel. Below it: every direction round trips.
  int checked = 0;
  for (int k = 0; k < 360; k += 5) {
    const double phi = k * M_PI / 180;
    const auto ray_at = [&](double theta) {
      return Eigen::Vector3d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    };
    Eigen::Vector2d pixel;
    EXPECT_FALSE(camera.project(ray_at(d.theta_max * 1.001), &pixel));
    ASSERT_TRUE(camera.project(ray_at(d.theta_max * 0.999), &pixel));
    Eigen::Vector3d back;
    ASSERT_TRUE(camera.unproject(pixel, &back)) << k;
    EXPECT_LT(test::angle_between(back, ray_at(d.theta_max * 0.999)), 1e-9);
    ++checked;
  }
  EXPECT_EQ(checked, 72);
  // One-to-one up to there: the plane map's determinant (finite differences of the
  // pixel over the undistorted plane) stays positive on the domain's rim ...
  const auto pixel_of_plane = [&](double x, double y) {
    Eigen::Vector2d q;
    camera.project(Eigen::Vector3d(x, y, 1), &q);
    return q;
  };
  const double u_max = std::tan(d.theta_max);
  double smallest = std::numeric_limits<double>::infinity(), smallest_past = smallest;
  for (int k = 0; k < 3600; ++k) {
    const double phi = 2 * M_PI * k / 3600, h = 1e-7;
    for (const double scale : {0.999, 1.02}) {
      const double x = scale * u_max * std::cos(phi), y = scale * u_max * std::sin(phi);
      if (scale > 1) {  // past the domain: the bare formula (a radial-free pinhole: pixel = c + f a (m + T(m)))
        Eigen::Matrix2d jt;
        p.tangential_terms().offset({x, y}, &jt);
        smallest_past = std::min(smallest_past, (Eigen::Matrix2d::Identity() + jt).determinant());
        continue;
      }
      Eigen::Matrix2d j;
      j.col(0) = (pixel_of_plane(x + h, y) - pixel_of_plane(x - h, y)) / (2 * h);
      j.col(1) = (pixel_of_plane(x, y + h) - pixel_of_plane(x, y - h)) / (2 * h);
      smallest = std::min(smallest, j.determinant());
    }
  }
  EXPECT_GT(smallest, 0);
  // ... and turns negative just past it (the fold itself, not a margin of safety).
  EXPECT_LT(smallest_past, 0);
}

// A skewed pixel grid on every kind of camera (every registry example, every
// tangential camera, the spline): pixel = c + a (.) (S q) with q the same camera's
// projection without c, a and skew; its Jacobian by finite differences; unprojection
// undoing it to 1e-9 px.
TEST(Tangential, SkewedGridsProjectThroughTheSkewAndUnprojectBack) {
  const PixelSkew skew{0.013102, -0.0143};
  int cameras = 0;
  for (auto [name, params] : test::every_camera()) {
    CameraParameters unit = params;
    unit.grid.principal_point.setZero(), unit.grid.pixel_scale.setOnes(), unit.grid.skew = {};
    params.grid.skew = skew;
    const Camera camera(params), plain(unit);
    ASSERT_FALSE(camera.radial()) << name;
    const ValidDomain& d = camera.domain();
    const double limit = std::min(d.closed ? d.theta_max : d.theta_max - 1e-3, 100 * M_PI / 180);
    const Eigen::Matrix2d as = params.grid.pixel_scale.asDiagonal() * skew.matrix();
    double worst = 0, worst_jacobian = 0, worst_back = 0;
    int n = 0;
    for (const auto& ray : test::random_rays(2000, limit, 11)) {
      const Eigen::Vector3d p = (0.5 + double(n++ % 7)) * ray;
      Eigen::Vector2d pixel, q;
      Eigen::Matrix<double, 2, 3> jacobian;
      ASSERT_TRUE(camera.project(p, &pixel, &jacobian)) << name;
      ASSERT_TRUE(plain.project(p, &q)) << name;
      const double scale = 1 + 1e-3 * q.norm();
      worst = std::max(worst, (pixel - (params.grid.principal_point + as * q)).norm() / scale);
      Eigen::Vector3d back;
      ASSERT_TRUE(camera.unproject(pixel, &back)) << name;
      Eigen::Vector2d again;
      ASSERT_TRUE(camera.project(back, &again));
      worst_back = std::max(worst_back, (again - pixel).norm() / scale);
      if (n % 10) continue;
      Eigen::Matrix<double, 2, 3> numeric;
      for (int k = 0; k < 3; ++k) {
        const double h = 1e-6 * p.norm();
        Eigen::Vector2d plus, minus;
        ASSERT_TRUE(camera.project(p + h * Eigen::Vector3d::Unit(k), &plus));
        ASSERT_TRUE(camera.project(p - h * Eigen::Vector3d::Unit(k), &minus));
        numeric.col(k) = (plus - minus) / (2 * h);
      }
      worst_jacobian =
          std::max(worst_jacobian, (numeric - jacobian).cwiseAbs().maxCoeff() / (1 + jacobian.cwiseAbs().maxCoeff()));
    }
    EXPECT_LE(worst, 1e-12) << name;
    EXPECT_LE(worst_back, 1e-9) << name;
    EXPECT_LE(worst_jacobian, 1e-6) << name;
    ++cameras;
  }
  EXPECT_EQ(cameras, int(test::every_camera().size()));
  EXPECT_GE(cameras, 24);  // 16 models + 3 tangential + 4 mrcal lenses + the skewed ocam
}

TEST(Tangential, SkewsThatCannotBeAGridAreRefused) {
  CameraParameters p = test::every_model()[0].second;
  for (const PixelSkew& bad : {PixelSkew{1, 1}, PixelSkew{2, 0.5}, PixelSkew{NAN, 0}, PixelSkew{0, INFINITY}}) {
    p.grid.skew = bad;
    try {
      Camera camera(p);
      ADD_FAILURE() << "accepted " << bad.xy << " " << bad.yx;
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("skew: ", 0), 0u) << e.what();
    }
  }
  p.grid.skew = {0.5, 0.5};  // det 0.75: a valid (if odd) grid
  EXPECT_NO_THROW(Camera{p});
  // Formats without a skew say so and name the ones with.
  p.grid.skew = {0.01, 0};
  try {
    format_camera(p, CameraFormat::woodscape);
    ADD_FAILURE() << "woodscape wrote a skew";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "skew: the woodscape format cannot hold a skewed pixel grid (fishcam, boofcv, ocamcalib can)");
  }
}

TEST(Tangential, CamerasRefuseTermsTheyCannotHold) {
  const auto refused = [](CameraParameters p, const std::string& expected) {
    try {
      Camera camera(p);
      ADD_FAILURE() << "accepted: " << expected;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  CameraParameters p = test::woodscape_front();
  p.distortion = TangentialDistortion{{0.001, 0, {}}};
  refused(p,
          "tangential: only the pinhole, mei or opencv model's undistorted plane takes tangential terms (the model "
          "is polynomial)");
  p.model = Mei<double>(640.0, 0.9, 0, 0);
  p.distortion = TangentialDistortion{{0.001, std::numeric_limits<double>::quiet_NaN(), {}}};
  refused(p, "tangential.p2: must be finite");
  p.distortion = TangentialDistortion{{0, 0, {0, 0, std::numeric_limits<double>::infinity(), 0}}};
  refused(p, "tangential.s3: must be finite");
  // An mrcal lens: on its base model only, its name, configuration and value count
  // checked. (A camera holds one plane distortion: CameraParameters::distortion.)
  CameraParameters s = test::spline_camera().second;
  s.model = Equidistant<double>(330.0);
  refused(s,
          "mrcal_lens: only the stereographic model's undistorted plane takes mrcal's "
          "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=150 (the model is equidistant)");
  s.distortion =
      MrcalLensDistortion{std::make_shared<const MrcalLens>("LENSMODEL_CAHVOR", std::vector<double>(5, 0.0))};
  s.model = Stereographic<double>(330.0);
  refused(s,
          "mrcal_lens: only the pinhole model's undistorted plane takes mrcal's LENSMODEL_CAHVOR (the model is "
          "stereographic)");
  const auto spline_refused = [](const std::string& lensmodel, std::vector<double> values,
                                 const std::string& expected) {
    try {
      MrcalLens spline(lensmodel, std::move(values));
      ADD_FAILURE() << "accepted: " << expected;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  spline_refused("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=150", std::vector<double>(95, 0.0),
                 "has 96 values after fx, fy, cx, cy, got 95");
  spline_refused("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8", std::vector<double>(96, 0.0),
                 "is not one of the mrcal lens");
  spline_refused("LENSMODEL_OPENCV8", std::vector<double>(8, 0.0),
                 "is not one of the mrcal lens models fishcam evaluates");
  spline_refused("LENSMODEL_CAHVORE_linearity=0.00", std::vector<double>(7, 0.0),
                 "has 8 values after fx, fy, cx, cy, got 7");
  spline_refused("LENSMODEL_CAHVORE_linearity=0.5", std::vector<double>(8, 0.0), "is not written as mrcal");
  spline_refused("LENSMODEL_CAHVOR", std::vector<double>(4, 0.0), "has 5 values after fx, fy, cx, cy, got 4");
  spline_refused("LENSMODEL_LONLAT", {1.0}, "has 0 values after fx, fy, cx, cy, got 1");
  // Configurations libmrcal would abort on, or parse wrapped (uint16), never reach it.
  const std::string prefix = "LENSMODEL_SPLINED_STEREOGRAPHIC_";
  spline_refused(prefix + "order=7_Nx=4_Ny=4_fov_x_deg=120", std::vector<double>(32, 0.0), "order must be 2 or 3");
  spline_refused(prefix + "order=3_Nx=1_Ny=1_fov_x_deg=120", std::vector<double>(2, 0.0),
                 "Nx and Ny must be in [4, 200]");
  spline_refused(prefix + "order=3_Nx=-4_Ny=4_fov_x_deg=120", std::vector<double>(32, 0.0), "is not written as mrcal");
  spline_refused(prefix + "order=3_Nx=99999999_Ny=4_fov_x_deg=120", std::vector<double>(32, 0.0),
                 "is not written as mrcal");
  spline_refused(prefix + "order=3_Nx=4_Ny=4_fov_x_deg=0", std::vector<double>(32, 0.0),
                 "fov_x_deg must be in [1, 359]");
  spline_refused(prefix + "order=3_Nx=4_Ny=4_fov_x_deg=120_extra", std::vector<double>(32, 0.0),
                 "is not one of the mrcal lens");
  std::vector<double> values(96, 0.0);
  values[5] = std::numeric_limits<double>::quiet_NaN();
  spline_refused("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=150", values, "must be finite");
}

// What fishcam's own file holds and what the other formats say when they cannot.
TEST(Tangential, FormatsHoldTheTermsTheyCanAndRefuseTheRestInOneLine) {
  CameraParameters p = test::every_tangential_camera().back().second;  // opencv with thin-prism terms
  ASSERT_EQ(model_name(p.model), "opencv");
  ASSERT_TRUE(p.tangential_terms().any_thin_prism());
  const Camera back(parse_camera(format_camera(p, CameraFormat::fishcam), "fishcam.json"));
  EXPECT_EQ(back.parameters().tangential_terms(), p.tangential_terms());
  try {
    format_camera(p, CameraFormat::ros);
    ADD_FAILURE() << "ros took thin-prism terms";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "tangential: the ros format cannot hold s1, s2, s3, s4 of the tangential terms (mrcal, opencv, "
                 "fishcam can)");
  }
  p.distortion = TangentialDistortion{{p.tangential_terms().p1, p.tangential_terms().p2, {}}};
  EXPECT_NE(format_camera(p, CameraFormat::ros).find("rational_polynomial"), std::string::npos);
  EXPECT_TRUE(camera_format_holds(CameraFormat::colmap, p.distortion));
  EXPECT_FALSE(camera_format_holds(CameraFormat::basalt, p.distortion));
  EXPECT_FALSE(camera_format_holds(CameraFormat::woodscape, p.distortion));
  // An unknown term in fishcam JSON is an error, not a silent zero.
  try {
    parse_camera(R"({"fishcam_camera": 1, "width": 640, "height": 480, "principal_point": [320, 240],
                     "pixel_scale": [1, 1], "model": "pinhole", "parameters": [300],
                     "tangential": {"p1": 0.001, "k3": 0.1}})",
                 "bad.json");
    ADD_FAILURE() << "an unknown tangential term was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("k3: unknown tangential term"), std::string::npos) << e.what();
  }
}

// Converting a camera with tangential terms to a radial model (principal point and a_y
// free): the report, the non-radial part and the error map, reproduced with OpenCV's
// projection of the source and Kannala-Brandt's formula for the result.
TEST(Tangential, ConversionToARadialModelReportsWhatAnIndependentComparisonFinds) {
  CameraParameters p = test::every_tangential_camera()[1].second;  // mei
  ASSERT_EQ(model_name(p.model), "mei");
  p = resized(p, 320, 242);
  const Camera source(p);
  const Conversion conversion = convert_camera(source, parse_model_spec("kannala-brandt"));
  EXPECT_TRUE(conversion.center_and_aspect_fitted);
  EXPECT_FALSE(displaces(conversion.camera.distortion));
  EXPECT_NE(conversion.camera.grid.principal_point, p.grid.principal_point);
  const auto k = model_params(conversion.camera.model);
  const test::Intrinsics fitted{k[0] * conversion.camera.grid.pixel_scale.x(),
                                k[0] * conversion.camera.grid.pixel_scale.y(),
                                conversion.camera.grid.principal_point.x(), conversion.camera.grid.principal_point.y()};
  const auto samples = sample_image(source, 2, 0);  // the report's evaluation grid
  std::vector<Eigen::Vector3d> rays;
  for (const auto& s : samples) rays.push_back(s.ray);
  const std::vector<Eigen::Vector2d> source_pixels = opencv_projection(p, rays);
  const std::vector<float> map = reprojection_error_map(source, Camera(conversion.camera));
  double sum2 = 0, worst = 0, map2 = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const Eigen::Vector2d ours = test::kannala_brandt(fitted, {k[1], k[2], k[3], k[4]}, rays[i]);
    const double e = (ours - source_pixels[i]).norm();
    sum2 += e * e, worst = std::max(worst, e);
    const float m = map[size_t(samples[i].pixel.y()) * size_t(p.width) + size_t(samples[i].pixel.x())];
    map2 += double(m) * double(m);
  }
  const double n = double(samples.size());
  ASSERT_EQ(conversion.report.samples, long(samples.size()));
  EXPECT_NEAR(std::sqrt(sum2 / n), conversion.report.rms_px, 1e-6);
  EXPECT_NEAR(worst, conversion.report.max_px, 1e-6);
  EXPECT_NEAR(std::sqrt(map2 / n), conversion.report.rms_px, 1e-5);  // the map's floats
  // The floor no radial model gets below (about the fitted centre): the terms matter
  // here, and the floor lies under every radial model's error, close under the best.
  EXPECT_EQ(conversion.non_radial.samples, long(samples.size()));
  EXPECT_GT(conversion.non_radial.rms_px, 0.05);
  EXPECT_LE(conversion.non_radial.rms_px, conversion.report.rms_px);
  EXPECT_GT(conversion.non_radial.rms_px, 0.8 * conversion.report.rms_px);
  for (const char* other : {"polynomial:6", "mei", "equidistant"}) {
    const Conversion c = convert_camera(source, parse_model_spec(other));
    EXPECT_LE(c.non_radial.rms_px, c.report.rms_px * (1 + 1e-9)) << other;
  }
  // A radial source has no floor to report; the same lens without its terms comes
  // out near exact with the same centre.
  CameraParameters radial = p;
  radial.distortion = NoPlaneDistortion{};
  EXPECT_EQ(convert_camera(Camera(radial), parse_model_spec("mei")).non_radial.samples, 0);
  std::printf("  mei + p1, p2 -> kannala-brandt: rms %.4f px, max %.4f px; no radial model below rms %.4f px\n",
              conversion.report.rms_px, conversion.report.max_px, conversion.non_radial.rms_px);
}

}  // namespace
}  // namespace fishcam
