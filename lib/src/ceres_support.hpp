// What the Ceres-based fits share: models built from parameter blocks (double or
// Jet), the solve settings, and the dispatch from a model name to its class.
#pragma once

#include <ceres/ceres.h>

#include <string>
#include <type_traits>

#include "fishcam/camera.hpp"

namespace fishcam::detail {

// The model of parameter block p (params values: the polynomial's order).
template <template <typename> class Model, typename T>
Model<T> model_from_block(const T* p, int params) {
  if constexpr (std::is_same_v<Model<T>, Polynomial<T>>) {
    return Polynomial<T>(p, params);
  } else if constexpr (std::is_same_v<Model<T>, KannalaBrandt<T>>) {
    return KannalaBrandt<T>(p);
  } else {
    return Model<T>(p[0]);
  }
}

// Tight tolerances (the fits are checked to 1e-6 relative), silent, two threads.
inline ceres::Solver::Options solver_options(ceres::LinearSolverType linear_solver) {
  ceres::Solver::Options options;
  options.linear_solver_type = linear_solver;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-15;
  options.parameter_tolerance = 1e-15;
  options.gradient_tolerance = 1e-15;
  options.num_threads = 2;
  options.logging_type = ceres::SILENT;
  return options;
}

// Calls f.template operator()<Model>() for the model class named `name`
// (a name parse_model_spec accepted); throws Error for any other name.
template <class F>
decltype(auto) with_model_class(const std::string& name, F&& f) {
  if (name == "polynomial") return f.template operator()<Polynomial>();
  if (name == "kannala-brandt") return f.template operator()<KannalaBrandt>();
  if (name == "equidistant") return f.template operator()<Equidistant>();
  if (name == "stereographic") return f.template operator()<Stereographic>();
  if (name == "pinhole") return f.template operator()<Pinhole>();
  throw Error("unknown model '" + name + "'");  // never another model's formula
}

}  // namespace fishcam::detail
