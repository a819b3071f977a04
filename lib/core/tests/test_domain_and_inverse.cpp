// The valid domain (model limit, fold, user limit), the robust theta(rho) and its
// independent algebraic cross-check, the inverse table, and adversarial models.
#include <random>

#include "fishcam/testing/test_support.hpp"
#include "fishcam/testing/testing.hpp"

namespace fishcam {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDeg = 180 / M_PI;

CameraParameters polynomial_camera(std::vector<double> k) {
  return test::with_model(test::woodscape_front(), Polynomial<double>(std::move(k)));
}

double residual_px(const Camera& camera, double rho, double theta) { return std::abs(camera.rho(theta) - rho); }

TEST(Domain, WoodScapeFrontIsValidToPi) {
  const Camera camera(test::woodscape_front());
  EXPECT_EQ(camera.domain().theta_max, M_PI);
  EXPECT_EQ(camera.domain().limited_by, ValidDomain::Limit::model);
  EXPECT_TRUE(camera.domain().closed);
  EXPECT_DOUBLE_EQ(camera.domain().rho_max, camera.rho(M_PI));
}

TEST(Domain, FoldIsTheExactRootOfTheDerivative) {
  // rho = 300 t - 40 t^4: rho' = 300 - 160 t^3 = 0 at t = (300/160)^(1/3) = 1.2331 rad (70.7 deg),
  // rho_max = 277.4 px: a fold well inside a 1280x966 image.
  const Camera camera(polynomial_camera({300, 0, 0, -40}));
  const double exact = std::cbrt(300.0 / 160.0);
  EXPECT_EQ(camera.domain().limited_by, ValidDomain::Limit::fold);
  EXPECT_NEAR(camera.domain().theta_max, exact, 1e-15);
  EXPECT_NEAR(camera.drho(camera.domain().theta_max), 0.0, 1e-12);
  EXPECT_NEAR(camera.domain().rho_max, 300 * exact - 40 * std::pow(exact, 4), 1e-12);
}

TEST(Domain, NegativeK4FoldsBeforePiAndRhoIncreasesUpToIt) {
  const Camera camera(polynomial_camera({339.749, -31.988, 48.275, -30.0}));
  const double theta_max = camera.domain().theta_max;
  EXPECT_EQ(camera.domain().limited_by, ValidDomain::Limit::fold);
  EXPECT_LT(theta_max, M_PI);
  EXPECT_NEAR(camera.drho(theta_max), 0.0, 1e-9);
  for (int i = 0; i < 100000; ++i) ASSERT_GT(camera.drho(theta_max * i / 100000.0), 0.0);
}

TEST(Domain, KannalaBrandtFoldUsesTheDegreeNinePolynomial) {
  // k1 = -0.1: rho' = f (1 - 0.3 t^2) = 0 at t = sqrt(1/0.3).
  CameraParameters p = test::with_model(test::woodscape_front(), KannalaBrandt<double>(300, -0.1, 0, 0, 0));
  const Camera camera(p);
  EXPECT_NEAR(camera.domain().theta_max, std::sqrt(1 / 0.3), 1e-15);
}

TEST(Domain, DoubleRootOfTheDerivativeIsFound) {
  // rho' = 3 (t - 1)^2 = 3 - 6 t + 3 t^2 touches zero at t = 1 without changing sign.
  const Camera camera(polynomial_camera({3, -3, 1}));
  EXPECT_NEAR(camera.domain().theta_max, 1.0, 1e-7);
  EXPECT_EQ(camera.domain().limited_by, ValidDomain::Limit::fold);
}

TEST(Domain, ModelsThatDoNotIncreaseAtZeroAreRejected) {
  for (double k1 : {0.0, -1.0}) {
    try {
      Camera camera(polynomial_camera({k1, 10, 5}));
      FAIL() << "k1 = " << k1 << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("k1 must be > 0"), std::string::npos) << e.what();
    }
  }
  CameraParameters p = test::woodscape_front();
  for (RadialModel m : {RadialModel(Equidistant<double>(0.0)), RadialModel(Stereographic<double>(-1)),
                        RadialModel(Pinhole<double>(0.0)), RadialModel(KannalaBrandt<double>(-300, 0, 0, 0, 0))}) {
    p.model = m;
    EXPECT_THROW(Camera{p}, Error) << model_name(m);
  }
  p.model = Polynomial<double>({kNaN, 1});
  EXPECT_THROW(Camera{p}, Error);
}

TEST(Domain, UserLimit) {
  CameraParameters p = test::woodscape_front();
  p.theta_limit = 100 * M_PI / 180;
  const Camera camera(p);
  EXPECT_EQ(camera.domain().theta_max, *p.theta_limit);
  EXPECT_EQ(camera.domain().limited_by, ValidDomain::Limit::user);
  Eigen::Vector2d pixel;
  EXPECT_FALSE(camera.project(Eigen::Vector3d(1, 0, -0.2), &pixel));  // 101 deg
  EXPECT_TRUE(camera.project(Eigen::Vector3d(1, 0, -0.1), &pixel));   // 95.7 deg
  for (double bad : {0.0, -0.1, 3.2, kNaN}) {
    p.theta_limit = bad;
    EXPECT_THROW(Camera{p}, Error) << bad;
  }
  p.model = Pinhole<double>(500);
  p.theta_limit = M_PI / 2;  // the pinhole limit itself is excluded, and the message says so
  try {
    Camera{p};
    ADD_FAILURE() << "theta_limit 90 accepted for a pinhole";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "theta_limit: must be in (0, 90) degrees for pinhole, got 90");
  }
  p.theta_limit = 1.0;
  EXPECT_EQ(Camera(p).domain().theta_max, 1.0);
  EXPECT_TRUE(Camera(p).domain().closed);
}

// A limit per azimuth sector: whole images unproject to NaN past it, the field of
// view follows it, resizing, cropping and flipping keep it (it is of the camera
// frame), and a sector's limit outside [0, 180] degrees is refused by name.
TEST(Domain, PerAzimuthLimit) {
  CameraParameters p = resized(test::woodscape_front(), 320, 242);
  AzimuthSectors& limits = p.theta_limit_by_azimuth.emplace();
  limits.fill(80 / kDeg);
  for (int k : {5, 6, 7}) limits[size_t(k)] = 30 / kDeg;  // azimuths -105 .. -60 deg: the image's top
  const Camera camera(p);
  std::vector<float> rays(3 * 320 * 242);
  camera.unproject_image(rays);
  int refused = 0, kept = 0;
  for (size_t i = 0; i < rays.size() / 3; ++i) {
    const Eigen::Vector2d pixel(double(i % 320), double(i / 320));
    Eigen::Vector3d ray;
    const bool valid = camera.unproject(pixel, &ray);
    ASSERT_EQ(valid, !std::isnan(rays[3 * i])) << pixel.transpose();
    if (!valid) {
      ++refused;
      continue;
    }
    ++kept;
    const double theta = std::acos(std::clamp(ray.z(), -1.0, 1.0)) * kDeg;
    EXPECT_LE(theta, angle_near_azimuth(limits, std::atan2(ray.y(), ray.x())) * kDeg + 1e-9);
  }
  EXPECT_GT(refused, 1000);
  EXPECT_GT(kept, 20000);
  // Vertically the field of view is 30 deg up (the top sectors' limit) and down what
  // the bottom border sees (within the 80 deg limit there). Sampled along the column: 0.5 deg.
  const Camera whole(resized(test::woodscape_front(), 320, 242));
  Eigen::Vector3d bottom;
  ASSERT_TRUE(whole.unproject({whole.principal_point().x(), 241.5}, &bottom));
  ASSERT_LT(std::acos(bottom.z()) * kDeg, 80);
  EXPECT_NEAR(camera.field_of_view_deg().vertical, 30 + std::acos(bottom.z()) * kDeg, 0.5);
  for (const CameraParameters& kept_limit :
       {resized(p, 640, 484), cropped(p, 10, 5, 200, 200), mirrored(p, true, true)}) {
    EXPECT_EQ(kept_limit.theta_limit_by_azimuth, p.theta_limit_by_azimuth);
  }
  for (double bad : {-0.1, 3.2, kNaN}) {
    CameraParameters broken = p;
    (*broken.theta_limit_by_azimuth)[3] = bad;
    try {
      Camera{broken};
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("theta_limit_by_azimuth: every sector's limit must be in [0, 180]"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(Domain, HugeCoefficients) {
  // Finite but enormous: still solved to full relative precision.
  const Camera huge(polynomial_camera({1e12, -3e11, 2e11, -1e10}));
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int i = 0; i < 10000; ++i) {
    const double rho = uniform(rng) * huge.domain().rho_max;
    const double theta = huge.theta_from_rho(rho);
    ASSERT_TRUE(huge.domain().contains_theta(theta));
    EXPECT_LE(residual_px(huge, rho, theta), 1e-14 * huge.domain().rho_max);
  }
  // Tiny positive derivative roots of a huge-coefficient polynomial are complex, not folds.
  const Camera steep(polynomial_camera({339.749, -31.988, 48.275, 1e306}));
  EXPECT_EQ(steep.domain().limited_by, ValidDomain::Limit::model);
  EXPECT_NEAR(steep.domain().rho_max / 1e306, std::pow(M_PI, 4), 1e-12);
  // Overflow: rejected, not a silent infinity.
  EXPECT_THROW(Camera{polynomial_camera({1, 0, 0, 1e308})}, Error);
  EXPECT_THROW(Camera{polynomial_camera({1, 0, 0, 0, 0, 0, 0, 0, 0, 1e306})}, Error);
}

TEST(Inverse, BoundariesAndInvalidRadii) {
  for (const auto& params : {test::woodscape_front(), polynomial_camera({300, 0, 0, -40})}) {
    const Camera camera(params);
    const ValidDomain& d = camera.domain();
    EXPECT_EQ(camera.theta_from_rho(0.0), 0.0);
    EXPECT_EQ(camera.theta_from_rho(d.rho_max), d.theta_max);
    EXPECT_EQ(camera.theta_from_rho_table(0.0), 0.0);
    EXPECT_NEAR(camera.theta_from_rho_table(d.rho_max), d.theta_max, 1e-6);
    for (double bad : {std::nextafter(d.rho_max, kInf), d.rho_max + 1, -1e-300, -1.0, kNaN, kInf}) {
      EXPECT_TRUE(std::isnan(camera.theta_from_rho(bad))) << bad;
      EXPECT_TRUE(std::isnan(camera.theta_from_rho_table(bad))) << bad;
    }
    Eigen::Vector3d ray;
    ASSERT_TRUE(camera.unproject(params.grid.principal_point, &ray));
    EXPECT_EQ(ray, Eigen::Vector3d(0, 0, 1));
    ASSERT_TRUE(camera.unproject(params.grid.principal_point + Eigen::Vector2d(d.rho_max, 0), &ray));
    EXPECT_NEAR(std::acos(ray.z()), d.theta_max, 1e-7);
  }
}

TEST(Inverse, EveryUnprojectionOutsideTheDomainIsNaN) {
  const Camera camera(polynomial_camera({300, 0, 0, -40}));  // image circle of 277 px in a 1280x966 image
  std::vector<Eigen::Vector2d> pixels;
  for (int v = 0; v < camera.height(); v += 3) {
    for (int u = 0; u < camera.width(); u += 3) pixels.emplace_back(u, v);
  }
  std::vector<Eigen::Vector3d> rays(pixels.size());
  std::vector<std::uint8_t> valid(pixels.size());
  for (InversePath path : {InversePath::robust, InversePath::table}) {
    camera.unproject(pixels, rays, valid, path);
    size_t inside = 0;
    for (size_t i = 0; i < pixels.size(); ++i) {
      const bool in_domain = camera.rho_of_pixel(pixels[i]) <= camera.domain().rho_max;
      ASSERT_EQ(bool(valid[i]), in_domain) << pixels[i].transpose();
      ASSERT_EQ(rays[i].allFinite(), in_domain);
      if (!in_domain) {
        ASSERT_TRUE(rays[i].array().isNaN().all());
      }
      inside += in_domain;
    }
    EXPECT_GT(inside, 10000u);
    EXPECT_LT(inside, pixels.size() / 2);
  }
}

// One test per example of every model (test_support.hpp).
class EveryModel : public ::testing::TestWithParam<test::ModelCase> {};

TEST_P(EveryModel, RobustSolverResidualAndAlgebraicCrossCheck) {
  const Camera camera(GetParam().second);
  std::mt19937_64 rng(17);
  const double rho_hi = camera.domain().closed ? camera.domain().rho_max : 3000.0;
  std::uniform_real_distribution<double> uniform(0.0, rho_hi);
  int algebraic_checks = 0;
  for (int i = 0; i < 20000; ++i) {
    const double rho = uniform(rng), theta = camera.theta_from_rho(rho);
    ASSERT_TRUE(camera.domain().contains_theta(theta)) << "rho " << rho;
    ASSERT_LE(residual_px(camera, rho, theta), 1e-9) << "rho " << rho;
    std::visit(
        [&](const auto& m) {
          if constexpr (PolynomialInTheta<std::decay_t<decltype(m)>>) {
            if (i % 10 == 0) {
              const double algebraic = testing::algebraic_theta(m.power_coefficients(), rho, camera.domain());
              ASSERT_NEAR(algebraic, theta, 1e-9) << "rho " << rho;
              ++algebraic_checks;
            }
          }
        },
        camera.model());
  }
  std::visit(
      [&](const auto& m) {
        // Models polynomial in theta are also checked against the algebraic root.
        EXPECT_EQ(algebraic_checks, PolynomialInTheta<std::decay_t<decltype(m)>> ? 2000 : 0);
      },
      camera.model());
}

INSTANTIATE_TEST_SUITE_P(Inverse, EveryModel, ::testing::ValuesIn(test::every_model()), test::model_case_name);

TEST(Inverse, FoldRadiiSolveToTheBracket) {
  // Right next to a fold rho' -> 0: Newton alone diverges, the bracket keeps it.
  const Camera camera(polynomial_camera({300, 0, 0, -40}));
  const double rho_max = camera.domain().rho_max;
  for (double gap : {1e-1, 1e-4, 1e-8, 1e-11}) {
    const double theta = camera.theta_from_rho(rho_max - gap);
    ASSERT_TRUE(camera.domain().contains_theta(theta));
    EXPECT_LE(residual_px(camera, rho_max - gap, theta), 1e-9) << gap;
  }
}

TEST(Inverse, TableErrorIsMeasuredAndWithinTolerance) {
  for (const auto& params :
       {test::woodscape_front(), polynomial_camera({300, 0, 0, -40}),
        test::with_model(test::woodscape_front(),
                         KannalaBrandt<double>(331.5526, 0.0346514, 0.0241055, -0.0074981, 0.0007767))}) {
    const Camera camera(params);
    const InverseTable& table = camera.inverse_table();
    ASSERT_FALSE(table.empty());
    EXPECT_LE(table.worst_error_px(), 1e-6);
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> uniform(0.0, camera.domain().rho_max);
    double worst = 0;
    for (int i = 0; i < 200000; ++i) {
      const double rho = uniform(rng);
      worst = std::max(worst, residual_px(camera, rho, camera.theta_from_rho_table(rho)));
    }
    EXPECT_LE(worst, 1e-6);
    // The ray table: angle error times rho'(theta), in pixels, within the same tolerance.
    EXPECT_LE(table.worst_ray_error_px(), 1e-6);
    double worst_ray = 0;
    for (int i = 0; i < 200000; ++i) {
      const double rho = uniform(rng);
      double s, c;
      if (!table.lookup_ray(rho, &s, &c)) continue;
      const double theta = camera.theta_from_rho(rho);
      const Eigen::Vector3d exact(std::sin(theta), 0, std::cos(theta)), approx(s * rho, 0, c);
      worst_ray = std::max(worst_ray, test::angle_between(exact, approx) * camera.drho(theta));
      ASSERT_NEAR(approx.norm(), 1.0, 1e-8);
    }
    EXPECT_LE(worst_ray, 1e-6);
  }
  // The fold's square-root singularity forces the last cells onto the robust solver.
  EXPECT_GT(Camera(polynomial_camera({300, 0, 0, -40})).inverse_table().fallback_cells(), 0);
  EXPECT_EQ(Camera(test::woodscape_front()).inverse_table().fallback_cells(), 0);
}

TEST(Inverse, FirstPositiveRootHandlesMissingAndEndpointRoots) {
  const std::vector<double> no_root = {1, 0, 1};  // 1 + x^2
  EXPECT_FALSE(first_positive_root(no_root, 10.0).has_value());
  const std::vector<double> line = {-2, 1};  // root at 2
  EXPECT_EQ(first_positive_root(line, 10.0).value(), 2.0);
  EXPECT_FALSE(first_positive_root(line, 1.0).has_value());
  const std::vector<double> two_roots = {6, -5, 1};  // roots 2 and 3
  EXPECT_NEAR(first_positive_root(two_roots, 10.0).value(), 2.0, 1e-15);
}

// fit_power_series (the ocam kernel's Newton start, OCamCalib's invpol): a power series
// through exact samples comes back to rounding, with powers from `first`; a lower
// degree than the data's leaves the residual it must; bad arguments are refused.
TEST(Inverse, PowerSeriesFitRecoversAPolynomialAndReportsItsResidual) {
  std::vector<double> x, y;
  for (int i = 0; i <= 200; ++i) {
    const double t = -1 + i / 100.0;
    x.push_back(t);
    y.push_back(0.5 * t - 2 * t * t * t + 0.25 * t * t * t * t);  // powers 1..4
  }
  const PowerSeriesFit exact = fit_power_series(x, y, 1, 4);
  ASSERT_EQ(exact.coefficients.size(), 4u);
  const double expected[4] = {0.5, 0, -2, 0.25};
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(exact.coefficients[size_t(k)], expected[k], 1e-13) << k;
  EXPECT_LE(exact.worst, 1e-13);
  const PowerSeriesFit low = fit_power_series(x, y, 0, 2);  // misses the cubic and quartic terms
  EXPECT_EQ(low.coefficients.size(), 3u);
  EXPECT_GT(low.worst, 0.1);
  EXPECT_THROW(fit_power_series(x, std::vector<double>(3, 0.0), 0, 2), Error);
  EXPECT_THROW(fit_power_series(x, y, 3, 2), Error);
}

TEST(Projection, InvalidPoints) {
  const Camera camera(test::woodscape_front());
  Eigen::Vector2d pixel;
  EXPECT_FALSE(camera.project(Eigen::Vector3d(0, 0, 0), &pixel));
  EXPECT_TRUE(pixel.array().isNaN().all());
  EXPECT_FALSE(camera.project(Eigen::Vector3d(0, 0, -1), &pixel));  // direction undefined at theta = pi
  EXPECT_FALSE(camera.project(Eigen::Vector3d(kNaN, 0, 1), &pixel));
  EXPECT_FALSE(camera.project(Eigen::Vector3d(kInf, 0, 1), &pixel));
  EXPECT_TRUE(camera.project(Eigen::Vector3d(1e-9, 0, -1), &pixel));  // just off the -z axis
  const Camera pinhole(test::with_model(test::woodscape_front(), Pinhole<double>(500)));
  EXPECT_FALSE(pinhole.project(Eigen::Vector3d(1, 0, 0), &pixel));   // theta = 90 deg
  EXPECT_FALSE(pinhole.project(Eigen::Vector3d(1, 0, -1), &pixel));  // behind
  const Camera stereographic(test::with_model(test::woodscape_front(), Stereographic<double>(300)));
  EXPECT_TRUE(stereographic.project(Eigen::Vector3d(1, 0, -3), &pixel));  // behind, 161.6 deg
}

}  // namespace
}  // namespace fishcam
