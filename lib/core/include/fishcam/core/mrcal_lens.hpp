// mrcal's lens models that are a displacement of a radial model's plane, evaluated by
// libmrcal itself (mrcal_project), so the projection is mrcal's exactly:
//   pixel = c + a (.) f (m + delta(m)),   delta(m) = D(m) - m,
// m being the base model's undistorted plane (u = 2 tan(theta / 2) along the azimuth
// for `stereographic`, tan(theta) for `pinhole`) and D mrcal's projection of the ray
// through m with fx = fy = 1, cx = cy = 0 and the model's own values after them.
//
//   mrcal lens model                                  base model     values
//   LENSMODEL_SPLINED_STEREOGRAPHIC_order=O_Nx=X_Ny=Y_fov_x_deg=F
//                                                     stereographic  2 X Y control values
//   LENSMODEL_CAHVOR                                  pinhole        alpha, beta, r0, r1, r2
//   LENSMODEL_CAHVORE_linearity=L                     stereographic  alpha, beta, r0, r1, r2, e0, e1, e2
//   LENSMODEL_LONLAT  (lon, lat)                      stereographic  none
//   LENSMODEL_LATLON  (lat, lon)                      stereographic  none
//
// CAHVORE is noncentral by definition (its E terms move the entrance pupil with the
// angle), but libmrcal's projection of it depends on the direction only, and that is
// what fishcam evaluates; libmrcal has no gradients for it: its Jacobian here is a
// central difference of libmrcal's projection (relative error ~1e-10). It rides on the
// stereographic plane: its E terms make it a fisheye (linearity > 0) that reaches
// 90 degrees, where the pinhole plane is singular.
// Camera's valid domain stops where the map stops being one-to-one (docs/conventions.md):
// for LONLAT and LATLON at their poles (theta = 90 degrees).
#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace fishcam {

class MrcalLens {
 public:
  // The largest |value| a lens may have (refused past it: no lens is that strong).
  static constexpr double kMaxValue = 1e3;
  enum class Kind { splined_stereographic, cahvor, cahvore, lonlat, latlon };
  struct KindInfo {
    Kind kind;
    const char* lensmodel;      // mrcal's name, or its prefix for a configured one
    const char* configuration;  // what follows the prefix ("" for none), for messages
    const char* base_model;     // the fishcam model whose plane it displaces (model_name)
  };
  // Every lens model this class evaluates: the one list readers, messages and tests use.
  static const std::array<KindInfo, 5>& kinds();
  // Whether the name is one of kinds() (its configuration unchecked).
  static bool names_a_kind(const std::string& lensmodel);
  // "LENSMODEL_SPLINED_STEREOGRAPHIC_..., LENSMODEL_CAHVOR, ..." for messages.
  static std::string kind_names();

  // Throws Error unless lensmodel is one of kinds(), written as mrcal writes it, and
  // values holds exactly its finite values (mrcal's intrinsics after fx, fy, cx, cy).
  MrcalLens(std::string lensmodel, std::vector<double> values);
  // The lens with all its values 0 (the base model's projection for a spline), as a
  // calibration starts; throws Error as the constructor does.
  static std::shared_ptr<const MrcalLens> with_zero_values(const std::string& lensmodel);
  ~MrcalLens();
  MrcalLens(const MrcalLens&) = delete;
  MrcalLens& operator=(const MrcalLens&) = delete;

  const std::string& lensmodel() const { return lensmodel_; }
  const std::vector<double>& values() const { return values_; }
  Kind kind() const { return kind_; }
  const char* base_model() const;
  bool operator==(const MrcalLens& other) const { return lensmodel_ == other.lensmodel_ && values_ == other.values_; }

  // delta(m) on the base model's plane, with d delta / dm on request; NaN where libmrcal
  // gives no projection (and behind the camera for a model mrcal cannot project there:
  // CAHVOR(E)), so the valid domain stops there.
  Eigen::Vector2d offset(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian = nullptr) const;

  // For calibrating a lens's values (splined_stereographic and cahvor, whose gradients
  // libmrcal gives): D(p) = m + delta(m) for a camera-frame point p (any length) and
  // `values` in place of values() (as many), i.e. mrcal_project with fx = fy = 1,
  // cx = cy = 0. On request dD/dp (2 x 3) and dD/dvalues (2 x values, row-major).
  // NaN where libmrcal gives no projection (as offset). Throws Error for the other
  // kinds or a wrong count.
  Eigen::Vector2d project_with_values(const Eigen::Vector3d& point, const double* values,
                                      Eigen::Matrix<double, 2, 3>* d_point = nullptr, double* d_values = nullptr) const;

  // Where mrcal's spline is one polynomial: in cell coordinates g = m * cells_per_u + origin
  // it is a polynomial of degree `order` in each of g_x, g_y on every unit cell
  // [i, i + 1) x [j, j + 1), 0 <= i < nx, 0 <= j < ny (cubic segments lie between knots,
  // quadratic ones are centred on them); past the outer cells mrcal extrapolates the
  // outer cells' polynomials (it clamps the segment index). nullopt for the other kinds.
  struct PolynomialCells {
    double cells_per_u = 0;
    Eigen::Vector2d origin = Eigen::Vector2d::Zero();
    int nx = 0, ny = 0, order = 0;
  };
  std::optional<PolynomialCells> polynomial_cells() const;

 private:
  struct Lensmodel;  // mrcal_lensmodel_t (mrcal's headers stay in the .cpp)
  std::string lensmodel_;
  std::vector<double> values_;
  Kind kind_ = Kind::splined_stereographic;
  std::vector<double> intrinsics_;  // fx = fy = 1, cx = cy = 0, then values_
  std::unique_ptr<Lensmodel> parsed_;
};

}  // namespace fishcam
