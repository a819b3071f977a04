// What the Ceres-based fits share: models built from parameter blocks (double or
// Jet), the solve settings, and the dispatch from a model name to its class.
#pragma once

#include <ceres/ceres.h>
#include <glog/logging.h>

#include <mutex>

#include <string>
#include <type_traits>

#include "fishcam/core/camera.hpp"

namespace fishcam::detail {

// The model of parameter block p (params values: their count).
template <template <typename> class Model, typename T>
Model<T> model_from_block(const T* p, int params) {
  return Model<T>(p, params);
}

// The bounds of the non-linear models' parameters (alpha in [0, 1], ...), so the
// solver never leaves the model's valid range.
template <template <typename> class Model>
void bound_model_block(ceres::Problem* problem, double* block, int params) {
  if constexpr (requires { Model<double>::param_bounds(0); }) {
    for (int i = 0; i < params; ++i) {
      const auto [lo, hi] = Model<double>::param_bounds(i);
      if (std::isfinite(lo)) problem->SetParameterLowerBound(block, i, lo);
      if (std::isfinite(hi)) problem->SetParameterUpperBound(block, i, hi);
    }
  }
}

// Tight tolerances (the fits are checked to 1e-6 relative), silent, one thread.
// Ceres reports through glog, whose warnings and errors go to standard error raw (a
// near-degenerate problem printed ~40 lines): fishcam turns what they mean into its
// own one-line errors and warnings, so below FATAL glog stays quiet in this process.
inline void quiet_ceres_logging() {
  static std::once_flag once;
  std::call_once(once, [] { FLAGS_minloglevel = google::GLOG_FATAL; });
}

inline ceres::Solver::Options solver_options(ceres::LinearSolverType linear_solver) {
  quiet_ceres_logging();
  ceres::Solver::Options options;
  options.linear_solver_type = linear_solver;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-15;
  options.parameter_tolerance = 1e-15;
  options.gradient_tolerance = 1e-15;
  // One thread: Ceres sums costs and gradients per thread, so more threads change
  // the last bits of a result with the machine's thread scheduling.
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  return options;
}

}  // namespace fishcam::detail
