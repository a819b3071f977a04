#include "fishcam/core/model_registry.hpp"

#include <cmath>
#include <sstream>

namespace fishcam {

std::vector<std::string_view> model_names() {
  std::vector<std::string_view> names;
  ModelRegistry::for_each([&]<template <typename> class Model>() { names.push_back(Model<double>::kName); });
  return names;
}

std::string model_names_text() {
  std::string text;
  for (std::string_view name : model_names()) {
    if (!text.empty()) text += ", ";
    text += name;
    if (name == Polynomial<double>::kName) text += "[:N]";
  }
  return text;
}

void check_model_name(std::string_view name) {
  for (std::string_view known : model_names()) {
    if (name == known) return;
  }
  throw Error("unknown model " + quoted_for_message(name) + " (expected one of: " + model_names_text() + ")");
}

std::string_view model_name(const RadialModel& model) {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kName; }, model);
}

std::vector<double> model_params(const RadialModel& model) {
  return std::visit(
      [](const auto& m) {
        const auto params = m.params();
        return std::vector<double>(params.begin(), params.end());
      },
      model);
}

std::vector<std::string> model_param_names(std::string_view name, int count) {
  return with_model_class(name, [&]<template <typename> class Model>() {
    std::vector<std::string> names;
    if constexpr (Model<double>::kParamNames.empty()) {  // k1..kN
      for (int i = 1; i <= count; ++i) {
        std::string name = "k";  // appended: GCC 12 warns falsely on "k" + to_string(i)
        name += std::to_string(i);
        names.push_back(name);
      }
    } else {
      for (std::string_view n : Model<double>::kParamNames) names.emplace_back(n);
    }
    return names;
  });
}

std::vector<std::string> model_param_names(const RadialModel& model) {
  return model_param_names(model_name(model), static_cast<int>(model_params(model).size()));
}

RadialModel make_model(std::string_view name, std::span<const double> params) {
  return with_model_class(name, [&]<template <typename> class Model>() -> RadialModel {
    const std::string prefix(name);
    constexpr size_t kFixed = Model<double>::kParamNames.size();
    if (kFixed != 0 && params.size() != kFixed) {
      std::ostringstream msg;
      msg << prefix << ": expected " << kFixed << " parameter(s) (";
      for (size_t i = 0; i < kFixed; ++i) msg << (i ? ", " : "") << Model<double>::kParamNames[i];
      msg << "), got " << params.size();
      throw Error(msg.str());
    }
    const std::vector<std::string> names = model_param_names(name, static_cast<int>(params.size()));
    for (size_t i = 0; i < params.size(); ++i) {
      if (!std::isfinite(params[i])) throw Error(prefix + ": " + names[i] + " is not finite");
    }
    if (params.empty()) throw Error(prefix + ": needs at least one parameter");
    Model<double> model(params.data(), static_cast<int>(params.size()));
    if (const std::string problem = model.invalid(); !problem.empty()) throw Error(prefix + ": " + problem);
    return model;
  });
}

bool model_has_paper_form(std::string_view name) {
  return with_model_class(name, []<template <typename> class Model>() { return has_paper_form<Model>; });
}

}  // namespace fishcam
