// The plane-distortion registry (fishcam/core/plane_distortion.hpp): every registered
// part, from the registry's own list, serialises and reads back, has the Jacobian its
// offset claims, and gives cameras that project and unproject consistently.
#include <gtest/gtest.h>

#include <string>

#include "fishcam/core/camera.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

class EveryPlaneDistortion : public ::testing::TestWithParam<std::string_view> {};

TEST_P(EveryPlaneDistortion, SerialisesProjectsAndUnprojects) {
  const std::string_view name = GetParam();
  const std::vector<test::ModelCase> examples = test::distortion_examples(name);
  ASSERT_FALSE(examples.empty());
  int checked = 0;
  for (const test::ModelCase& example : examples) {
    // Not a structured binding: the lambdas below capture the camera (clang 14 refuses
    // to capture a binding).
    const CameraParameters& p = example.second;
    SCOPED_TRACE(example.first);
    // The one serialisation reads back to the same part.
    const PlaneDistortionNumbers numbers = numbers_of(p.distortion);
    EXPECT_EQ(numbers.name, name);
    const PlaneDistortion back = make_plane_distortion(numbers.name, numbers.configuration, numbers.values);
    EXPECT_TRUE(same_distortion(back, p.distortion));
    EXPECT_EQ(distortion_name(back), name == "none" ? distortion_name(p.distortion) : name);
    // The offset's Jacobian is its derivative (central differences, step 1e-6 on the plane).
    const Camera camera(p);
    const double reach = std::isfinite(camera.domain().plane_reach) ? camera.domain().plane_reach : 1.0;
    for (const Eigen::Vector2d& m : {Eigen::Vector2d(0.1, -0.05), Eigen::Vector2d(-0.2, 0.15)}) {
      const Eigen::Vector2d at = m * std::min(1.0, reach);
      Eigen::Matrix2d jacobian;
      const Eigen::Vector2d offset = std::visit([&](const auto& d) { return d.offset(at, &jacobian); }, p.distortion);
      ASSERT_TRUE(offset.allFinite());
      for (int k = 0; k < 2; ++k) {
        const Eigen::Vector2d h = 1e-6 * Eigen::Vector2d::Unit(k);
        const auto eval = [&](const Eigen::Vector2d& x) {
          return std::visit([&](const auto& d) { return d.offset(x); }, p.distortion);
        };
        const Eigen::Vector2d numeric = (eval(at + h) - eval(at - h)) / 2e-6;
        EXPECT_LE((numeric - jacobian.col(k)).norm(), 1e-6 * (1 + jacobian.norm())) << "column " << k;
      }
    }
    // The camera of this part: unproject(project(ray)) = ray, and the projection's
    // Jacobian matches central differences, over its valid domain.
    const double limit = camera.domain().closed ? camera.domain().theta_max : camera.domain().theta_max - 1e-3;
    double worst_ray = 0, worst_jacobian = 0;
    for (const Eigen::Vector3d& ray : test::random_rays(200, limit * 0.98, 7)) {
      Eigen::Vector2d pixel;
      Eigen::Matrix<double, 2, 3> jacobian;
      ASSERT_TRUE(camera.project(ray, &pixel, &jacobian));
      Eigen::Vector3d back_ray;
      ASSERT_TRUE(camera.unproject(pixel, &back_ray));
      worst_ray = std::max(worst_ray, (back_ray - ray).norm());
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d h = 1e-7 * Eigen::Vector3d::Unit(k);
        Eigen::Vector2d plus, minus;
        ASSERT_TRUE(camera.project(ray + h, &plus) && camera.project(ray - h, &minus));
        const Eigen::Vector2d numeric = (plus - minus) / 2e-7;
        worst_jacobian = std::max(worst_jacobian, (numeric - jacobian.col(k)).norm() / (1 + jacobian.col(k).norm()));
      }
    }
    EXPECT_LE(worst_ray, 1e-9);
    EXPECT_LE(worst_jacobian, 1e-5);
    ++checked;
  }
  EXPECT_EQ(checked, int(examples.size()));
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryPlaneDistortion, ::testing::ValuesIn(plane_distortion_names()),
                         [](const ::testing::TestParamInfo<std::string_view>& info) {
                           return std::string(info.param);
                         });

// The sweep above has one case per registered part (counted from GoogleTest's own
// registry: CTest runs each case in its own process).
TEST(PlaneDistortionRegistry, TheSweepHasOneCasePerPart) {
  const ::testing::UnitTest& unit = *::testing::UnitTest::GetInstance();
  int cases = 0;
  for (int i = 0; i < unit.total_test_suite_count(); ++i) {
    if (std::string(unit.GetTestSuite(i)->name()) == "Registry/EveryPlaneDistortion") {
      cases = unit.GetTestSuite(i)->total_test_count();
    }
  }
  EXPECT_EQ(cases, int(PlaneDistortionRegistry::kSize));
  EXPECT_EQ(plane_distortion_names().size(), PlaneDistortionRegistry::kSize);
}

TEST(PlaneDistortionRegistry, RefusesUnknownPartsAndWrongNumbersInOneLine) {
  const auto refused = [](std::string_view name, std::string_view configuration, std::vector<double> values,
                          const std::string& expected) {
    try {
      make_plane_distortion(name, configuration, std::move(values));
      ADD_FAILURE() << name << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()), expected);
    }
  };
  refused("radtan", "", {}, "distortion: unknown plane distortion 'radtan' (none, tangential, mrcal_lens)");
  refused("none", "", {1.0}, "none: takes no values, got 1");
  refused("tangential", "", {0.1, 0.2}, "tangential: expected 6 values (p1, p2, s1, s2, s3, s4), got 2");
  refused("tangential", "x", std::vector<double>(6, 0.0), "tangential: takes no configuration, got 'x'");
  EXPECT_THROW(make_plane_distortion("mrcal_lens", "LENSMODEL_NOPE", {}), Error);
  // A part without its lens is refused by the camera in one line, never dereferenced.
  CameraParameters lensless = test::spline_camera().second;
  lensless.distortion = MrcalLensDistortion{};
  try {
    Camera camera(lensless);
    ADD_FAILURE() << "a camera without its mrcal lens accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "mrcal_lens.lens: none given");
  }
  // Terms all zero displace nothing: they serialise as "none", and equal "none".
  EXPECT_TRUE(same_distortion(TangentialDistortion{}, NoPlaneDistortion{}));
  EXPECT_FALSE(same_distortion(TangentialDistortion{{1e-3, 0, {}}}, NoPlaneDistortion{}));
}

}  // namespace
}  // namespace fishcam
