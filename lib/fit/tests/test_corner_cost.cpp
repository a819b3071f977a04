// The calibration's corner residual with written-out Jacobians (CornerCost) against
// Ceres' automatic derivatives of the same residual (CornerResidual), for every
// model: the solve and its covariance depend on these Jacobians.
#include <gtest/gtest.h>

#include <random>

#include "calibration_internal.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

class EveryModelCornerCost : public ::testing::TestWithParam<test::ModelCase> {};

TEST_P(EveryModelCornerCost, JacobiansMatchAutomaticDifferentiation) {
  const CameraParameters& p = GetParam().second;
  const Camera camera(p);
  std::vector<double> model = model_params(p.model);
  Eigen::Vector2d center = p.grid.principal_point;
  double ay = p.grid.pixel_scale.y();
  const int n = int(model.size());
  // Camera-frame points: random rays up to 100 deg (or the model's limit), and rays
  // near and on the axis (where the closed form hands over to automatic derivatives).
  std::vector<Eigen::Vector3d> rays = test::random_rays(300, std::min(100 * M_PI / 180, camera.domain().theta_max), 11);
  for (const double off_axis : {0.0, 1e-6, 1e-5, 1e-4, 1e-2})
    rays.push_back(Eigen::Vector3d(off_axis, -off_axis / 3, 1).normalized());
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int compared = 0;
  with_model_class(model_name(p.model), [&]<template <typename> class Model>() {
    for (const Eigen::Vector3d& ray : rays) {
      Eigen::Vector2d pixel;
      if (!camera.project(ray, &pixel)) continue;
      // A board pose (rotation up to ~100 deg) and the board point it takes onto the ray.
      std::array<double, 6> pose{2 * uniform(rng), 2 * uniform(rng), 2 * uniform(rng),
                                 uniform(rng),     uniform(rng),     1 + uniform(rng)};
      const BoardPose board = detail::pose_of(pose);
      const Eigen::Vector3d point = board.rotation.inverse() * ((1.5 + uniform(rng)) * ray - board.translation);
      const Eigen::Vector2d corner = pixel + Eigen::Vector2d(uniform(rng), uniform(rng));
      detail::CornerCost<Model> analytic(point, corner, n);
      ceres::DynamicAutoDiffCostFunction<detail::CornerResidual<Model>, 8> automatic(
          new detail::CornerResidual<Model>{point, corner, n});
      for (const int size : {n, 2, 1, 6}) automatic.AddParameterBlock(size);
      automatic.SetNumResiduals(2);
      const double* blocks[4] = {model.data(), center.data(), &ay, pose.data()};
      std::vector<double> j_model(2 * size_t(n)), j_center(4), j_ay(2), j_pose(12);
      std::vector<double> k_model(2 * size_t(n)), k_center(4), k_ay(2), k_pose(12);
      double* jacobians[4] = {j_model.data(), j_center.data(), j_ay.data(), j_pose.data()};
      double* references[4] = {k_model.data(), k_center.data(), k_ay.data(), k_pose.data()};
      double residual[2], expected[2];
      ASSERT_TRUE(analytic.Evaluate(blocks, residual, jacobians));
      ASSERT_TRUE(automatic.Evaluate(blocks, expected, references));
      EXPECT_NEAR(residual[0], expected[0], 1e-9);
      EXPECT_NEAR(residual[1], expected[1], 1e-9);
      const auto same = [&](const std::vector<double>& a, const std::vector<double>& b, const char* what) {
        for (size_t i = 0; i < a.size(); ++i) {
          EXPECT_NEAR(a[i], b[i], 1e-8 * std::max(1.0, std::abs(b[i])))
              << what << "[" << i << "] at ray " << ray.transpose();
        }
      };
      same(j_model, k_model, "d/d model"), same(j_center, k_center, "d/d center");
      same(j_ay, k_ay, "d/d a_y"), same(j_pose, k_pose, "d/d pose");
      // Constant blocks (no Jacobian asked) and residuals alone.
      double* pose_only[4] = {nullptr, nullptr, nullptr, j_pose.data()};
      ASSERT_TRUE(analytic.Evaluate(blocks, residual, pose_only));
      same(j_pose, k_pose, "d/d pose (pose only)");
      ASSERT_TRUE(analytic.Evaluate(blocks, residual, nullptr));
      EXPECT_NEAR(residual[0], expected[0], 1e-9);
      // With the boards' warp (a fifth block): the point moved along the board's z.
      const Eigen::Vector2d factors(0.5 + 0.5 * uniform(rng), 0.5 + 0.5 * uniform(rng));
      double warp[2] = {0.02 * uniform(rng), 0.02 * uniform(rng)};
      detail::CornerCost<Model> warped(point, corner, n, factors);
      ceres::DynamicAutoDiffCostFunction<detail::CornerResidual<Model>, 8> warped_reference(
          new detail::CornerResidual<Model>{point, corner, n, factors});
      for (const int size : {n, 2, 1, 6, 2}) warped_reference.AddParameterBlock(size);
      warped_reference.SetNumResiduals(2);
      const double* warped_blocks[5] = {model.data(), center.data(), &ay, pose.data(), warp};
      std::vector<double> j_warp(4), k_warp(4);
      double* warped_jacobians[5] = {j_model.data(), j_center.data(), j_ay.data(), j_pose.data(), j_warp.data()};
      double* warped_references[5] = {k_model.data(), k_center.data(), k_ay.data(), k_pose.data(), k_warp.data()};
      ASSERT_TRUE(warped.Evaluate(warped_blocks, residual, warped_jacobians));
      ASSERT_TRUE(warped_reference.Evaluate(warped_blocks, expected, warped_references));
      EXPECT_NEAR(residual[0], expected[0], 1e-9);
      EXPECT_NEAR(residual[1], expected[1], 1e-9);
      same(j_model, k_model, "warped: d/d model"), same(j_pose, k_pose, "warped: d/d pose");
      same(j_warp, k_warp, "d/d warp");
      ++compared;
    }
  });
  EXPECT_GE(compared, 200) << "points compared";
}

INSTANTIATE_TEST_SUITE_P(Calibration, EveryModelCornerCost, ::testing::ValuesIn(test::every_model()),
                         test::model_case_name);

}  // namespace
}  // namespace fishcam
