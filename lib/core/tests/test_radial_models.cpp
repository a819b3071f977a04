// The models' analytic derivatives against central differences, and the generic
// projection instantiated with ceres::Jet against the analytic Jacobian.
#include <ceres/jet.h>

#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

// One test per example of every model (test_support.hpp).
class EveryModel : public ::testing::TestWithParam<test::ModelCase> {};

TEST_P(EveryModel, DerivativeMatchesCentralDifferences) {
  const Camera camera(GetParam().second);
  const double limit = camera.domain().closed ? camera.domain().theta_max : camera.domain().theta_max - 0.05;
  int checked = 0;
  for (double theta = 0.01; theta < limit - 1e-3; theta += 0.05, ++checked) {
    const double h = 1e-6;
    const double numeric = (camera.rho(theta + h) - camera.rho(theta - h)) / (2 * h);
    EXPECT_NEAR(camera.drho(theta), numeric, 1e-6 * std::max(1.0, std::abs(numeric))) << "theta " << theta;
  }
  EXPECT_GE(checked, 10) << "the domain left too few angles to test";
}

TEST(RadialModels, KnownValues) {
  EXPECT_DOUBLE_EQ(Equidistant<double>(2.0).rho(0.5), 1.0);
  EXPECT_DOUBLE_EQ(Stereographic<double>(2.0).rho(M_PI / 2), 4.0);  // 2 f tan(pi/4)
  EXPECT_DOUBLE_EQ(Pinhole<double>(3.0).rho(M_PI / 4), 3.0 * std::tan(M_PI / 4));
  // KB: f theta (1 + k1 theta^2 + ...); theta = 0.5, f = 100, k1 = 0.1 -> 100 * 0.5 * 1.025 = 51.25
  EXPECT_DOUBLE_EQ(KannalaBrandt<double>(100, 0.1, 0, 0, 0).rho(0.5), 51.25);
  // Polynomial: 2 t + 3 t^2 + 4 t^3 at t = 2 -> 4 + 12 + 32 = 48; derivative 2 + 12 + 48 = 62
  EXPECT_DOUBLE_EQ(Polynomial<double>({2, 3, 4}).rho(2.0), 48.0);
  EXPECT_DOUBLE_EQ(Polynomial<double>({2, 3, 4}).drho(2.0), 62.0);
  // Scaling is exact for every model.
  EXPECT_DOUBLE_EQ(KannalaBrandt<double>(100, 0.1, 0.01, 0, 0).scaled(2).rho(0.7),
                   2 * KannalaBrandt<double>(100, 0.1, 0.01, 0, 0).rho(0.7));
}

TEST_P(EveryModel, ProjectionJacobianMatchesCentralDifferences) {
  const Camera camera(GetParam().second);
  const double theta_max = std::min(camera.domain().theta_max - 0.05, 3.0);
  int checked = 0;
  for (const Eigen::Vector3d& ray : test::random_rays(200, theta_max, 11)) {
    const Eigen::Vector3d p = 2.5 * ray;
    Eigen::Vector2d pixel;
    Eigen::Matrix<double, 2, 3> jacobian;
    ASSERT_TRUE(camera.project(p, &pixel, &jacobian));
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6;
      Eigen::Vector3d dp = Eigen::Vector3d::Zero();
      dp[k] = h;
      Eigen::Vector2d plus, minus;
      ASSERT_TRUE(camera.project(p + dp, &plus) && camera.project(p - dp, &minus));
      const Eigen::Vector2d numeric = (plus - minus) / (2 * h);
      EXPECT_LT((jacobian.col(k) - numeric).norm(), 1e-5 * std::max(1.0, numeric.norm()))
          << "column " << k << " at " << p.transpose();
    }
    ++checked;
  }
  EXPECT_EQ(checked, 200);
}

INSTANTIATE_TEST_SUITE_P(RadialModels, EveryModel, ::testing::ValuesIn(test::every_model()), test::model_case_name);

// The generic projection with Jets: derivatives with respect to the point equal
// the analytic Jacobian, and derivatives with respect to the model parameters are
// what calibration (Ceres autodiff) needs.
TEST(RadialModels, CeresJetInstantiationMatchesAnalyticJacobian) {
  using Jet = ceres::Jet<double, 3>;
  const CameraParameters params = test::woodscape_front();
  const Camera camera(params);
  const auto k = std::get<Polynomial<double>>(params.model).params();
  const Polynomial<Jet> model({Jet(k[0]), Jet(k[1]), Jet(k[2]), Jet(k[3])});
  const Jet mapping[4] = {Jet(params.grid.principal_point.x()), Jet(params.grid.principal_point.y()), Jet(1.0),
                          Jet(1.0)};
  for (const Eigen::Vector3d& ray : test::random_rays(500, 3.0, 5)) {
    const Eigen::Vector3d p = 1.7 * ray;
    const Jet point[3] = {Jet(p.x(), 0), Jet(p.y(), 1), Jet(p.z(), 2)};
    Jet pixel[2];
    project_radial(model, mapping, point, pixel);
    Eigen::Vector2d expected;
    Eigen::Matrix<double, 2, 3> jacobian;
    ASSERT_TRUE(camera.project(p, &expected, &jacobian));
    EXPECT_NEAR(pixel[0].a, expected.x(), 1e-12);
    EXPECT_NEAR(pixel[1].a, expected.y(), 1e-12);
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(pixel[0].v[j], jacobian(0, j), 1e-9 * std::max(1.0, std::abs(jacobian(0, j))));
      EXPECT_NEAR(pixel[1].v[j], jacobian(1, j), 1e-9 * std::max(1.0, std::abs(jacobian(1, j))));
    }
  }
  // d u / d k1 = theta X / chi for the polynomial.
  using Jet1 = ceres::Jet<double, 1>;
  const Polynomial<Jet1> by_k1({Jet1(k[0], 0), Jet1(k[1]), Jet1(k[2]), Jet1(k[3])});
  const Jet1 mapping1[4] = {Jet1(0.0), Jet1(0.0), Jet1(1.0), Jet1(1.0)};
  const Jet1 point[3] = {Jet1(0.3), Jet1(-0.4), Jet1(-0.2)};  // behind the camera: theta > 90 deg
  Jet1 pixel[2];
  const Jet1 theta = project_radial(by_k1, mapping1, point, pixel);
  EXPECT_GT(theta.a, M_PI / 2);
  EXPECT_NEAR(pixel[0].v[0], theta.a * 0.3 / 0.5, 1e-14);
  EXPECT_NEAR(pixel[1].v[0], theta.a * -0.4 / 0.5, 1e-14);
}

TEST(RadialModels, JetOnTheOpticalAxisHasFirstOrderDerivatives) {
  using Jet = ceres::Jet<double, 3>;
  const Equidistant<Jet> model{Jet(300.0)};
  const Jet mapping[4] = {Jet(10.0), Jet(20.0), Jet(1.0), Jet(2.0)};
  const Jet point[3] = {Jet(0.0, 0), Jet(0.0, 1), Jet(2.0, 2)};
  Jet pixel[2];
  project_radial(model, mapping, point, pixel);
  EXPECT_EQ(pixel[0].a, 10.0);
  EXPECT_EQ(pixel[1].a, 20.0);
  EXPECT_DOUBLE_EQ(pixel[0].v[0], 300.0 / 2.0);  // a_x f / Z
  EXPECT_DOUBLE_EQ(pixel[1].v[1], 2 * 300.0 / 2.0);
  EXPECT_TRUE(std::isfinite(pixel[0].v[2]));
}

}  // namespace
}  // namespace fishcam
