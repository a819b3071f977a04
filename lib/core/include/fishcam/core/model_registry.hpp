// The one list of radial models. Everything that depends on "which models exist"
// follows from ModelRegistry below: the RadialModel variant, name <-> class lookup
// (unknown names throw, never another model's formula), parameter names and
// checks, the Ceres dispatch of fitting and calibration, their starting points,
// the float warp kernel's form, the CLI's help texts and the every-model tests.
//
// How to add a radial model (docs/conventions.md has the conventions):
//   1. Write one class in its own header, models/NAME.hpp (included by
//      radial_models.hpp, which lists every member), templated on the scalar: kName,
//      kParamNames, rho, drho, theta_limit/limit_is_open (its exact valid domain),
//      invalid(), scaled(), params(), initial_params(); plus theta_from_rho if it
//      has a closed-form inverse, basis/from_basis if rho is linear in its
//      parameters (else fit_starts/param_bounds for the non-linear fit), and
//      unified_form() or power_coefficients() if the float warp kernel can
//      evaluate it (else warps take the exact path).
//   2. Add it to ModelRegistry below: one line.
//   3. Give it example parameters in lib/testing/include/fishcam/testing/test_support.hpp (model_examples()):
//      the every-model tests fail until it has them.
//   4. Document its formula, parameters and valid domain in docs/conventions.md,
//      and teach the file formats that can hold it (lib/io/src/formats/).
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "fishcam/core/error.hpp"
#include "fishcam/core/radial_models.hpp"

namespace fishcam {

template <template <typename> class... Models>
struct ModelList {
  using Variant = std::variant<Models<double>...>;
  static constexpr size_t kSize = sizeof...(Models);

  // f.template operator()<Model>() for every model, in registry order.
  template <class F>
  static void for_each(F&& f) {
    (f.template operator()<Models>(), ...);
  }
};

using ModelRegistry = ModelList<Polynomial,       //
                                Equidistant,      //
                                Stereographic,    //
                                Pinhole,          //
                                KannalaBrandt,    //
                                Unified,          //
                                ExtendedUnified,  //
                                DoubleSphere,     //
                                Mei,              //
                                OpenCV,           //
                                OCam>;

using RadialModel = ModelRegistry::Variant;

// Model names in registry order.
std::vector<std::string_view> model_names();
// "polynomial[:N], equidistant, ..." for help texts and messages.
std::string model_names_text();
// Throws Error("unknown model 'NAME' (expected ...)") for a name not in the registry.
void check_model_name(std::string_view name);

namespace detail {
template <template <typename> class First, template <typename> class... Rest, class F>
decltype(auto) dispatch_model(std::string_view name, F&& f) {
  if (name == First<double>::kName) return f.template operator()<First>();
  if constexpr (sizeof...(Rest) > 0) {
    return dispatch_model<Rest...>(name, std::forward<F>(f));
  } else {
    check_model_name(name);                 // throws: not a model
    return f.template operator()<First>();  // unreachable
  }
}
template <template <typename> class... Models, class F>
decltype(auto) dispatch_list(ModelList<Models...>*, std::string_view name, F&& f) {
  return dispatch_model<Models...>(name, std::forward<F>(f));
}
}  // namespace detail

// f.template operator()<Model>() for the model class named `name`; throws Error
// for any other name.
template <class F>
decltype(auto) with_model_class(std::string_view name, F&& f) {
  return detail::dispatch_list(static_cast<ModelRegistry*>(nullptr), name, std::forward<F>(f));
}

// Model traits generic code asks instead of testing names (models/model_base.hpp).
template <template <typename> class Model>
constexpr bool has_paper_form = requires {
  Model<double>::from_paper(1.0, 1.0);
};
template <template <typename> class Model>
constexpr bool takes_order = requires {
  Model<double>::kTakesOrder;
};
// Whether the model called `name` has the paper's closed form (eqs. 13-14);
// throws Error for an unknown name.
bool model_has_paper_form(std::string_view name);

std::string_view model_name(const RadialModel& model);
std::vector<double> model_params(const RadialModel& model);
// The names of a model's parameters, in params() order ("k1".."kN" for polynomial).
std::vector<std::string> model_param_names(const RadialModel& model);
std::vector<std::string> model_param_names(std::string_view name, int count);
// A model from its name and parameters (in the order params() documents); throws
// Error naming what is wrong: unknown name, parameter count, a non-finite value,
// or a value outside the model's range ("unified: xi must be >= 0").
RadialModel make_model(std::string_view name, std::span<const double> params);

}  // namespace fishcam
