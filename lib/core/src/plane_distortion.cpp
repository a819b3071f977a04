#include "fishcam/core/plane_distortion.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include "fishcam/core/error.hpp"
#include "fishcam/core/model_registry.hpp"

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
