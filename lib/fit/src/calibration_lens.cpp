// Calibrating an mrcal lens's values (ModelSpec::mrcal_lens): the corner residual
// through libmrcal's projection and gradients, and mrcal's regularisation.
#include <cmath>

#include "calibration_internal.hpp"

namespace fishcam::detail {

LensCornerCost::LensCornerCost(const MrcalLens* lens, const Eigen::Vector3d& point, const Eigen::Vector2d& corner,
                               std::optional<Eigen::Vector2d> warp)
    : lens_(lens), point_(point), corner_(corner), warp_(warp) {
  set_num_residuals(2);
  std::vector<int> sizes = {1, int(lens->values().size()), 2, 1, 6};
  if (warp) sizes.push_back(2);
  *mutable_parameter_block_sizes() = sizes;
}

bool LensCornerCost::Evaluate(double const* const* p, double* residuals, double** jacobians) const {
  Eigen::Vector3d point, rotated;
  warped_point(point_, warp_, warp_ ? p[5] : nullptr, point.data());
  ceres::AngleAxisRotatePoint(p[4], point.data(), rotated.data());
  const Eigen::Vector3d q = rotated + Eigen::Vector3d(p[4][3], p[4][4], p[4][5]);
  const bool warp_wanted = jacobians && warp_ && jacobians[5];
  const bool point_wanted = jacobians && (jacobians[4] || warp_wanted);
  Eigen::Matrix<double, 2, 3> d_point;
  const Eigen::Vector2d d =
      lens_->project_with_values(q, p[1], point_wanted ? &d_point : nullptr, jacobians ? jacobians[1] : nullptr);
  if (!d.allFinite()) return false;
  const double f = p[0][0], ay = p[3][0];
  residuals[0] = p[2][0] + f * d.x() - corner_.x();
  residuals[1] = p[2][1] + ay * f * d.y() - corner_.y();
  if (!jacobians) return true;
  if (jacobians[0]) jacobians[0][0] = d.x(), jacobians[0][1] = ay * d.y();
  if (jacobians[1]) {
    const size_t count = lens_->values().size();
    for (size_t i = 0; i < count; ++i) jacobians[1][i] *= f, jacobians[1][count + i] *= ay * f;
  }
  if (jacobians[2]) jacobians[2][0] = 1, jacobians[2][1] = 0, jacobians[2][2] = 0, jacobians[2][3] = 1;
  if (jacobians[3]) jacobians[3][0] = 0, jacobians[3][1] = f * d.y();
  if (point_wanted) {
    const Eigen::Matrix<double, 2, 3> dpixel = Eigen::Vector2d(f, ay * f).asDiagonal() * d_point;
    board_jacobians(dpixel, rotated, p[4], warp_, jacobians[4], warp_wanted ? jacobians[5] : nullptr);
  }
  return true;
}

LensRegularisation::LensRegularisation(const MrcalLens& lens, long corners) {
  const std::optional<MrcalLens::PolynomialCells> cells = lens.polynomial_cells();
  if (!cells) throw Error("calibrate: " + lens.lensmodel() + " has no regularisation (only splines are calibrated)");
  // The knots' count from the cells (order 3: N - 3 cells, order 2: N - 2).
  const int nx = cells->order == 3 ? cells->nx + 3 : cells->nx + 2;
  const int ny = cells->order == 3 ? cells->ny + 3 : cells->ny + 2;
  const Eigen::Index count = Eigen::Index(lens.values().size());
  if (count != 2 * Eigen::Index(nx) * ny)
    throw Error("calibrate: internal error: the spline's knots and values differ");
  // scale^2 = the corners' expected cost (2 per corner at 1 px) * 0.005 / 2 kinds of
  // regularisation / (its residuals * its nominal size^2), as mrcal 2.2.
  const double scale = std::sqrt(2.0 * double(corners) * 0.005 / 2 / (double(count) * 0.2 * 0.2));
  a_ = Eigen::MatrixXd::Zero(count, count);
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      const Eigen::Index at = 2 * (Eigen::Index(iy) * nx + ix);
      Eigen::Vector2d radial(2 * ix - nx + 1, 2 * iy - ny + 1);
      const bool centre = radial.isZero();  // the middle knot (odd Nx and Ny): no direction
      radial = centre ? Eigen::Vector2d(1, 0) : radial.normalized();
      const double across = centre ? scale : 10 * scale;
      a_(at, at) = scale * radial.x(), a_(at, at + 1) = scale * radial.y();
      a_(at + 1, at) = across * radial.y(), a_(at + 1, at + 1) = -across * radial.x();
    }
  }
  set_num_residuals(int(count));
  *mutable_parameter_block_sizes() = {int(count)};
}

bool LensRegularisation::Evaluate(double const* const* p, double* residuals, double** jacobians) const {
  const Eigen::Index count = a_.cols();
  Eigen::Map<Eigen::VectorXd>(residuals, count) = a_ * Eigen::Map<const Eigen::VectorXd>(p[0], count);
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  if (jacobians && jacobians[0]) Eigen::Map<RowMajor>(jacobians[0], count, count) = a_;
  return true;
}

}  // namespace fishcam::detail
