// The unified-camera family (unified, extended-unified, double-sphere, mei)
// against the published formulas written here in 3D (Usenko et al. 2018 for
// UCM/EUCM/DS, Mei & Rives 2007 for mei), their closed-form inverses against the
// bracketed solver, and their closed-form valid domains against the generic
// fold search and the poles of the formulas.
#include <functional>

#include "fishcam/testing/reference_models.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

using test::double_sphere;
using test::eucm;
using test::Intrinsics;
using test::mei;
using test::ucm_xi;

struct Case {
  std::string name;
  RadialModel model;
  std::function<Eigen::Vector2d(const Intrinsics&, const Eigen::Vector3d&)> reference;
};

std::vector<Case> cases() {
  return {
      {"unified pole", Unified<double>(640, 0.9), [](auto& k, auto& p) { return ucm_xi(k, 0.9, p); }},
      {"unified fold", Unified<double>(1100, 1.6), [](auto& k, auto& p) { return ucm_xi(k, 1.6, p); }},
      {"unified xi 1", Unified<double>(660, 1.0), [](auto& k, auto& p) { return ucm_xi(k, 1.0, p); }},
      {"eucm fold", ExtendedUnified<double>(400, 0.6, 1.1), [](auto& k, auto& p) { return eucm(k, 0.6, 1.1, p); }},
      {"eucm pole", ExtendedUnified<double>(340, 0.45, 0.9), [](auto& k, auto& p) { return eucm(k, 0.45, 0.9, p); }},
      {"eucm alpha 1", ExtendedUnified<double>(340, 1.0, 0.7), [](auto& k, auto& p) { return eucm(k, 1.0, 0.7, p); }},
      {"ds fold", DoubleSphere<double>(370, -0.18, 0.6),
       [](auto& k, auto& p) { return double_sphere(k, -0.18, 0.6, p); }},
      {"ds pole", DoubleSphere<double>(370, 0.1, 0.4), [](auto& k, auto& p) { return double_sphere(k, 0.1, 0.4, p); }},
      {"ds pole xi<0", DoubleSphere<double>(300, -0.3, 0.2),
       [](auto& k, auto& p) { return double_sphere(k, -0.3, 0.2, p); }},
      {"mei", Mei<double>(640, 0.9, -0.05, 0.01), [](auto& k, auto& p) { return mei(k, 0.9, -0.05, 0.01, p); }},
      {"mei fold", Mei<double>(900, 1.2, -0.3, 0.0), [](auto& k, auto& p) { return mei(k, 1.2, -0.3, 0.0, p); }},
  };
}

CameraParameters camera_of(const RadialModel& model) {
  CameraParameters p = test::woodscape_front();
  p.model = model;
  p.grid.pixel_scale = {1.0, 1.003};
  return p;
}

// Projection against the published 3D formulas over the whole valid domain (off
// the pole by 1e-3 rad, radii up to 1e5 px), at distances 0.3 to 50: to 1e-9 px.
TEST(UnifiedFamily, ProjectionMatchesThePublishedFormulas) {
  for (const auto& c : cases()) {
    const Camera camera(camera_of(c.model));
    const auto& d = camera.domain();
    const double f = model_params(c.model)[0];
    const Intrinsics k{f, f * 1.003, camera.principal_point().x(), camera.principal_point().y()};
    const double theta_max = d.closed ? d.theta_max : d.theta_max - 1e-3;
    double worst = 0;
    int n = 0;
    for (const Eigen::Vector3d& ray : test::random_rays(20000, theta_max, 5)) {
      const Eigen::Vector3d p = ray * (0.3 + 49.7 * (n++ % 97) / 96.0);
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.project(p, &pixel)) << c.name;
      const Eigen::Vector2d expected = c.reference(k, p);
      const double radius = (expected - camera.principal_point()).norm();
      if (radius > 1e5) continue;  // next to a pole both formulas are ill-conditioned
      // Next to a pole the reference's own xi |P| + z cancels: 1e-12 of the radius there.
      worst = std::max(worst, (pixel - expected).norm() / (1 + 1e-3 * radius));
    }
    EXPECT_LE(worst, 1e-9) << c.name;
  }
}

// A model without its closed-form inverse: solve_theta takes the bracketed solver.
template <class Model>
struct Iterative {
  Model model;
  static constexpr std::string_view kName = Model::kName;
  double rho(double t) const { return model.rho(t); }
  double drho(double t) const { return model.drho(t); }
};

TEST(UnifiedFamily, ClosedFormInverseAgreesWithTheBracketedSolver) {
  for (const auto& c : cases()) {
    const Camera camera(camera_of(c.model));
    const auto& d = camera.domain();
    std::visit(
        [&](const auto& m) {
          const Iterative<std::decay_t<decltype(m)>> iterative{m};
          // Radii up to 1e5 px (an image 200000 px across).
          const double top = d.closed ? d.rho_max : std::min(1e5, m.rho(d.theta_max - 1e-3));
          double worst = 0;
          for (int i = 0; i <= 4000; ++i) {
            const double rho = top * i / 4000.0;
            const double closed = camera.theta_from_rho(rho), solved = solve_theta(iterative, rho, d);
            // In rho (px): the bracketed solver's own tolerance is 1e-10 px.
            const double e = std::max(std::abs(m.rho(closed) - rho), std::abs(m.rho(solved) - rho));
            worst = std::max(worst, e / (1 + 1e-2 * rho));  // 1e-12 relative at large radii
            ASSERT_TRUE(std::isfinite(closed)) << c.name << " rho " << rho;
          }
          EXPECT_LE(worst, 1e-10) << c.name;
        },
        c.model);
  }
}

// The closed-form limits: a closed limit is where the generic fold search finds
// rho' = 0 (searching past it), an open one is a pole (rho grows without bound).
TEST(UnifiedFamily, ClosedFormDomainsAgreeWithTheGenericFoldSearch) {
  for (const auto& c : cases()) {
    std::visit(
        [&](const auto& m) {
          const double limit = m.theta_limit();
          if (!m.limit_is_open()) {
            const auto fold = first_fold(m, std::min(std::numbers::pi, limit + 0.3));
            ASSERT_TRUE(fold.has_value()) << c.name;
            EXPECT_NEAR(*fold, limit, 1e-9) << c.name;
            EXPECT_LE(std::abs(m.drho(limit)), 1e-6 * m.drho(0.0)) << c.name;
          } else {
            EXPECT_FALSE(first_fold(m, limit).has_value()) << c.name;
            EXPECT_GT(m.rho(limit - 1e-9), 1e6 * m.drho(0.0)) << c.name << ": a pole";
          }
          const Camera camera(camera_of(c.model));
          EXPECT_EQ(camera.domain().theta_max, limit) << c.name;
        },
        c.model);
  }
}

TEST(UnifiedFamily, SpecialCasesAreTheClassicalModels) {
  for (double theta : {0.1, 0.8, 1.4, 2.0, 3.0}) {
    // xi = 1: stereographic with f = 2 f_s; EUCM beta = 1: unified in alpha form;
    // DS xi = 0: EUCM with beta = 1; xi = 0, alpha = 0: pinhole.
    EXPECT_NEAR(Unified<double>(660, 1).rho(theta), Stereographic<double>(330).rho(theta),
                1e-12 * Stereographic<double>(330).rho(theta));
    const double alpha = 0.3, xi = alpha / (1 - alpha);
    EXPECT_NEAR(ExtendedUnified<double>(400, alpha, 1).rho(theta), Unified<double>(400 / (1 - alpha), xi).rho(theta),
                1e-12 * std::abs(Unified<double>(400 / (1 - alpha), xi).rho(theta)));
    EXPECT_NEAR(DoubleSphere<double>(400, 0, 0.6).rho(theta), ExtendedUnified<double>(400, 0.6, 1).rho(theta), 1e-9);
    EXPECT_NEAR(Mei<double>(500, 0.8, 0, 0).rho(theta), Unified<double>(500, 0.8).rho(theta), 1e-9);
  }
  EXPECT_NEAR(DoubleSphere<double>(400, 0, 0).rho(0.7), Pinhole<double>(400).rho(0.7), 1e-12);
  EXPECT_DOUBLE_EQ(ExtendedUnified<double>(1, 0, 1).theta_limit(), std::numbers::pi / 2);
}

TEST(UnifiedFamily, OutOfRangeParametersAreRefusedNamingTheParameter) {
  const std::vector<std::pair<std::pair<std::string, std::vector<double>>, std::string>> bad = {
      {{"unified", {500, -0.1}}, "unified: xi must be >= 0"},
      {{"extended-unified", {500, 1.2, 1}}, "extended-unified: alpha must be in [0, 1]"},
      {{"extended-unified", {500, 0.5, 0}}, "extended-unified: beta must be > 0"},
      {{"double-sphere", {500, 1.0, 0.5}}, "double-sphere: xi must be in (-1, 1)"},
      {{"double-sphere", {500, 0.1, -0.5}}, "double-sphere: alpha must be in [0, 1]"},
      {{"mei", {500, -1, 0, 0}}, "mei: xi must be >= 0"},
      {{"mei", {500, 1, 0}}, "mei: expected 4 parameter(s) (f, xi, k1, k2), got 3"},
      {{"unified", {500, NAN}}, "unified: xi is not finite"},
      {{"omni", {500, 1}}, "unknown model 'omni'"},
  };
  for (const auto& [input, expected] : bad) {
    try {
      make_model(input.first, input.second);
      ADD_FAILURE() << input.first << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
}

// Every registry name resolves to its class and back; the help text lists them all.
TEST(ModelRegistry, NamesRoundTripAndUnknownNamesThrow) {
  for (std::string_view name : model_names()) {
    const std::string_view back =
        with_model_class(name, []<template <typename> class M>() { return M<double>::kName; });
    EXPECT_EQ(back, name);
    EXPECT_NE(model_names_text().find(name), std::string::npos);
  }
  EXPECT_THROW(with_model_class("pinhole2", []<template <typename> class M>() { return 0; }), Error);
  EXPECT_EQ(model_names().size(), ModelRegistry::kSize);
}

}  // namespace
}  // namespace fishcam
