// What the chessboard calibration's files share (calibration.cpp: one camera;
// calibration_rig.cpp: rigs; calibration_covariance.cpp: covariance and projection
// uncertainty): the solve's parameter blocks, the corner residual, the covariance.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ceres_support.hpp"
#include "fishcam/core/camera.hpp"
#include "fishcam/core/mrcal_lens.hpp"
#include "fishcam/fit/calibration.hpp"
#include "fishcam/fit/fit.hpp"

namespace fishcam::detail {

// The parameters of one camera's solve: the model's, the principal point, a_y, and
// each board's pose as a block (angle-axis, translation; board -> camera); with
// ModelSpec::tangential_terms, those terms (p1, p2[, s1..s4]) as one more block; with
// ModelSpec::mrcal_lens, the lens's values as that block instead.
struct Solve {
  std::vector<double> model;
  Eigen::Vector2d center;
  double ay = 1;
  std::vector<std::array<double, 6>> poses;
  std::vector<double> tangential = {};
  // With the boards' warp: (x2, y2) and the board they bend (BoardWarp); empty: flat.
  std::vector<double> warp = {};
  BoardSpec board = {};
  // An mrcal lens on the model's plane: its values and the lens that says how they
  // are read (its own values unused). As mrcal-calibrate-cameras solves a spline, the
  // base model's core (its parameters, cx, cy, a_y) is solved with the values held
  // at 0, then held while the values are solved (the spline can represent any
  // change of the core: holding it removes the trade between them).
  std::vector<double> lens_values = {};
  std::shared_ptr<const MrcalLens> lens = {};
  bool core_held = false, lens_values_held = false;
};

// A board point moved along z by its warp (factors: warp_factors; none: flat).
template <typename T>
void warped_point(const Eigen::Vector3d& point, const std::optional<Eigen::Vector2d>& factors, const T* warp, T* out) {
  out[0] = T(point.x()), out[1] = T(point.y()), out[2] = T(point.z());
  if (factors) out[2] += T(factors->x()) * warp[0] + T(factors->y()) * warp[1];
}

// A board point where a warp (x2, y2) puts it (empty: flat, as it is).
Eigen::Vector3d warped(const BoardSpec& board, const std::vector<double>& warp, const Eigen::Vector3d& point);

std::array<double, 6> pose_block(const BoardPose& pose);
BoardPose pose_of(const std::array<double, 6>& block);

// [v]x, and the left Jacobian of SO(3) at angle-axis r: R(r + dr) = exp([J dr]x) R(r)
// to first order.
Eigen::Matrix3d cross_matrix(const Eigen::Vector3d& v);
Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& r);

// One corner's reprojection residual as a functor of every parameter, for Ceres'
// automatic derivatives: the reference CornerCost is tested against, and what it
// falls back to on the optical axis.
template <template <typename> class Model>
struct CornerResidual {
  Eigen::Vector3d point;
  Eigen::Vector2d corner;
  int params;
  std::optional<Eigen::Vector2d> warp = std::nullopt;  // the point's warp factors: a fifth block (x2, y2)

  template <typename T>
  bool operator()(T const* const* p, T* residuals) const {
    const Model<T> model = detail::model_from_block<Model>(p[0], params);
    const T mapping[4] = {p[1][0], p[1][1], T(1.0), p[2][0]};
    const T* pose = p[3];  // angle-axis, translation
    T board[3];
    warped_point(point, warp, warp ? p[4] : static_cast<const T*>(nullptr), board);
    T camera[3];
    ceres::AngleAxisRotatePoint(pose, board, camera);
    for (int k = 0; k < 3; ++k) camera[k] += pose[3 + k];
    T pixel[2];
    project_radial(model, mapping, camera, pixel);
    residuals[0] = pixel[0] - corner.x();
    residuals[1] = pixel[1] - corner.y();
    return true;
  }
};

// A camera-frame point's pixel through a model and OpenCV's tangential terms on its
// undistorted plane m (fishcam/core/tangential.hpp), generic in the scalar type:
// pixel = c + a (.) (rho (X, Y) / chi + f T(m)), mapping = (cx, cy, a_x, a_y), the
// first `count` of (p1, p2, s1..s4) given (0: the radial projection alone).
template <class ModelT, typename T>
void project_with_terms(const ModelT& model, const T* terms, int count, const T* mapping, const T* point, T* pixel) {
  if constexpr (requires(T * m) { model.plane_point(point, m); }) {
    if (count > 0) {
      const T unit[4] = {T(0.0), T(0.0), T(1.0), T(1.0)};
      T radial[2], m[2], offset[2];
      project_radial(model, unit, point, radial);
      const T f = model.plane_point(point, m);
      TangentialTerms::offset_of(terms, count, m[0], m[1], offset);
      pixel[0] = mapping[0] + mapping[2] * (radial[0] + f * offset[0]);
      pixel[1] = mapping[1] + mapping[3] * (radial[1] + f * offset[1]);
      return;
    }
  }
  project_radial(model, mapping, point, pixel);
}

// A corner's residual with the tangential terms solved, for Ceres' automatic
// derivatives. Blocks: model, the terms, (cx, cy), a_y, board pose.
template <template <typename> class Model>
struct TangentialCornerResidual {
  Eigen::Vector3d point;
  Eigen::Vector2d corner;
  int params, terms;
  std::optional<Eigen::Vector2d> warp = std::nullopt;  // the point's warp factors: a sixth block (x2, y2)

  template <typename T>
  bool operator()(T const* const* p, T* residuals) const {
    const Model<T> model = detail::model_from_block<Model>(p[0], params);
    const T* pose = p[4];
    T board[3];
    warped_point(point, warp, warp ? p[5] : static_cast<const T*>(nullptr), board);
    T camera[3];
    ceres::AngleAxisRotatePoint(pose, board, camera);
    for (int k = 0; k < 3; ++k) camera[k] += pose[3 + k];
    const T mapping[4] = {p[2][0], p[2][1], T(1.0), p[3][0]};
    T pixel[2];
    project_with_terms(model, p[1], terms, mapping, camera, pixel);
    residuals[0] = pixel[0] - corner.x();
    residuals[1] = pixel[1] - corner.y();
    return true;
  }
};

// A corner's residual with an mrcal lens's values solved (ModelSpec::mrcal_lens), its
// Jacobians from libmrcal's gradients: pixel = c + diag(1, a_y) f D(q), D the lens's
// projection with fx = fy = 1 (MrcalLens::project_with_values). Blocks: the base
// model (f), the lens's values, (cx, cy), a_y, board pose[, the boards' warp].
class LensCornerCost final : public ceres::CostFunction {
 public:
  LensCornerCost(const MrcalLens* lens, const Eigen::Vector3d& point, const Eigen::Vector2d& corner,
                 std::optional<Eigen::Vector2d> warp);
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override;

 private:
  const MrcalLens* lens_;
  Eigen::Vector3d point_;
  Eigen::Vector2d corner_;
  std::optional<Eigen::Vector2d> warp_;
};

// mrcal's regularisation of a splined lens, as mrcal 2.2 solves it (mrcal.c, the
// optimizer callback; its core held, so without the principal point's term): at
// every knot the control value's displacement along the knot's direction from the
// centre and across it, the part across weighed 10x (no curl where no data hold the
// field). Scaled so that at its nominal size (a displacement of 0.2) it adds 0.25 %
// of the cost of the corners at 1 px each. Linear: residuals A values. One block:
// the lens's values.
class LensRegularisation final : public ceres::CostFunction {
 public:
  LensRegularisation(const MrcalLens& lens, long corners);
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override;
  // A^T A: its curvature in the values, what the covariance counts as a prior.
  Eigen::MatrixXd normal() const { return a_.transpose() * a_; }

 private:
  Eigen::MatrixXd a_;
};

// A board point in a rig camera's frame: the board -> camera 0 pose, then (for
// cameras other than 0: rig_to_camera non-null) camera 0 -> the camera; angle-axis
// and translation blocks.
template <typename T>
void board_point_in_camera(const T* board_pose, const T* rig_to_camera, const T* board, T* camera) {
  T in_rig[3];
  ceres::AngleAxisRotatePoint(board_pose, board, in_rig);
  for (int k = 0; k < 3; ++k) in_rig[k] += board_pose[3 + k];
  if (!rig_to_camera) {
    for (int k = 0; k < 3; ++k) camera[k] = in_rig[k];
    return;
  }
  ceres::AngleAxisRotatePoint(rig_to_camera, in_rig, camera);
  for (int k = 0; k < 3; ++k) camera[k] += rig_to_camera[3 + k];
}

// A corner seen through a camera whose intrinsics are held fixed (any camera: its
// projection and Jacobian d pixel / d point are the camera's own), as a functor of the
// poses for Ceres' automatic derivatives. Blocks: (moved: camera 0 -> this camera),
// then the board -> camera 0 (unmoved: board -> this camera).
class FixedCameraCornerResidual {
  // pixel(point) - corner, the Jacobian from Camera::project.
  class Projection final : public ceres::SizedCostFunction<2, 3> {
   public:
    Projection(const Camera* camera, const Eigen::Vector2d& corner) : camera_(camera), corner_(corner) {}
    bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
      Eigen::Vector2d pixel;
      Eigen::Matrix<double, 2, 3> d;
      const bool want = jacobians && jacobians[0];
      if (!camera_->project(Eigen::Vector3d(p[0][0], p[0][1], p[0][2]), &pixel, want ? &d : nullptr)) return false;
      residuals[0] = pixel.x() - corner_.x();
      residuals[1] = pixel.y() - corner_.y();
      if (want) Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>>{jacobians[0]} = d;
      return true;
    }

   private:
    const Camera* camera_;
    Eigen::Vector2d corner_;
  };

 public:
  // warp: the point's warp factors (the boards' warp (x2, y2) then a last block).
  FixedCameraCornerResidual(const Camera* camera, const Eigen::Vector3d& point, const Eigen::Vector2d& corner,
                            bool moved, std::optional<Eigen::Vector2d> warp = std::nullopt)
      : project_(new Projection(camera, corner)), point_(point), moved_(moved), warp_(warp) {}

  template <typename T>
  bool operator()(T const* const* p, T* residuals) const {
    T board[3], camera[3];
    warped_point(point_, warp_, warp_ ? p[moved_ ? 2 : 1] : static_cast<const T*>(nullptr), board);
    board_point_in_camera(moved_ ? p[1] : p[0], moved_ ? p[0] : static_cast<const T*>(nullptr), board, camera);
    return project_(camera, residuals);
  }

 private:
  ceres::CostFunctionToFunctor<2, 3> project_;
  Eigen::Vector3d point_;
  bool moved_;
  std::optional<Eigen::Vector2d> warp_;
};

// A corner's Jacobians in its board's pose (angle-axis, translation: 2 x 6, row-major)
// and in the boards' warp (2 x 2) from d pixel / d camera-frame point: `rotated` is the
// (warped) board point turned by the pose, `warp` its warp factors. Either output may be
// null (not wanted).
void board_jacobians(const Eigen::Matrix<double, 2, 3>& dpixel, const Eigen::Vector3d& rotated, const double* pose,
                     const std::optional<Eigen::Vector2d>& warp, double* d_pose, double* d_warp);

// The same residual with its Jacobians written out; parameter blocks (model,
// (cx, cy), a_y, board pose[, the boards' warp (x2, y2) when the point has factors]).
// A radial model enters only through rho(theta): one
// forward-mode evaluation of rho with Jets over (model parameters, theta) gives
// d rho / d params and rho'(theta); the rest is the chain rule through the
// projection and the pose. Automatic derivatives of the whole residual carry every
// derivative through the rotation and atan2 and cost several times more; they
// remain the fallback where the closed form divides by ~0 (a corner on the axis).
template <template <typename> class Model>
class CornerCost final : public ceres::CostFunction {
  // Model parameters (a polynomial's count varies: up to the fitted maximum), then theta.
  static constexpr int kJetSize =
      (Model<double>::kParamNames.empty() ? kMaxFittedPolynomialOrder : int(Model<double>::kParamNames.size())) + 1;
  using Jet = ceres::Jet<double, kJetSize>;

 public:
  CornerCost(const Eigen::Vector3d& point, const Eigen::Vector2d& corner, int params,
             std::optional<Eigen::Vector2d> warp = std::nullopt)
      : point_(point),
        corner_(corner),
        params_(params),
        warp_(warp),
        reference_(new CornerResidual<Model>{point, corner, params, warp}) {
    std::vector<int> sizes = {params, 2, 1, 6};
    if (warp) sizes.push_back(2);
    for (const int size : sizes) reference_.AddParameterBlock(size);
    reference_.SetNumResiduals(2);
    set_num_residuals(2);
    *mutable_parameter_block_sizes() = sizes;
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    Eigen::Vector3d point, rotated;
    warped_point(point_, warp_, warp_ ? p[4] : nullptr, point.data());
    ceres::AngleAxisRotatePoint(p[3], point.data(), rotated.data());
    const Eigen::Vector3d q = rotated + Eigen::Vector3d(p[3][3], p[3][4], p[3][5]);
    const double chi2 = q.x() * q.x() + q.y() * q.y();
    // Near the axis the closed form loses digits (its terms grow as 1/chi^2 and cancel).
    if (!(chi2 > 1e-10 * q.z() * q.z()) || params_ + 1 > kJetSize) return reference_.Evaluate(p, residuals, jacobians);
    const double chi = std::sqrt(chi2), theta = std::atan2(chi, q.z()), ay = p[2][0];
    std::array<Jet, kJetSize> jets;
    for (int i = 0; i < params_; ++i) jets[size_t(i)] = Jet(p[0][i], i);
    const Jet rho = Model<Jet>(jets.data(), params_).rho(Jet(theta, kJetSize - 1));
    const double s = rho.a / chi;  // pixel = c + diag(1, a_y) s (x, y)
    residuals[0] = p[1][0] + s * q.x() - corner_.x();
    residuals[1] = p[1][1] + ay * s * q.y() - corner_.y();
    if (!jacobians) return true;
    if (jacobians[0]) {
      for (int i = 0; i < params_; ++i) {
        jacobians[0][i] = q.x() / chi * rho.v[i];
        jacobians[0][params_ + i] = ay * q.y() / chi * rho.v[i];
      }
    }
    if (jacobians[1]) jacobians[1][0] = 1, jacobians[1][1] = 0, jacobians[1][2] = 0, jacobians[1][3] = 1;
    if (jacobians[2]) jacobians[2][0] = 0, jacobians[2][1] = s * q.y();
    const bool warp_wanted = warp_ && jacobians[4];
    if (jacobians[3] || warp_wanted) {
      // d s / d q from d theta / d q = (z x / chi, z y / chi, -chi) / |q|^2 and d chi / d q = (x, y, 0) / chi.
      const double r2 = chi2 + q.z() * q.z(), drho = rho.v[kJetSize - 1];
      const Eigen::Vector3d dtheta(q.z() * q.x() / (chi * r2), q.z() * q.y() / (chi * r2), -chi / r2);
      const Eigen::Vector3d ds = (drho * dtheta - s * Eigen::Vector3d(q.x() / chi, q.y() / chi, 0)) / chi;
      Eigen::Matrix<double, 2, 3> dpixel;
      dpixel.row(0) = q.x() * ds.transpose(), dpixel(0, 0) += s;
      dpixel.row(1) = ay * q.y() * ds.transpose(), dpixel(1, 1) += ay * s;
      board_jacobians(dpixel, rotated, p[3], warp_, jacobians[3], warp_wanted ? jacobians[4] : nullptr);
    }
    return true;
  }

 private:
  Eigen::Vector3d point_;
  Eigen::Vector2d corner_;
  int params_;
  std::optional<Eigen::Vector2d> warp_;
  ceres::DynamicAutoDiffCostFunction<CornerResidual<Model>, 8> reference_;
};

// The covariance of a solve's parameters as sigma^2 (J^T J)^+ with sigma^2 the
// residual variance per coordinate. Directions the data do not determine (scaled
// eigenvalues below kUndetermined of the largest) are left out of the inverse and
// returned, so that no sigma pretends to know them.
struct ParameterCovariance {
  Eigen::MatrixXd covariance;
  std::vector<Eigen::VectorXd> undetermined;  // unit directions in parameters scaled to unit curvature
  double variance = 0;                        // residual variance per coordinate, px^2
};

constexpr double kUndetermined = 1e-12;

// The covariance of a problem's parameter blocks at their current values (no loss
// function), in the order `kept` then `eliminated`. No residual may depend on two
// eliminated blocks (they are board poses): those are then solved block by block
// and the kept ones through the Schur complement, as Ceres' Schur solvers do.
// `prior`: the curvature of residuals that are no observations (a regularisation,
// not in `problem`), over the first prior.rows() kept parameters: the solve's
// normal matrix is then N = J^T J + prior, and as in mrcal only the observations
// carry noise: covariance = sigma^2 N^-1 J^T J N^-1.
ParameterCovariance covariance_of(ceres::Problem* problem, const std::vector<double*>& kept,
                                  const std::vector<double*>& eliminated, const Eigen::MatrixXd& prior = {});

// A covariance of parameters some of which were held: row/column i of c at place[i]
// of a size x size matrix, zero elsewhere (the held parameters: no variance).
Eigen::MatrixXd embedded(const Eigen::MatrixXd& c, const std::vector<Eigen::Index>& place, Eigen::Index size);

// What projection uncertainty needs of a single camera's full covariance (the
// record's (n + k + 9)^2 matrix, k the camera's plane distortion numbers;
// calibration_covariance.cpp says how).
Eigen::MatrixXd projection_covariance_of(const ParameterCovariance& full, const Solve& s);

// Where one camera's parameters lie in a covariance: its intrinsics (n + 3 from
// `intrinsics`), its pose relative to the frame the boards are kept in (`pose`, 6
// columns, -1: the boards are in this camera's frame; `frame_to_camera` is that
// pose as a block), and the boards (6 columns each from `boards`).
struct CovarianceLayout {
  Eigen::Index intrinsics = 0, intrinsic_count = 0, pose = -1, boards = 0;
  std::array<double, 6> frame_to_camera{};
};
// The record's matrix for that camera: its intrinsics, and the mean motion of every
// board, seen from the camera (a rig's camera k: the boards of every instant, kept
// in camera 0's frame, moved by their own uncertainty and by camera k's pose).
Eigen::MatrixXd projection_covariance_of(const ParameterCovariance& full, const CovarianceLayout& layout,
                                         const std::vector<std::array<double, 6>>& boards);

// "f, xi and alpha trade against each other", with a hint where a model is degenerate.
std::string undetermined_text(const std::vector<std::string>& names, bool poses, const std::string& model,
                              const std::vector<double>& parameters);

// A solve whose result cannot be right is an error, not a camera.
// How far the principal point lies from the image centre, as the larger share of the
// image's width or height. Lenses are centred within a few per cent; past
// kPrincipalPointWarned a calibration says so, past kPrincipalPointRefused
// (check_solution) the image size is not the one the corners came from.
constexpr double kPrincipalPointWarned = 0.1, kPrincipalPointRefused = 0.2;
double principal_point_offset(const Eigen::Vector2d& principal_point, int width, int height);
// Corners may lie this far outside the image (sub-pixel refinement at the border).
constexpr double kCornerMarginPx = 2;
void check_solution(const CalibrationResult& r, int width, int height, const std::string& model);

// The outlier rule of every solve (single camera, located boards, the rig's joint
// solve): a corner whose error exceeds 5 robust sigmas of all the errors (median *
// 1.4826, the 2-D error's scale) and 0.1 px (however exact the others, a corner that
// close is no outlier). Returns that limit; an empty list has none (infinity).
double outlier_limit_px(std::vector<double> errors_px);

// Throws Error (prefixed with `what`) unless the view's ids fit the board
// (check_observation) and a partial view has at least 4 corners spanning 2 rows and
// 2 columns (fewer leave its pose free to turn).
void check_placeable(const BoardSpec& board, const BoardObservation& observation, const std::string& what);

}  // namespace fishcam::detail
