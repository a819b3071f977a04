#include "fishcam/core/plane_distortion.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>

#include "fishcam/core/error.hpp"
#include "fishcam/core/model_registry.hpp"
#include "fishcam/core/stderr_capture.hpp"

namespace fishcam {

namespace {

template <class Part>
void expect_no_configuration(std::string_view configuration) {
  if (!configuration.empty()) {
    throw Error(std::string(Part::kName) + ": takes no configuration, got " + quoted_for_message(configuration));
  }
}

}  // namespace

NoPlaneDistortion NoPlaneDistortion::from_numbers(std::string_view configuration, std::vector<double> values) {
  expect_no_configuration<NoPlaneDistortion>(configuration);
  if (!values.empty()) throw Error("none: takes no values, got " + std::to_string(values.size()));
  return {};
}

std::vector<std::string> NoPlaneDistortion::base_models() const {
  std::vector<std::string> names;
  for (std::string_view name : model_names()) names.emplace_back(name);
  return names;
}

std::vector<double> TangentialDistortion::values() const {
  const auto v = terms.values();
  return {v.begin(), v.end()};
}

std::vector<std::string> TangentialDistortion::parameter_names() const {
  return {TangentialTerms::kNames.begin(), TangentialTerms::kNames.end()};
}

TangentialDistortion TangentialDistortion::from_numbers(std::string_view configuration, std::vector<double> values) {
  expect_no_configuration<TangentialDistortion>(configuration);
  if (values.size() != TangentialTerms::kNames.size()) {
    throw Error("tangential: expected 6 values (p1, p2, s1, s2, s3, s4), got " + std::to_string(values.size()));
  }
  std::array<double, 6> v;
  std::copy(values.begin(), values.end(), v.begin());
  return {TangentialTerms::from_values(v)};
}

std::vector<std::string> TangentialDistortion::base_models() const {
  std::vector<std::string> names;
  ModelRegistry::for_each([&]<template <typename> class Model>() {
    if constexpr (TakesTangentialTerms<Model<double>>) names.emplace_back(Model<double>::kName);
  });
  return names;
}

std::string TangentialDistortion::invalid() const {
  for (size_t i = 0; i < TangentialTerms::kNames.size(); ++i) {
    if (!std::isfinite(terms.values()[i])) return std::string(TangentialTerms::kNames[i]) + ": must be finite";
  }
  return "";
}

std::vector<std::string> MrcalLensDistortion::parameter_names() const {
  std::vector<std::string> names;
  for (size_t i = 0; i < values().size(); ++i) names.push_back("values[" + std::to_string(i) + "]");
  return names;
}

namespace {

// Evaluates the lens at `azimuths` points of the ring of plane radius u (under the
// caller's capture of what libmrcal says); false when one of them has no offset.
bool lens_finite_on_ring(const MrcalLens& lens, double u, int azimuths) {
  bool finite = true;
  for (int k = 0; k < azimuths; ++k) {
    const double phi = 2 * std::numbers::pi * k / azimuths;
    finite = lens.offset(u * Eigen::Vector2d(std::cos(phi), std::sin(phi))).allFinite() && finite;
  }
  return finite;
}

}  // namespace

// The largest theta at most theta_max (by steps up to 1 % inside) on whose ring, and
// on a ring just past it (Newton's steps and CAHVORE's central differences reach
// there), libmrcal evaluates at 1440 azimuths without a word. CAHVORE's own iteration
// fails at and past its fold, which the fold scan finds to a few ulps.
std::optional<double> MrcalLensDistortion::evaluation_end(const PlaneRadius& radius, double theta_max) const {
  for (double inside : {0.0, 1e-6, 1e-5, 1e-4, 1e-3, 3e-3, 1e-2}) {
    const double theta = theta_max * (1 - inside);
    const double u = radius(theta);
    detail::StderrCapture libmrcal;
    const bool evaluates =
        lens_finite_on_ring(*lens, u, 1440) && lens_finite_on_ring(*lens, u * (1 + 1e-9) + 2e-5 * (1 + u), 1440);
    if (evaluates && libmrcal.summary().empty()) return theta;
  }
  return std::nullopt;
}

// The domain's rays, 64 rings by 360 azimuths up to theta_max: libmrcal must evaluate
// each without a complaint on standard error (a projection whose own iteration failed
// cannot be right).
std::string MrcalLensDistortion::evaluation_problem(const PlaneRadius& radius, double theta_max) const {
  detail::StderrCapture libmrcal;
  for (int ring = 1; ring <= 64; ++ring)
    (void)lens_finite_on_ring(*lens, radius(theta_max * (1 - 1e-9) * ring / 64), 360);
  const std::string said = libmrcal.summary();
  return said.empty() ? "" : "it said: " + quoted_for_message(said, 200);
}

std::vector<std::string> MrcalLensDistortion::base_models() const {
  if (!lens) return {};
  return {lens->base_model()};
}

MrcalLensDistortion MrcalLensDistortion::from_numbers(std::string_view configuration, std::vector<double> values) {
  return {std::make_shared<const MrcalLens>(std::string(configuration), std::move(values))};
}

const std::vector<std::string_view>& plane_distortion_names() {
  static const std::vector<std::string_view> names = [] {
    std::vector<std::string_view> list;
    PlaneDistortionRegistry::for_each([&]<class Part>() { list.push_back(Part::kName); });
    return list;
  }();
  return names;
}

std::string_view distortion_name(const PlaneDistortion& distortion) {
  return std::visit([](const auto& part) { return std::decay_t<decltype(part)>::kName; }, distortion);
}

bool displaces(const PlaneDistortion& distortion) {
  return std::visit([](const auto& part) { return part.any(); }, distortion);
}

PlaneDistortionNumbers numbers_of(const PlaneDistortion& distortion) {
  if (!displaces(distortion)) return {std::string(NoPlaneDistortion::kName), "", {}};
  return std::visit(
      [](const auto& part) {
        return PlaneDistortionNumbers{std::string(std::decay_t<decltype(part)>::kName), part.configuration(),
                                      part.values()};
      },
      distortion);
}

PlaneDistortion make_plane_distortion(std::string_view name, std::string_view configuration,
                                      std::vector<double> values) {
  std::optional<PlaneDistortion> made;
  PlaneDistortionRegistry::for_each([&]<class Part>() {
    if (!made && name == Part::kName) made = Part::from_numbers(configuration, std::move(values));
  });
  if (!made) {
    std::string known;
    for (std::string_view n : plane_distortion_names()) known += (known.empty() ? "" : ", ") + std::string(n);
    throw Error("distortion: unknown plane distortion " + quoted_for_message(name) + " (" + known + ")");
  }
  return *made;
}

bool same_distortion(const PlaneDistortion& a, const PlaneDistortion& b) { return numbers_of(a) == numbers_of(b); }

}  // namespace fishcam
