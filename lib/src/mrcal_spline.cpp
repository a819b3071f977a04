#include "fishcam/mrcal_spline.hpp"

#include <cmath>

#include "fishcam/error.hpp"

extern "C" {  // mrcal 2.2's headers have no extern "C" of their own
#include <mrcal/mrcal.h>
}

namespace fishcam {

struct MrcalSpline::Lensmodel {
  mrcal_lensmodel_t model;
};

MrcalSpline::MrcalSpline(std::string lensmodel, std::vector<double> values)
    : lensmodel_(std::move(lensmodel)), values_(std::move(values)), parsed_(std::make_unique<Lensmodel>()) {
  if (lensmodel_.rfind("LENSMODEL_SPLINED_STEREOGRAPHIC", 0) != 0 ||
      !mrcal_lensmodel_from_name(&parsed_->model, lensmodel_.c_str()) ||
      parsed_->model.type != MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC) {
    throw Error("'" + lensmodel_.substr(0, 80) +
                "' is not a configured LENSMODEL_SPLINED_STEREOGRAPHIC_order=O_Nx=X_Ny=Y_fov_x_deg=F");
  }
  // libmrcal asserts (aborts) on configurations it does not support, and parses its
  // integers as uint16 (wrapping): checked here, and the name must be what mrcal
  // itself writes for the configuration it parsed.
  const auto& config = parsed_->model.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
  char canonical[256];
  if (!mrcal_lensmodel_name(canonical, sizeof canonical, &parsed_->model) || lensmodel_ != canonical) {
    throw Error("'" + lensmodel_.substr(0, 80) + "' is not written as mrcal writes its configuration");
  }
  if (config.order != 2 && config.order != 3) throw Error("order must be 2 or 3 (mrcal's splines)");
  if (config.Nx < 4 || config.Ny < 4 || config.Nx > 200 || config.Ny > 200) {
    throw Error("Nx and Ny must be in [4, 200]");
  }
  if (config.fov_x_deg < 1 || config.fov_x_deg > 359) throw Error("fov_x_deg must be in [1, 359]");
  const int count = mrcal_lensmodel_num_params(&parsed_->model) - 4;
  if (int(values_.size()) != count) {
    throw Error(lensmodel_ + " has " + std::to_string(count) + " control values, got " +
                std::to_string(values_.size()));
  }
  for (double v : values_) {
    if (!std::isfinite(v)) throw Error("the control values must be finite");
  }
  intrinsics_ = {1, 1, 0, 0};
  intrinsics_.insert(intrinsics_.end(), values_.begin(), values_.end());
}

MrcalSpline::~MrcalSpline() = default;

Eigen::Vector2d MrcalSpline::offset(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian) const {
  // The ray whose stereographic projection is m: (m, 1 - |m|^2 / 4) (any length).
  const mrcal_point3_t p = {{m.x(), m.y(), 1 - 0.25 * m.squaredNorm()}};
  mrcal_point2_t q;
  mrcal_point3_t dq_dp[2];
  if (!mrcal_project(&q, jacobian ? dq_dp : nullptr, nullptr, &p, 1, &parsed_->model, intrinsics_.data())) {
    throw Error("spline: libmrcal could not project through " + lensmodel_);
  }
  if (jacobian) {
    // dq/dm = dq/dp dp/dm, dp/dm = [1 0; 0 1; -m_x / 2  -m_y / 2]; delta_u = q - m.
    for (int r = 0; r < 2; ++r) {
      const double* g = dq_dp[r].xyz;
      (*jacobian)(r, 0) = g[0] - 0.5 * m.x() * g[2] - (r == 0);
      (*jacobian)(r, 1) = g[1] - 0.5 * m.y() * g[2] - (r == 1);
    }
  }
  return {q.x - m.x(), q.y - m.y()};
}

MrcalSpline::PolynomialCells MrcalSpline::polynomial_cells() const {
  const auto& config = parsed_->model.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
  std::vector<double> ux(config.Nx), uy(config.Ny);
  if (!mrcal_knots_for_splined_models(ux.data(), uy.data(), &parsed_->model)) {
    throw Error("spline: libmrcal gave no knots for " + lensmodel_);
  }
  // mrcal's segment coordinate is u * cells_per_u + (N - 1) / 2 (the knots' indices);
  // a cubic segment [i, i + 1] needs knots i - 1 .. i + 2 (i = 1 .. N - 3), a quadratic
  // one [i - 1/2, i + 1/2] knots i - 1 .. i + 1 (i = 1 .. N - 2).
  PolynomialCells cells;
  cells.order = config.order;
  cells.cells_per_u = 1 / (ux[1] - ux[0]);
  const double first = config.order == 3 ? 1 : 0.5;
  cells.origin = {0.5 * (config.Nx - 1) - first, 0.5 * (config.Ny - 1) - first};
  cells.nx = config.order == 3 ? config.Nx - 3 : config.Nx - 2;
  cells.ny = config.order == 3 ? config.Ny - 3 : config.Ny - 2;
  return cells;
}

}  // namespace fishcam
