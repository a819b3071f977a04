#include "fishcam/fit/calibration.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "calibration_internal.hpp"

namespace fishcam {
namespace detail {

namespace {

// J^T J from the sparse rows (each corner touches the kept blocks, columns [0, a), and one
// eliminated block, which start at `starts`).
Eigen::MatrixXd normal_equations(const ceres::CRSMatrix& crs, Eigen::Index a, const std::vector<Eigen::Index>& starts) {
  const Eigen::Index m = crs.num_cols;
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(m, m);
  for (int r = 0; r < crs.num_rows; ++r) {
    const int begin = crs.rows[size_t(r)], end = crs.rows[size_t(r) + 1];
    Eigen::Index lo = m, hi = -1;  // the eliminated columns this row touches
    for (int i = begin; i < end; ++i) {
      const Eigen::Index c = crs.cols[size_t(i)];
      if (c >= a) lo = std::min(lo, c), hi = std::max(hi, c);
      for (int j = begin; j < end; ++j) normal(c, crs.cols[size_t(j)]) += crs.values[size_t(i)] * crs.values[size_t(j)];
    }
    if (hi >= 0 &&
        std::upper_bound(starts.begin(), starts.end(), lo) != std::upper_bound(starts.begin(), starts.end(), hi)) {
      throw Error("calibrate: internal error: a residual depends on two eliminated parameter blocks");
    }
  }
  return normal;
}

// The pseudo-inverse of a block from its eigen decomposition: a direction without
// curvature (eigenvalue at most kUndetermined * reference) is reported in
// `undetermined` (as a vector of all m parameters, the block at `at`), not inverted.
// Adds the directions inverted to *rank.
Eigen::MatrixXd pseudo_inverse(const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>& eigen, double reference,
                               Eigen::Index at, Eigen::Index m, std::vector<Eigen::VectorXd>* undetermined, int* rank) {
  const Eigen::Index size = eigen.eigenvalues().size();
  Eigen::MatrixXd inverse = Eigen::MatrixXd::Zero(size, size);
  for (Eigen::Index k = 0; k < size; ++k) {
    const double lambda = eigen.eigenvalues()[k];
    const Eigen::VectorXd v = eigen.eigenvectors().col(k);
    if (lambda > kUndetermined * reference) {
      inverse += v * v.transpose() / lambda;
      ++*rank;
    } else {
      Eigen::VectorXd full = Eigen::VectorXd::Zero(m);
      full.segment(at, size) = v;
      undetermined->push_back(full);
    }
  }
  return inverse;
}

}  // namespace

ParameterCovariance covariance_of(ceres::Problem* problem, const std::vector<double*>& kept,
                                  const std::vector<double*>& eliminated, const Eigen::MatrixXd& prior) {
  std::vector<double*> blocks = kept;
  blocks.insert(blocks.end(), eliminated.begin(), eliminated.end());
  ceres::Problem::EvaluateOptions options;
  options.parameter_blocks = blocks;
  options.apply_loss_function = false;
  options.num_threads = 1;
  double cost = 0;
  ceres::CRSMatrix crs;
  problem->Evaluate(options, &cost, nullptr, nullptr, &crs);
  Eigen::Index a = 0;  // kept columns [0, a), then the eliminated blocks'
  for (double* b : kept) a += problem->ParameterBlockSize(b);
  std::vector<Eigen::Index> starts;
  for (Eigen::Index at = a; double* b : eliminated) starts.push_back(at), at += problem->ParameterBlockSize(b);
  const Eigen::Index m = crs.num_cols;
  if (prior.rows() > a) throw Error("calibrate: internal error: a prior on parameters that are not kept");
  const Eigen::Index p = prior.rows();
  const Eigen::MatrixXd observed = normal_equations(crs, a, starts);
  Eigen::MatrixXd normal = observed;
  normal.topLeftCorner(p, p) += prior;
  Eigen::VectorXd scale(m);  // to unit curvature: the threshold then has no units
  for (Eigen::Index i = 0; i < m; ++i) scale[i] = normal(i, i) > 0 ? 1 / std::sqrt(normal(i, i)) : 0.0;
  normal = scale.asDiagonal() * normal * scale.asDiagonal();
  // Each eliminated block inverted on its own (pseudo-inverse: a direction without
  // curvature is reported, not inverted).
  const Eigen::Index e = m - a;
  Eigen::MatrixXd d_inverse = Eigen::MatrixXd::Zero(e, e);
  std::vector<Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>> blocks_eigen;
  double largest = 0;
  for (size_t k = 0; k < starts.size(); ++k) {
    const Eigen::Index size = problem->ParameterBlockSize(eliminated[k]);
    blocks_eigen.emplace_back(normal.block(starts[k], starts[k], size, size));
    largest = std::max(largest, blocks_eigen.back().eigenvalues().maxCoeff());
  }
  // The Schur complement onto the kept parameters, S = A - B D^+ B^T.
  int rank = 0;
  ParameterCovariance out;
  for (size_t k = 0; k < starts.size(); ++k) {
    const Eigen::Index size = problem->ParameterBlockSize(eliminated[k]), at = starts[k] - a;
    d_inverse.block(at, at, size, size) =
        pseudo_inverse(blocks_eigen[k], largest, starts[k], m, &out.undetermined, &rank);
  }
  const Eigen::MatrixXd g = normal.topRightCorner(a, e) * d_inverse;  // B D^+
  const Eigen::MatrixXd schur = normal.topLeftCorner(a, a) - g * normal.topRightCorner(a, e).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(schur);
  largest = std::max(largest, eigen.eigenvalues().maxCoeff());
  std::vector<Eigen::VectorXd> kept_undetermined;
  const Eigen::MatrixXd s_inverse = pseudo_inverse(eigen, largest, 0, m, &kept_undetermined, &rank);
  for (Eigen::VectorXd& direction : kept_undetermined) {  // the eliminated blocks follow: (u, -D^+ B^T u)
    direction.tail(e) = -g.transpose() * direction.head(a);
    out.undetermined.push_back(direction.normalized());
  }
  // The inverse of [A B; B^T D] from S^+ and D^+.
  Eigen::MatrixXd inverse(m, m);
  inverse.topLeftCorner(a, a) = s_inverse;
  inverse.topRightCorner(a, e) = -s_inverse * g;
  inverse.bottomLeftCorner(e, a) = inverse.topRightCorner(a, e).transpose();
  inverse.bottomRightCorner(e, e) = d_inverse + g.transpose() * s_inverse * g;
  if (p > 0) {  // N^-1 J^T J N^-1 (scaled as N is), a product of positive semi-definite matrices
    const Eigen::MatrixXd sandwich = inverse * (scale.asDiagonal() * observed * scale.asDiagonal()) * inverse;
    inverse = (sandwich + sandwich.transpose()) / 2;
  }
  const double dof = double(crs.num_rows - rank);
  out.variance = dof > 0 ? 2 * cost / dof : std::numeric_limits<double>::quiet_NaN();
  out.covariance = out.variance * scale.asDiagonal() * inverse * scale.asDiagonal();
  return out;
}

Eigen::Matrix3d cross_matrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d k;
  k << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return k;
}

Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& r) {
  const double angle = r.norm();
  const Eigen::Matrix3d k = cross_matrix(r);
  if (angle < 1e-8) return Eigen::Matrix3d::Identity() + 0.5 * k;
  return Eigen::Matrix3d::Identity() + (1 - std::cos(angle)) / (angle * angle) * k +
         (angle - std::sin(angle)) / (angle * angle * angle) * k * k;
}

// What projection uncertainty needs of the full covariance (mrcal's definition):
// a point fixed relative to the boards moves, in the camera frame, by the mean of
// the boards' motions. Board b's pose perturbed by (dr, dt) moves a point p of its
// frame's to p + w x p + t' with w = J_l(r_b) dr and t' = dt + t_b x w. Seen from a
// camera whose pose relative to that frame is (R, t) -- itself perturbed to add
// (w_c, t'_c) the same way -- the motion is (R w + w_c, R t' + t x R w + t'_c). The
// record keeps the intrinsics and the mean (w, t') over the boards.
Eigen::MatrixXd projection_covariance_of(const ParameterCovariance& full, const CovarianceLayout& layout,
                                         const std::vector<std::array<double, 6>>& boards) {
  const Eigen::Index n = layout.intrinsic_count, count = Eigen::Index(boards.size());
  Eigen::MatrixXd map = Eigen::MatrixXd::Zero(n + 6, full.covariance.cols());
  map.block(0, layout.intrinsics, n, n).setIdentity();
  const auto& c = layout.frame_to_camera;
  const Eigen::Vector3d camera_r(c[0], c[1], c[2]), camera_t(c[3], c[4], c[5]);
  const Eigen::Matrix3d rotation = pose_of(c).rotation.toRotationMatrix();
  if (layout.pose >= 0) {
    const Eigen::Matrix3d jl = left_jacobian(camera_r);
    map.block<3, 3>(n, layout.pose) = jl;
    map.block<3, 3>(n + 3, layout.pose) = cross_matrix(camera_t) * jl;
    map.block<3, 3>(n + 3, layout.pose + 3) = Eigen::Matrix3d::Identity();
  }
  for (Eigen::Index b = 0; b < count; ++b) {
    const auto& pose = boards[size_t(b)];
    const Eigen::Matrix3d jl = left_jacobian({pose[0], pose[1], pose[2]});
    const Eigen::Index col = layout.boards + 6 * b;
    const Eigen::Matrix3d w = rotation * jl / double(count);  // d(R w) / d dr
    map.block<3, 3>(n, col) = w;
    map.block<3, 3>(n + 3, col) =
        rotation * cross_matrix({pose[3], pose[4], pose[5]}) * jl / double(count) + cross_matrix(camera_t) * w;
    map.block<3, 3>(n + 3, col + 3) = rotation / double(count);
  }
  Eigen::MatrixXd covariance = map * full.covariance * map.transpose();
  return (covariance + covariance.transpose()) / 2;
}

Eigen::MatrixXd projection_covariance_of(const ParameterCovariance& full, const Solve& s) {
  const Eigen::Index n = Eigen::Index(s.model.size()), solved = Eigen::Index(s.tangential.size());
  // An mrcal lens's values lie where the terms would (the record holds all of them).
  const Eigen::Index intrinsics = n + solved + Eigen::Index(s.lens_values.size()) + 3;
  // The boards follow the intrinsics and the warp (parameter_covariance's order).
  const Eigen::Index boards = intrinsics + Eigen::Index(s.warp.size());
  const Eigen::MatrixXd c = projection_covariance_of(full, {0, intrinsics, -1, boards, {}}, s.poses);
  if (solved == 0) return c;
  // The record holds every tangential term (the camera's part has six), those the
  // solve held at zero with zero variance.
  const Eigen::Index held = Eigen::Index(TangentialTerms::kNames.size()) - solved;
  std::vector<Eigen::Index> place(size_t(c.rows()));
  for (Eigen::Index i = 0; i < c.rows(); ++i) place[size_t(i)] = i < n + solved ? i : i + held;
  return embedded(c, place, c.rows() + held);
}

Eigen::MatrixXd embedded(const Eigen::MatrixXd& c, const std::vector<Eigen::Index>& place, Eigen::Index size) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(size, size);
  for (Eigen::Index i = 0; i < c.rows(); ++i) {
    for (Eigen::Index j = 0; j < c.cols(); ++j) out(place[size_t(i)], place[size_t(j)]) = c(i, j);
  }
  return out;
}

}  // namespace detail

namespace {

// A camera-frame point's pixel, for the Jacobians of projection uncertainty. Blocks:
// model, the tangential terms (six; a radial camera: one unused), (cx, cy), a_y, point.
template <template <typename> class Model>
struct PointProjection {
  int params;
  int terms;  // 6 or 0
  double ax;

  template <typename T>
  bool operator()(T const* const* p, T* pixel) const {
    const Model<T> model = detail::model_from_block<Model>(p[0], params);
    const T mapping[4] = {p[2][0], p[2][1], T(ax), p[3][0]};
    detail::project_with_terms(model, p[1], terms, mapping, p[4], pixel);
    return true;
  }
};

// d pixel / d (f, the lens's values, cx, cy, a_y, w, t) of a camera with an mrcal lens
// on its stereographic plane (as calibrate solves it, LensCornerCost) at a camera-frame
// point; a board-fixed point moves to p + w x p + t (t only for a point at a distance).
Eigen::MatrixXd lens_projection_jacobian(const Camera& camera, const MrcalLens& lens, const Eigen::Vector3d& point,
                                         bool at_distance) {
  const auto* stereographic = std::get_if<Stereographic<double>>(&camera.model());
  if (!stereographic) throw Error("projection uncertainty: an mrcal lens is calibrated on the stereographic model");
  const Eigen::Index k = Eigen::Index(lens.values().size());
  Eigen::Matrix<double, 2, 3> d_point;
  Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor> d_values(2, k);
  const Eigen::Vector2d d = lens.project_with_values(point, lens.values().data(), &d_point, d_values.data());
  const double f = stereographic->f(), ax = camera.pixel_scale().x(), ay = camera.pixel_scale().y();
  const Eigen::Matrix2d scale = Eigen::Vector2d(ax * f, ay * f).asDiagonal();
  const Eigen::Matrix<double, 2, 3> dpixel = scale * d_point;
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(2, 1 + k + 9);
  jacobian.col(0) << ax * d.x(), ay * d.y();
  jacobian.middleCols(1, k) = scale * d_values;
  jacobian.block<2, 2>(0, 1 + k).setIdentity();
  jacobian(1, 3 + k) = f * d.y();
  jacobian.middleCols(4 + k, 3) = -dpixel * detail::cross_matrix(point);
  if (at_distance) jacobian.middleCols(7 + k, 3) = dpixel;
  return jacobian;
}

}  // namespace

Eigen::Matrix2d projection_covariance(const Camera& camera, const Eigen::Vector2d& pixel,
                                      std::optional<double> distance) {
  const auto& record = camera.parameters().calibration;
  if (!record || record->covariance.size() == 0) {
    throw Error(
        "projection uncertainty: the camera carries no calibration covariance (fishcam calibrate writes one "
        "into fishcam JSON)");
  }
  if (distance && !(*distance > 0 && std::isfinite(*distance))) {
    throw Error("projection uncertainty: the distance must be finite and > 0");
  }
  Eigen::Vector3d ray;
  if (!camera.unproject(pixel, &ray)) return Eigen::Matrix2d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d point = distance ? Eigen::Vector3d(*distance * ray) : ray;
  if (const MrcalLens* lens = camera.parameters().mrcal_lens()) {
    const Eigen::MatrixXd jacobian = lens_projection_jacobian(camera, *lens, point, distance.has_value());
    if (record->covariance.rows() != jacobian.cols()) {
      throw Error("projection uncertainty: the calibration covariance does not match the camera's parameters");
    }
    return jacobian * record->covariance * jacobian.transpose();
  }
  std::vector<double> model = model_params(camera.model());
  const PlaneDistortionNumbers plane = numbers_of(camera.parameters().distortion);
  if (plane.name != "none" && plane.name != TangentialDistortion::kName) {
    throw Error("projection uncertainty: not for a camera with " + std::string(plane.name) +
                " (fishcam calibrates radial models, OpenCV's tangential terms and mrcal's splines)");
  }
  std::vector<double> terms = plane.values;
  const int k = int(terms.size());
  if (terms.empty()) terms.push_back(0.0);  // an unused block
  Eigen::Vector2d center = camera.principal_point();
  double ay = camera.pixel_scale().y();
  const int n = int(model.size());
  Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor> d_model(2, n), d_terms(2, terms.size());
  Eigen::Matrix<double, 2, 2, Eigen::RowMajor> d_center;
  Eigen::Matrix<double, 2, 1> d_ay;
  Eigen::Matrix<double, 2, 3, Eigen::RowMajor> d_point;
  const std::string name(model_name(camera.model()));
  with_model_class(name, [&]<template <typename> class Model>() {
    ceres::DynamicAutoDiffCostFunction<PointProjection<Model>, 8> f(
        new PointProjection<Model>{n, k, camera.pixel_scale().x()});
    for (const int size : {n, int(terms.size()), 2, 1, 3}) f.AddParameterBlock(size);
    f.SetNumResiduals(2);
    const double* blocks[5] = {model.data(), terms.data(), center.data(), &ay, point.data()};
    double* jacobians[5] = {d_model.data(), d_terms.data(), d_center.data(), d_ay.data(), d_point.data()};
    double q[2];
    f.Evaluate(blocks, q, jacobians);
  });
  // d pixel / d (model, terms, cx, cy, a_y, w, t): a board-fixed point moves to p + w x p + t.
  Eigen::MatrixXd jacobian(2, n + k + 9);
  jacobian.leftCols(n) = d_model;
  jacobian.middleCols(n, k) = d_terms.leftCols(k);
  jacobian.rightCols(9) << d_center, d_ay, -d_point * detail::cross_matrix(point),
      (distance ? d_point : Eigen::Matrix<double, 2, 3, Eigen::RowMajor>::Zero());
  return jacobian * record->covariance * jacobian.transpose();
}

double projection_uncertainty(const Camera& camera, const Eigen::Vector2d& pixel, std::optional<double> distance) {
  const Eigen::Matrix2d c = projection_covariance(camera, pixel, distance);
  if (!c.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  // The larger eigenvalue of a symmetric 2x2.
  const double mean = (c(0, 0) + c(1, 1)) / 2, half = (c(0, 0) - c(1, 1)) / 2;
  return std::sqrt(std::max(0.0, mean + std::sqrt(half * half + c(0, 1) * c(0, 1))));
}

}  // namespace fishcam
