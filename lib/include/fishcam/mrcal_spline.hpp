// mrcal's splined surface (LENSMODEL_SPLINED_STEREOGRAPHIC_order=..._Nx=..._Ny=..._fov_x_deg=...)
// as a displacement on the stereographic plane: with u = 2 tan(theta / 2) (X, Y) / chi,
//   pixel = c + a (.) f (u + delta_u(u)),
// delta_u being mrcal's spline of u (its 2 Nx Ny control values). The camera's model is
// `stereographic` (rho = 2 f tan(theta / 2)); this is its non-radial part, evaluated
// by libmrcal itself (mrcal_project), so it is mrcal's projection exactly. Outside the
// knots mrcal extrapolates the last spline segment; Camera's valid domain stops where
// the map stops being one-to-one (docs/conventions.md).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

namespace fishcam {

class MrcalSpline {
 public:
  // Throws Error unless lensmodel names a splined model mrcal knows and values holds
  // exactly its 2 Nx Ny finite control values.
  MrcalSpline(std::string lensmodel, std::vector<double> values);
  ~MrcalSpline();
  MrcalSpline(const MrcalSpline&) = delete;
  MrcalSpline& operator=(const MrcalSpline&) = delete;

  const std::string& lensmodel() const { return lensmodel_; }
  const std::vector<double>& values() const { return values_; }  // mrcal's intrinsics after fx, fy, cx, cy
  bool operator==(const MrcalSpline& other) const {
    return lensmodel_ == other.lensmodel_ && values_ == other.values_;
  }

  // delta_u(m) on the stereographic plane, with d delta_u / dm on request.
  Eigen::Vector2d offset(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian = nullptr) const;

  // Where mrcal's spline is one polynomial: in cell coordinates g = m * cells_per_u + origin
  // it is a polynomial of degree `order` in each of g_x, g_y on every unit cell
  // [i, i + 1) x [j, j + 1), 0 <= i < nx, 0 <= j < ny (cubic segments lie between knots,
  // quadratic ones are centred on them); past the outer cells mrcal extrapolates the
  // outer cells' polynomials (it clamps the segment index).
  struct PolynomialCells {
    double cells_per_u = 0;
    Eigen::Vector2d origin = Eigen::Vector2d::Zero();
    int nx = 0, ny = 0, order = 0;
  };
  PolynomialCells polynomial_cells() const;

 private:
  struct Lensmodel;  // mrcal_lensmodel_t (mrcal's headers stay in the .cpp)
  std::string lensmodel_;
  std::vector<double> values_;
  std::vector<double> intrinsics_;  // fx = fy = 1, cx = cy = 0, then values_
  std::unique_ptr<Lensmodel> parsed_;
};

}  // namespace fishcam
