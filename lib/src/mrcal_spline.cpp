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
    throw Error("spline: '" + lensmodel_.substr(0, 80) +
                "' is not a configured LENSMODEL_SPLINED_STEREOGRAPHIC_order=O_Nx=X_Ny=Y_fov_x_deg=F");
  }
  const int count = mrcal_lensmodel_num_params(&parsed_->model) - 4;
  if (int(values_.size()) != count) {
    throw Error("spline: " + lensmodel_ + " has " + std::to_string(count) + " control values, got " +
                std::to_string(values_.size()));
  }
  for (double v : values_) {
    if (!std::isfinite(v)) throw Error("spline: control values must be finite");
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

}  // namespace fishcam
