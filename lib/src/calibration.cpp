#include "fishcam/calibration.hpp"
#include "fishcam/fit.hpp"

#include "fishcam/atomic_file.hpp"

#include <ceres/rotation.h>

#include "ceres_support.hpp"
#include "fishcam/parallel.hpp"

#include <Eigen/SVD>
#include <cmath>
#include <fstream>
#include <map>
#include <filesystem>
#include <numeric>
#include <set>
#include <random>
#include <sstream>

namespace fishcam {
namespace {

Eigen::Vector3d to_camera(const BoardPose& pose, const Eigen::Vector3d& p) { return pose.rotation * p + pose.translation; }

// Kabsch: the rigid transform taking `from` onto `to` (least squares).
BoardPose rigid_fit(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to) {
  Eigen::Vector3d mean_from = Eigen::Vector3d::Zero(), mean_to = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < from.size(); ++i) mean_from += from[i], mean_to += to[i];
  mean_from /= double(from.size()), mean_to /= double(to.size());
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < from.size(); ++i) h += (from[i] - mean_from) * (to[i] - mean_to).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixV() * svd.matrixU().transpose();
  if (r.determinant() < 0) {
    Eigen::Matrix3d v = svd.matrixV();
    v.col(2) *= -1;
    r = v * svd.matrixU().transpose();
  }
  return BoardPose{Eigen::Quaterniond(r), mean_to - r * mean_from};
}

// A board pose from its corners' rays: all corners first put at one distance
// (from the angle between neighbouring rays), then a few rounds of "fit the board,
// intersect the rays with its plane, fit again".
std::optional<BoardPose> pose_from_rays(const std::vector<Eigen::Vector3d>& rays, const std::vector<Eigen::Vector3d>& points,
                                        const BoardSpec& board) {
  double angle = 0;
  int pairs = 0;
  for (int j = 0; j < board.rows; ++j) {
    for (int i = 0; i + 1 < board.cols; ++i) {
      const auto& a = rays[size_t(j * board.cols + i)];
      const auto& b = rays[size_t(j * board.cols + i + 1)];
      angle += std::atan2(a.cross(b).norm(), a.dot(b));
      ++pairs;
    }
  }
  if (!(angle > 0)) return std::nullopt;
  const double distance = board.spacing / (angle / pairs);
  std::vector<Eigen::Vector3d> in_camera(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) in_camera[i] = distance * rays[i];
  BoardPose pose = rigid_fit(points, in_camera);
  for (int round = 0; round < 5; ++round) {
    const Eigen::Vector3d normal = pose.rotation * Eigen::Vector3d::UnitZ();
    const double offset = normal.dot(pose.translation);
    for (size_t i = 0; i < rays.size(); ++i) {
      const double along = normal.dot(rays[i]);
      if (std::abs(along) < 1e-6) return std::nullopt;
      in_camera[i] = offset / along * rays[i];
    }
    pose = rigid_fit(points, in_camera);
  }
  if (!pose.translation.allFinite()) return std::nullopt;
  return pose;
}

// One corner's reprojection residual, for Ceres. One block per corner, so that a
// robust loss (applied per block) discounts single bad corners, not whole boards.
template <template <typename> class Model>
struct CornerResidual {
  Eigen::Vector3d point;
  Eigen::Vector2d corner;
  int params;

  template <typename T>
  bool operator()(T const* const* p, T* residuals) const {
    const Model<T> model = detail::model_from_block<Model>(p[0], params);
    const T mapping[4] = {p[1][0], p[1][1], T(1.0), p[2][0]};
    const T* pose = p[3];  // angle-axis, translation
    const T board[3] = {T(point.x()), T(point.y()), T(point.z())};
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

// A camera-frame point's pixel, for the Jacobians of projection uncertainty.
template <template <typename> class Model>
struct PointProjection {
  int params;
  double ax;

  template <typename T>
  bool operator()(T const* const* p, T* pixel) const {
    const Model<T> model = detail::model_from_block<Model>(p[0], params);
    const T mapping[4] = {p[1][0], p[1][1], T(ax), p[2][0]};
    project_radial(model, mapping, p[3], pixel);
    return true;
  }
};

std::array<double, 6> pose_block(const BoardPose& pose) {
  const Eigen::AngleAxisd aa(pose.rotation);
  const Eigen::Vector3d r = aa.axis() * aa.angle();
  return {r.x(), r.y(), r.z(), pose.translation.x(), pose.translation.y(), pose.translation.z()};
}

BoardPose pose_of(const std::array<double, 6>& b) {
  const Eigen::Vector3d r(b[0], b[1], b[2]);
  const double angle = r.norm();
  BoardPose pose;
  pose.rotation = angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, r / angle)) : Eigen::Quaterniond::Identity();
  pose.translation = {b[3], b[4], b[5]};
  return pose;
}

struct Solve {
  std::vector<double> model;
  Eigen::Vector2d center;
  double ay = 1;
  std::vector<std::array<double, 6>> poses;
};

// One residual block per corner, in board order then corner order (the order
// fixes the Jacobian's rows, and so every sum over them).
template <template <typename> class Model>
void add_corner_residuals(ceres::Problem* problem, Solve* s, const std::vector<std::vector<Eigen::Vector3d>>& points,
                          const std::vector<std::vector<Eigen::Vector2d>>& corners, ceres::LossFunction* loss) {
  const int n = static_cast<int>(s->model.size());
  for (size_t b = 0; b < corners.size(); ++b) {
    for (size_t i = 0; i < corners[b].size(); ++i) {
      auto* cost = new ceres::DynamicAutoDiffCostFunction<CornerResidual<Model>, 8>(
          new CornerResidual<Model>{points[b][i], corners[b][i], n});
      cost->AddParameterBlock(n);
      cost->AddParameterBlock(2);
      cost->AddParameterBlock(1);
      cost->AddParameterBlock(6);
      cost->SetNumResiduals(2);
      problem->AddResidualBlock(cost, loss, s->model.data(), s->center.data(), &s->ay, s->poses[b].data());
    }
  }
}

// The joint (or, with intrinsics_fixed, pose-only) solve over all boards; each
// board's points and corners pair up. One thread: Ceres sums costs and gradients
// per thread, so more threads change the last bits of the result.
template <template <typename> class Model>
ceres::Solver::Summary solve(Solve* s, const std::vector<std::vector<Eigen::Vector3d>>& points,
                             const std::vector<std::vector<Eigen::Vector2d>>& corners, bool intrinsics_fixed,
                             ceres::LossFunction* loss, int max_iterations = 200, double tolerance = 1e-15) {
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  add_corner_residuals<Model>(&problem, s, points, corners, loss);
  detail::bound_model_block<Model>(&problem, s->model.data(), int(s->model.size()));
  if (intrinsics_fixed) {
    problem.SetParameterBlockConstant(s->model.data());
    problem.SetParameterBlockConstant(s->center.data());
    problem.SetParameterBlockConstant(&s->ay);
  }
  ceres::Solver::Summary summary;
  ceres::Solver::Options options = detail::solver_options(ceres::SPARSE_SCHUR);
  options.max_num_iterations = max_iterations;
  options.function_tolerance = options.parameter_tolerance = tolerance;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("calibrate: the solve failed: " + summary.message);
  return summary;
}

// The covariance of every parameter of a solve -- (model, cx, cy, a_y, then each
// board's angle-axis and translation) -- as sigma^2 (J^T J)^+ with sigma^2 the
// residual variance per coordinate. Directions the data do not determine (scaled
// eigenvalues of J^T J below kUndetermined of the largest) are left out of the
// inverse and returned, so that no sigma pretends to know them.
struct ParameterCovariance {
  Eigen::MatrixXd covariance;
  std::vector<Eigen::VectorXd> undetermined;  // unit directions in parameters scaled to unit curvature
  double variance = 0;                        // residual variance per coordinate, px^2
};

constexpr double kUndetermined = 1e-12;

// The covariance of a problem's parameter blocks, in the given order, at their
// current values (no loss function).
ParameterCovariance covariance_of(ceres::Problem* problem, const std::vector<double*>& blocks) {
  ceres::Problem::EvaluateOptions options;
  options.parameter_blocks = blocks;
  options.apply_loss_function = false;
  options.num_threads = 1;
  double cost = 0;
  ceres::CRSMatrix crs;
  problem->Evaluate(options, &cost, nullptr, nullptr, &crs);
  // J^T J from the sparse rows (each corner touches its intrinsics and one pose).
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(crs.num_cols, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    const int begin = crs.rows[size_t(r)], end = crs.rows[size_t(r) + 1];
    for (int a = begin; a < end; ++a) {
      for (int b = begin; b < end; ++b) {
        normal(crs.cols[size_t(a)], crs.cols[size_t(b)]) += crs.values[size_t(a)] * crs.values[size_t(b)];
      }
    }
  }
  const Eigen::Index m = normal.rows();
  Eigen::VectorXd scale(m);  // to unit curvature: the threshold then has no units
  for (Eigen::Index i = 0; i < m; ++i) scale[i] = normal(i, i) > 0 ? 1 / std::sqrt(normal(i, i)) : 0.0;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scale.asDiagonal() * normal * scale.asDiagonal());
  const double largest = eigen.eigenvalues().maxCoeff();
  ParameterCovariance out;
  Eigen::MatrixXd inverse = Eigen::MatrixXd::Zero(m, m);
  int rank = 0;
  for (Eigen::Index k = 0; k < m; ++k) {
    const double lambda = eigen.eigenvalues()[k];
    const Eigen::VectorXd v = eigen.eigenvectors().col(k);
    if (lambda > kUndetermined * largest) {
      inverse += v * v.transpose() / lambda;
      ++rank;
    } else {
      out.undetermined.push_back(v);
    }
  }
  for (Eigen::Index i = 0; i < m; ++i) {  // a parameter no residual depends on
    if (scale[i] == 0) {
      Eigen::VectorXd v = Eigen::VectorXd::Zero(m);
      v[i] = 1;
      out.undetermined.push_back(v);
    }
  }
  const double dof = double(crs.num_rows - rank);
  out.variance = dof > 0 ? 2 * cost / dof : std::numeric_limits<double>::quiet_NaN();
  out.covariance = out.variance * scale.asDiagonal() * inverse * scale.asDiagonal();
  return out;
}

template <template <typename> class Model>
ParameterCovariance parameter_covariance(Solve s, const std::vector<std::vector<Eigen::Vector3d>>& points,
                                         const std::vector<std::vector<Eigen::Vector2d>>& corners) {
  ceres::Problem problem;
  add_corner_residuals<Model>(&problem, &s, points, corners, nullptr);
  std::vector<double*> blocks = {s.model.data(), s.center.data(), &s.ay};
  for (auto& pose : s.poses) blocks.push_back(pose.data());
  return covariance_of(&problem, blocks);
}

// The left Jacobian of SO(3) at angle-axis r: R(r + dr) = exp([J dr]x) R(r) to first order.
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
// the boards' motions. Board b's pose perturbed by (dr, dt) moves a camera-frame
// point p to p + w x p + t' with w = J_l(r_b) dr and t' = dt + t_b x w; the record
// keeps the intrinsics and the mean (w, t') over the boards.
Eigen::MatrixXd projection_covariance_of(const ParameterCovariance& full, const Solve& s) {
  const Eigen::Index intrinsics = Eigen::Index(s.model.size()) + 3;
  const Eigen::Index boards = Eigen::Index(s.poses.size());
  Eigen::MatrixXd map = Eigen::MatrixXd::Zero(intrinsics + 6, intrinsics + 6 * boards);
  map.topLeftCorner(intrinsics, intrinsics).setIdentity();
  for (Eigen::Index b = 0; b < boards; ++b) {
    const auto& pose = s.poses[size_t(b)];
    const Eigen::Matrix3d jl = left_jacobian({pose[0], pose[1], pose[2]});
    const Eigen::Index col = intrinsics + 6 * b;
    map.block<3, 3>(intrinsics, col) = jl / double(boards);
    map.block<3, 3>(intrinsics + 3, col) = cross_matrix({pose[3], pose[4], pose[5]}) * jl / double(boards);
    map.block<3, 3>(intrinsics + 3, col + 3) = Eigen::Matrix3d::Identity() / double(boards);
  }
  Eigen::MatrixXd c = map * full.covariance * map.transpose();
  return (c + c.transpose()) / 2;
}

// How far corners, read as a cols x rows grid in board order, are from a grid: the
// median over the corners of the larger of their second differences along the row
// and along the column, over the mean step. A lens bends a board smoothly, so
// neighbouring steps along a row or a column stay alike (well under 0.25 even at a
// fisheye's rim); corners read with the wrong row length jump back and forth
// between rows along the columns and give 1 or more.
double grid_disorder(const std::vector<Eigen::Vector2d>& corners, int cols, int rows) {
  const auto at = [&](int i, int j) { return corners[size_t(j * cols + i)]; };
  const auto bend = [](const Eigen::Vector2d& before, const Eigen::Vector2d& here, const Eigen::Vector2d& after) {
    const double step = ((here - before).norm() + (after - here).norm()) / 2;
    return step > 0 ? (after - 2 * here + before).norm() / step : std::numeric_limits<double>::infinity();
  };
  std::vector<double> points;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      double worst = -1;
      if (i > 0 && i + 1 < cols) worst = std::max(worst, bend(at(i - 1, j), at(i, j), at(i + 1, j)));
      if (j > 0 && j + 1 < rows) worst = std::max(worst, bend(at(i, j - 1), at(i, j), at(i, j + 1)));
      if (worst >= 0) points.push_back(worst);
    }
  }
  if (points.empty()) return 0;  // a 2 x 2 board: nothing to tell
  std::nth_element(points.begin(), points.begin() + long(points.size() / 2), points.end());
  return points[points.size() / 2];
}

double median_grid_disorder(const std::vector<const BoardObservation*>& boards, int cols, int rows) {
  std::vector<double> disorder;
  for (const auto* b : boards) disorder.push_back(grid_disorder(b->corners, cols, rows));
  std::nth_element(disorder.begin(), disorder.begin() + long(disorder.size() / 2), disorder.end());
  return disorder[disorder.size() / 2];
}

// Refuses corners whose order contradicts the board: most often a W x H board given
// as --board HxW, which has the same corner count and so reads without complaint.
void check_board_order(const std::vector<const BoardObservation*>& boards, const BoardSpec& board) {
  constexpr double kOrdered = 0.25, kDisordered = 0.5;
  const double given = median_grid_disorder(boards, board.cols, board.rows);
  if (given <= kDisordered) return;
  const std::string as_given = std::to_string(board.cols) + "x" + std::to_string(board.rows);
  const std::string swapped = std::to_string(board.rows) + "x" + std::to_string(board.cols);
  if (board.cols != board.rows && median_grid_disorder(boards, board.rows, board.cols) <= kOrdered) {
    throw Error("calibrate: the corners are ordered as a " + swapped + " board, not " + as_given +
                " (rows of " + std::to_string(board.rows) + "): pass --board " + swapped);
  }
  char measure[32];
  std::snprintf(measure, sizeof measure, "%.2f", given);
  throw Error("calibrate: the corners are not in the board order of a " + as_given +
              " board (median cell distortion " + measure +
              ", a grid gives < 0.25): check --board and that each image lists its corners row by row");
}

// Boards seen in one pose only (the same view several times) determine no camera:
// the solve fits one view however the intrinsics trade against the pose. Poses
// closer than 2 deg and 5 % of their distance count as one.
void check_distinct_poses(const CalibrationResult& r) {
  std::vector<const BoardPose*> distinct;
  for (const BoardPose& pose : r.poses) {
    const bool seen = std::any_of(distinct.begin(), distinct.end(), [&](const BoardPose* other) {
      const double angle = pose.rotation.angularDistance(other->rotation);
      const double shift = (pose.translation - other->translation).norm();
      return angle < 2 * std::numbers::pi / 180 && shift < 0.05 * pose.translation.norm();
    });
    if (!seen) distinct.push_back(&pose);
  }
  if (distinct.size() < 3) {
    throw Error("calibrate: the " + std::to_string(r.poses.size()) + " boards show " + std::to_string(distinct.size()) +
                " distinct pose(s) (within 2 deg and 5 % of their distance); a calibration needs at least 3, tilted "
                "differently and spread over the image");
  }
}

// A solve whose result cannot be right is an error, not a camera.
void check_solution(const CalibrationResult& r, int width, int height, const std::string& model) {
  const std::string what = "calibrate (" + model + "): ";
  const auto& p = r.camera.principal_point;
  if (!std::isfinite(r.rms_px) ||
      !std::all_of(r.parameters.begin(), r.parameters.end(), [](double v) { return std::isfinite(v); })) {
    throw Error(what + "the solve ended without a finite cost or parameters (check --board, --imagersize and the "
                       "corners)");
  }
  char text[160];
  if (!(p.x() >= 0 && p.x() <= width - 1 && p.y() >= 0 && p.y() <= height - 1)) {
    std::snprintf(text, sizeof text, "the principal point (%.1f, %.1f) lies outside the %dx%d image", p.x(), p.y(),
                  width, height);
    throw Error(what + text + " (check --imagersize and --board; the data do not determine this model)");
  }
  const double ay = r.camera.pixel_scale.y();
  if (!(ay >= 0.5 && ay <= 2.0)) {
    std::snprintf(text, sizeof text, "the pixel aspect a_y = %.3g is outside [0.5, 2]", ay);
    throw Error(what + text + " (check --imagersize and --board; the data do not determine this model)");
  }
}

// What every step of one calibration reads: the boards' corners and the board's
// points (the same for every board), and the image size.
struct Observations {
  const std::vector<const BoardObservation*>& boards;
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<Eigen::Vector3d>> all_points;  // points, once per board
  std::vector<std::vector<Eigen::Vector2d>> corners;
  int width, height;
  int threads;  // for independent solves (starts); each solve runs on one thread

  Observations(const std::vector<const BoardObservation*>& b, const BoardSpec& board, int w, int h, int t)
      : boards(b), points(board_points(board)), all_points(b.size(), points), width(w), height(h), threads(t) {
    for (const auto* o : boards) corners.push_back(o->corners);
  }
  CameraParameters camera(const Solve& s, const RadialModel& model) const {
    CameraParameters p;
    p.width = width, p.height = height, p.principal_point = s.center, p.pixel_scale = {1.0, s.ay}, p.model = model;
    return p;
  }
};

// Step 1, initialisation: equidistant cameras over a range of focal lengths
// (fisheye to narrow), boards placed from their rays; the focal length that
// reprojects best wins, and its board poses are refined with the intrinsics fixed.
Solve initial_solve(const Observations& o, const BoardSpec& board) {
  const Eigen::Vector2d center0((o.width - 1) / 2.0, (o.height - 1) / 2.0);
  constexpr int kSteps = 12;
  std::vector<Solve> scan(kSteps);
  std::vector<double> costs(kSteps, std::numeric_limits<double>::infinity());
  for_each_index(kSteps, o.threads, [&](int step) {
    const double f = o.width * 0.1 * std::pow(1.25, step);
    Solve s{{f}, center0, 1.0, {}};
    const Camera guess(o.camera(s, Equidistant<double>(f)));
    for (size_t b = 0; b < o.boards.size(); ++b) {
      std::vector<Eigen::Vector3d> rays(o.corners[b].size());
      for (size_t i = 0; i < rays.size(); ++i) {
        if (!guess.unproject(o.corners[b][i], &rays[i])) return;
      }
      const auto pose = pose_from_rays(rays, o.points, board);
      if (!pose) return;
      s.poses.push_back(pose_block(*pose));
    }
    // Score: the robust (truncated at 20 px) reprojection error of these poses.
    double cost = 0;
    for (size_t b = 0; b < o.boards.size(); ++b) {
      const BoardPose pose = pose_of(s.poses[b]);
      for (size_t i = 0; i < o.points.size(); ++i) {
        Eigen::Vector2d q;
        const double e = guess.project(to_camera(pose, o.points[i]), &q) ? (q - o.corners[b][i]).norm() : 20.0;
        cost += std::min(e, 20.0);
      }
    }
    scan[size_t(step)] = std::move(s), costs[size_t(step)] = cost;
  });
  const auto best = std::min_element(costs.begin(), costs.end());  // the first of equal costs
  if (!std::isfinite(*best)) throw Error("calibrate: could not initialise any board pose (are the corners valid?)");
  Solve start = std::move(scan[size_t(best - costs.begin())]);
  ceres::CauchyLoss loss(2.0);
  solve<Equidistant>(&start, o.all_points, o.corners, /*intrinsics_fixed=*/true, &loss);
  return start;
}

// Step 2, the robust joint solve of the target model from the start. Models
// non-linear in their shape parameters: a polynomial is calibrated first (linear in
// its parameters, so robust from the equidistant start); the model's own starts
// scaled by its k1, and that polynomial converted to the model (the multi-start fit
// of fishcam convert), each solved (on o.threads threads); the lowest cost wins,
// the first start among equal costs.
template <template <typename> class Model>
Solve robust_solve(const Observations& o, Solve start, const ModelSpec& spec) {
  std::vector<std::vector<double>> starts = {Model<double>::initial_params(start.model[0], spec.order)};
  if constexpr (!LinearInParams<Model<double>>) {
    Solve poly = start;
    poly.model = Polynomial<double>::initial_params(start.model[0], 4);
    ceres::CauchyLoss loss(1.0);
    solve<Polynomial>(&poly, o.all_points, o.corners, false, &loss);
    try {
      const CameraParameters p = o.camera(poly, Polynomial<double>(poly.model));
      const Camera polynomial(p);
      starts = Model<double>::fit_starts(poly.model[0]);
      // A start needs no dense fit: about 40 samples across the image.
      starts.push_back(model_params(fit_camera(sample_image(polynomial, std::max(8, o.width / 40), 4), spec, p).model));
      start = poly;
    } catch (const Error&) {  // no valid polynomial camera: the model's own starts
      starts = Model<double>::fit_starts(start.model[0]);
    }
  }
  // Every start screened for 25 iterations (enough to tell the basins apart), the
  // best one finished.
  constexpr int kScreening = 25;
  std::vector<Solve> candidates(starts.size(), start);
  std::vector<double> costs(starts.size());
  for_each_index(int(starts.size()), o.threads, [&](int k) {
    candidates[size_t(k)].model = starts[size_t(k)];
    ceres::CauchyLoss loss(1.0);
    costs[size_t(k)] = solve<Model>(&candidates[size_t(k)], o.all_points, o.corners, false, &loss, kScreening).final_cost;
  });
  // Finished to 1e-9: the robust solution only decides the outliers; the final
  // plain solve (step 4) polishes.
  Solve best = std::move(candidates[size_t(std::min_element(costs.begin(), costs.end()) - costs.begin())]);
  ceres::CauchyLoss loss(1.0);
  solve<Model>(&best, o.all_points, o.corners, false, &loss, 200, 1e-9);
  return best;
}

// Step 3, outliers: corners beyond 5 robust sigmas of the robust solve (median
// absolute error * 1.4826, the 2-D error's scale) and beyond 0.1 px (however exact
// the others, a corner that close is no outlier).
std::vector<CalibrationResult::Outlier> find_outliers(const Observations& o, const Camera& camera, const Solve& s) {
  std::vector<double> errors;
  std::vector<std::vector<double>> per_board(o.boards.size());
  for (size_t b = 0; b < o.boards.size(); ++b) {
    const BoardPose pose = pose_of(s.poses[b]);
    for (size_t i = 0; i < o.points.size(); ++i) {
      Eigen::Vector2d q;
      const double e = camera.project(to_camera(pose, o.points[i]), &q) ? (q - o.corners[b][i]).norm()
                                                                         : std::numeric_limits<double>::infinity();
      per_board[b].push_back(e);
      errors.push_back(e);
    }
  }
  std::nth_element(errors.begin(), errors.begin() + long(errors.size() / 2), errors.end());
  const double sigma = std::max(1.4826 * errors[errors.size() / 2], 1e-9);
  std::vector<CalibrationResult::Outlier> outliers;
  for (size_t b = 0; b < o.boards.size(); ++b) {
    for (size_t i = 0; i < o.points.size(); ++i) {
      if (per_board[b][i] > std::max(5 * sigma, 0.1)) outliers.push_back({o.boards[b]->filename, int(i), per_board[b][i]});
    }
  }
  return outliers;
}

// "f, xi and alpha trade against each other", with a hint where a model is
// degenerate (the unified family at xi ~ 0: xi then acts as a combination of f and
// alpha).
std::string undetermined_text(const std::vector<std::string>& names, bool poses, const std::string& model,
                              const std::vector<double>& parameters) {
  std::string text;
  for (size_t i = 0; i < names.size(); ++i) {
    text += (i == 0 ? "" : i + 1 == names.size() ? (poses ? ", " : " and ") : ", ") + names[i];
  }
  if (poses) text += names.empty() ? "the board poses" : " and the board poses";
  text += names.size() + (poses ? 1 : 0) > 1 ? " trade against each other: the data determine "
                                                "only a combination of them"
                                              : " has no effect on the data";
  const auto names_all = model_param_names(model, int(parameters.size()) - 3);
  const auto xi = std::find(names_all.begin(), names_all.end(), "xi");
  if (xi != names_all.end() && std::abs(parameters[size_t(xi - names_all.begin())]) < 0.05) {
    text += " (xi ~ 0, where the " + model + " model's xi acts as a combination of its other parameters; a model "
            "without xi, such as kannala-brandt, determines this lens)";
  }
  return text;
}

// Step 4, the final plain least squares without the outliers, its covariance, and
// the report: per-image and overall RMS (2-D norm), parameters and their sigmas.
template <template <typename> class Model>
void final_solve(const Observations& o, Solve s, const ModelSpec& spec, CalibrationResult* result) {
  // The corners that are not outliers, per board; a board left with fewer than 3
  // has no determined pose and is left out (and said so).
  std::vector<std::vector<Eigen::Vector3d>> kept_points;
  std::vector<std::vector<Eigen::Vector2d>> kept_corners;
  std::vector<size_t> used;  // index into o.boards of each kept board
  std::vector<std::array<double, 6>> poses;
  for (size_t b = 0; b < o.boards.size(); ++b) {
    std::vector<Eigen::Vector3d> points;
    std::vector<Eigen::Vector2d> corners;
    for (size_t i = 0; i < o.points.size(); ++i) {
      const bool outlier = std::any_of(result->outliers.begin(), result->outliers.end(), [&](const auto& x) {
        return x.filename == o.boards[b]->filename && size_t(x.corner) == i;
      });
      if (outlier) continue;
      points.push_back(o.points[i]);
      corners.push_back(o.corners[b][i]);
    }
    if (points.size() < 3) {
      result->warnings.push_back("image " + o.boards[b]->filename + ": " + std::to_string(o.points.size() - points.size()) +
                                 " of its corners are outliers; the image is left out");
      continue;
    }
    kept_points.push_back(std::move(points)), kept_corners.push_back(std::move(corners));
    used.push_back(b), poses.push_back(s.poses[b]);
  }
  if (used.size() < 3) throw Error("calibrate: fewer than 3 images keep enough corners after the outliers are removed");
  s.poses = std::move(poses);
  result->observations = solve<Model>(&s, kept_points, kept_corners, false, nullptr).num_residuals / 2;
  result->camera = o.camera(s, make_model(spec.name, s.model));
  const Camera final_camera(result->camera);
  double sum2 = 0;
  CalibrationRecord record = CalibrationRecord::nothing_observed();
  for (size_t b = 0; b < used.size(); ++b) {
    const BoardPose pose = pose_of(s.poses[b]);
    result->poses.push_back(pose);
    result->used_images.push_back(o.boards[used[b]]->filename);
    double board_sum2 = 0;
    for (size_t i = 0; i < kept_points[b].size(); ++i) {
      const Eigen::Vector3d point = to_camera(pose, kept_points[b][i]);
      Eigen::Vector2d q;
      final_camera.project(point, &q);
      board_sum2 += (q - kept_corners[b][i]).squaredNorm();
      record.observe(point);
    }
    sum2 += board_sum2;
    result->per_image_rms_px.push_back(std::sqrt(board_sum2 / double(std::max<size_t>(1, kept_points[b].size()))));
  }
  result->rms_px = std::sqrt(sum2 / double(std::max(1L, result->observations)));
  result->parameter_names = model_param_names(spec.name, int(s.model.size()));
  result->parameter_names.insert(result->parameter_names.end(), {"cx", "cy", "a_y"});
  result->parameters = s.model;
  result->parameters.insert(result->parameters.end(), {s.center.x(), s.center.y(), s.ay});

  const ParameterCovariance full = parameter_covariance<Model>(s, kept_points, kept_corners);
  const size_t intrinsics = result->parameters.size();
  result->noise_px = std::sqrt(full.variance);
  result->sigmas.assign(intrinsics, 0);
  for (size_t i = 0; i < intrinsics; ++i) result->sigmas[i] = std::sqrt(full.covariance(Eigen::Index(i), Eigen::Index(i)));
  for (const Eigen::VectorXd& direction : full.undetermined) {
    std::vector<std::string> names;
    for (size_t i = 0; i < intrinsics; ++i) {
      if (std::abs(direction[Eigen::Index(i)]) >= 0.1) {
        names.push_back(result->parameter_names[i]);
        result->sigmas[i] = std::numeric_limits<double>::quiet_NaN();
      }
    }
    const bool poses = direction.tail(direction.size() - Eigen::Index(intrinsics)).norm() >= 0.1;
    result->undetermined.push_back(undetermined_text(names, poses, spec.name, result->parameters));
  }
  record.covariance = projection_covariance_of(full, s);
  result->camera.calibration = record;
}

template <template <typename> class Model>
CalibrationResult calibrate_with(const std::vector<const BoardObservation*>& boards, const BoardSpec& board, int width,
                                 int height, const ModelSpec& spec, const CalibrationOptions& options) {
  const Observations o(boards, board, width, height, options.threads);
  const Solve robust = robust_solve<Model>(o, initial_solve(o, board), spec);
  CalibrationResult result;
  result.outliers = find_outliers(o, Camera(o.camera(robust, make_model(spec.name, robust.model))), robust);
  final_solve<Model>(o, robust, spec, &result);
  return result;
}

}  // namespace

CalibrationResult calibrate(const std::vector<BoardObservation>& observations, const BoardSpec& board, int width,
                            int height, const ModelSpec& spec, const CalibrationOptions& options) {
  check_board(board);
  if (options.threads < 1) throw Error("calibrate: threads must be >= 1, got " + std::to_string(options.threads));
  std::vector<const BoardObservation*> boards;
  for (const auto& o : observations) {
    if (o.corners.empty()) continue;
    // A board seen as (almost) one point fits any lens perfectly: refuse, not report rms 0.
    Eigen::Vector2d lo = o.corners.front(), hi = o.corners.front();
    for (const auto& c : o.corners) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
    if (!((hi - lo).maxCoeff() >= 2.0)) {
      throw Error("calibrate: image " + o.filename + ": its corners span less than 2 px (a degenerate board)");
    }
    boards.push_back(&o);
  }
  if (boards.size() < 3) {
    throw Error("calibrate: " + std::to_string(boards.size()) + " image(s) with a board; at least 3 are needed (" +
                "more, spread over the whole image, for a good calibration)");
  }
  check_board_order(boards, board);
  CalibrationResult result = with_model_class(spec.name, [&]<template <typename> class Model>() {
    return calibrate_with<Model>(boards, board, width, height, spec, options);
  });
  check_solution(result, width, height, spec.name);
  check_distinct_poses(result);
  // Coverage: the share of an 8 x 6 grid over the image that holds corners. A lens
  // calibrated from its centre only is extrapolated at the rim.
  bool cell[6][8] = {};
  for (const auto* b : boards) {
    for (const auto& c : b->corners) {
      const int i = std::clamp(int(c.x() * 8 / width), 0, 7), j = std::clamp(int(c.y() * 6 / height), 0, 5);
      cell[j][i] = true;
    }
  }
  int covered = 0;
  for (const auto& row : cell) covered += int(std::count(std::begin(row), std::end(row), true));
  if (covered < 24) {
    result.warnings.push_back("the boards cover only " + std::to_string(100 * covered / 48) +
                              "% of the image (8x6 grid): the model is extrapolated elsewhere; add boards near the rim");
  }
  return result;
}

namespace {

// One corner of a rig camera at one instant: p[0..2] the camera's intrinsics, then
// (cameras other than 0) camera 0 -> this camera, then the board -> camera 0.
template <template <typename> class Model>
struct RigCornerResidual {
  Eigen::Vector3d point;
  Eigen::Vector2d corner;
  int params;
  bool moved;  // false for camera 0, whose frame is the rig's

  template <typename T>
  bool operator()(T const* const* p, T* residuals) const {
    const Model<T> model = detail::model_from_block<Model>(p[0], params);
    const T mapping[4] = {p[1][0], p[1][1], T(1.0), p[2][0]};
    const T* board_pose = moved ? p[4] : p[3];
    const T board[3] = {T(point.x()), T(point.y()), T(point.z())};
    T in_rig[3], camera[3];
    ceres::AngleAxisRotatePoint(board_pose, board, in_rig);
    for (int k = 0; k < 3; ++k) in_rig[k] += board_pose[3 + k];
    if (moved) {
      ceres::AngleAxisRotatePoint(p[3], in_rig, camera);
      for (int k = 0; k < 3; ++k) camera[k] += p[3][3 + k];
    } else {
      for (int k = 0; k < 3; ++k) camera[k] = in_rig[k];
    }
    T pixel[2];
    project_radial(model, mapping, camera, pixel);
    residuals[0] = pixel[0] - corner.x();
    residuals[1] = pixel[1] - corner.y();
    return true;
  }
};


// The mean of rigid transforms: quaternions aligned in sign and averaged, translations averaged.
Pose mean_pose(const std::vector<Pose>& poses) {
  Eigen::Vector4d q = Eigen::Vector4d::Zero();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (const Pose& p : poses) {
    Eigen::Vector4d c = p.rotation.coeffs();
    if (c.dot(poses.front().rotation.coeffs()) < 0) c = -c;
    q += c, t += p.translation;
  }
  q.normalize();
  return {Eigen::Quaterniond(q[3], q[0], q[1], q[2]), t / double(poses.size())};
}

std::string instant_of(const std::string& filename) { return std::filesystem::path(filename).filename().string(); }

}  // namespace

RigCalibrationResult calibrate_rig(const std::vector<RigCamera>& cameras, const BoardSpec& board,
                                   const CalibrationOptions& options) {
  const size_t n = cameras.size();
  if (n < 2) throw Error("calibrate rig: needs at least 2 cameras, got " + std::to_string(n));
  const auto camera_name = [](size_t k) { return "camera " + std::to_string(k); };
  // 1. Each camera alone: intrinsics, its boards' poses, its outliers.
  std::vector<CalibrationResult> singles;
  for (size_t k = 0; k < n; ++k) {
    try {
      singles.push_back(calibrate(cameras[k].observations, board, cameras[k].width, cameras[k].height,
                                  cameras[k].model, options));
    } catch (const Error& e) {
      throw Error(camera_name(k) + ": " + e.what());
    }
  }
  // The instants, and which camera saw which board (in that camera's frame).
  std::map<std::string, int> instant_index;
  std::vector<std::map<int, Pose>> seen(n);
  std::vector<std::map<int, const BoardObservation*>> observed(n);
  for (size_t k = 0; k < n; ++k) {
    std::map<std::string, const BoardObservation*> by_name;
    for (const auto& o : cameras[k].observations) by_name[o.filename] = &o;
    for (size_t b = 0; b < singles[k].used_images.size(); ++b) {
      const std::string instant = instant_of(singles[k].used_images[b]);
      const int i = instant_index.emplace(instant, int(instant_index.size())).first->second;
      if (seen[k].count(i)) throw Error(camera_name(k) + ": two images of the instant " + instant);
      seen[k][i] = singles[k].poses[b];
      observed[k][i] = by_name.at(singles[k].used_images[b]);
    }
  }
  // 2. Camera poses relative to camera 0 (cam0 -> cam k), through shared instants,
  // breadth first from camera 0.
  std::vector<std::optional<Pose>> from_rig(n);
  from_rig[0] = Pose{};
  for (bool grew = true; grew;) {
    grew = false;
    for (size_t b = 0; b < n; ++b) {
      if (from_rig[b]) continue;
      for (size_t a = 0; a < n && !from_rig[b]; ++a) {
        if (!from_rig[a]) continue;
        std::vector<Pose> estimates;
        for (const auto& [i, pose_b] : seen[b]) {
          if (const auto it = seen[a].find(i); it != seen[a].end()) {
            estimates.push_back(compose(compose(pose_b, inverse(it->second)), *from_rig[a]));
          }
        }
        if (!estimates.empty()) from_rig[b] = mean_pose(estimates), grew = true;
      }
    }
  }
  for (size_t k = 0; k < n; ++k) {
    if (!from_rig[k]) {
      throw Error(camera_name(k) + " shares no board instant with camera 0 or the cameras linked to it (images of "
                                   "the same instant must have the same file name)");
    }
  }
  // 3. The joint solve: every camera's intrinsics, cameras 1.. relative to camera 0,
  // each instant's board relative to camera 0 (placed from the first camera that saw it).
  const int instants = int(instant_index.size());
  std::vector<Solve> intrinsics(n);
  for (size_t k = 0; k < n; ++k) {
    const auto& p = singles[k].camera;
    intrinsics[k] = Solve{model_params(p.model), p.principal_point, p.pixel_scale.y(), {}};
  }
  std::vector<std::array<double, 6>> camera_blocks(n);
  std::vector<std::array<double, 6>> board_blocks(static_cast<size_t>(instants));
  for (size_t k = 0; k < n; ++k) camera_blocks[k] = pose_block(*from_rig[k]);
  std::vector<bool> placed(size_t(instants), false);
  for (size_t k = 0; k < n; ++k) {
    for (const auto& [i, pose] : seen[k]) {
      if (placed[size_t(i)]) continue;
      board_blocks[size_t(i)] = pose_block(compose(inverse(*from_rig[k]), pose));
      placed[size_t(i)] = true;
    }
  }
  const auto points = board_points(board);
  std::vector<std::set<std::pair<std::string, int>>> outliers(n);  // (image, corner) per camera, from step 1
  for (size_t k = 0; k < n; ++k) {
    for (const auto& o : singles[k].outliers) outliers[k].insert({o.filename, o.corner});
  }
  ceres::Problem problem;
  std::vector<long> corners_of(n, 0);
  for (size_t k = 0; k < n; ++k) {
    const int params = int(intrinsics[k].model.size());
    with_model_class(cameras[k].model.name, [&]<template <typename> class Model>() {
      for (const auto& [i, o] : observed[k]) {
        for (size_t c = 0; c < o->corners.size(); ++c) {
          if (outliers[k].count({o->filename, int(c)})) continue;
          auto* cost = new ceres::DynamicAutoDiffCostFunction<RigCornerResidual<Model>, 8>(
              new RigCornerResidual<Model>{points[c], o->corners[c], params, k > 0});
          cost->AddParameterBlock(params);
          cost->AddParameterBlock(2);
          cost->AddParameterBlock(1);
          std::vector<double*> blocks = {intrinsics[k].model.data(), intrinsics[k].center.data(), &intrinsics[k].ay};
          if (k > 0) cost->AddParameterBlock(6), blocks.push_back(camera_blocks[k].data());
          cost->AddParameterBlock(6);
          blocks.push_back(board_blocks[size_t(i)].data());
          cost->SetNumResiduals(2);
          problem.AddResidualBlock(cost, nullptr, blocks);
          ++corners_of[k];
        }
      }
      detail::bound_model_block<Model>(&problem, intrinsics[k].model.data(), params);
    });
  }
  ceres::Solver::Summary summary;
  ceres::Solve(detail::solver_options(ceres::SPARSE_SCHUR), &problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("calibrate rig: the joint solve failed: " + summary.message);
  // 4. Covariance of everything; the report per camera.
  std::vector<double*> blocks;
  std::vector<Eigen::Index> intrinsic_start(n), pose_start(n, -1);
  Eigen::Index column = 0;
  for (size_t k = 0; k < n; ++k) {
    intrinsic_start[k] = column;
    blocks.insert(blocks.end(), {intrinsics[k].model.data(), intrinsics[k].center.data(), &intrinsics[k].ay});
    column += Eigen::Index(intrinsics[k].model.size()) + 3;
  }
  for (size_t k = 1; k < n; ++k) pose_start[k] = column, blocks.push_back(camera_blocks[k].data()), column += 6;
  for (auto& b : board_blocks) blocks.push_back(b.data());
  const ParameterCovariance full = covariance_of(&problem, blocks);

  RigCalibrationResult out;
  out.instants = instants;
  out.rms_px = std::sqrt(2 * summary.final_cost / double(std::max(1L, std::accumulate(corners_of.begin(), corners_of.end(), 0L))));
  for (size_t k = 0; k < n; ++k) {
    CalibrationResult r = singles[k];
    const Pose rig_to_camera = pose_of(camera_blocks[k]);
    CameraParameters p = r.camera;
    p.model = make_model(cameras[k].model.name, intrinsics[k].model);
    p.principal_point = intrinsics[k].center;
    p.pixel_scale = {1.0, intrinsics[k].ay};
    p.pose = inverse(rig_to_camera);  // camera -> camera 0
    const Camera camera(p);
    // Reprojection, board poses (in this camera's frame) and observed angles from the joint solution.
    r.poses.clear(), r.used_images.clear(), r.per_image_rms_px.clear();
    double sum2 = 0;
    CalibrationRecord& record = *p.calibration;
    const Eigen::MatrixXd own_covariance = record.covariance;
    record = CalibrationRecord::nothing_observed();
    record.covariance = own_covariance;
    for (const auto& [i, o] : observed[k]) {
      const Pose board_pose = compose(rig_to_camera, pose_of(board_blocks[size_t(i)]));
      double board_sum2 = 0;
      long used = 0;
      for (size_t c = 0; c < o->corners.size(); ++c) {
        if (outliers[k].count({o->filename, int(c)})) continue;
        const Eigen::Vector3d point = board_pose.rotation * points[c] + board_pose.translation;
        Eigen::Vector2d q;
        camera.project(point, &q);
        board_sum2 += (q - o->corners[c]).squaredNorm(), ++used;
        record.observe(point);
      }
      sum2 += board_sum2;
      r.poses.push_back(board_pose);
      r.used_images.push_back(o->filename);
      r.per_image_rms_px.push_back(std::sqrt(board_sum2 / double(std::max(1L, used))));
    }
    r.rms_px = std::sqrt(sum2 / double(std::max(1L, corners_of[k])));
    r.observations = corners_of[k];
    r.parameters = intrinsics[k].model;
    r.parameters.insert(r.parameters.end(), {intrinsics[k].center.x(), intrinsics[k].center.y(), intrinsics[k].ay});
    r.undetermined.clear();
    for (size_t i = 0; i < r.parameters.size(); ++i) {
      const Eigen::Index at = intrinsic_start[k] + Eigen::Index(i);
      r.sigmas[i] = std::sqrt(full.covariance(at, at));
    }
    for (const Eigen::VectorXd& direction : full.undetermined) {
      std::vector<std::string> names;
      for (size_t i = 0; i < r.parameters.size(); ++i) {
        if (std::abs(direction[intrinsic_start[k] + Eigen::Index(i)]) >= 0.1) {
          names.push_back(r.parameter_names[i]);
          r.sigmas[i] = std::numeric_limits<double>::quiet_NaN();
        }
      }
      if (!names.empty()) r.undetermined.push_back(undetermined_text(names, false, cameras[k].model.name, r.parameters));
    }
    r.noise_px = std::sqrt(full.variance);
    r.camera = p;
    check_solution(r, cameras[k].width, cameras[k].height, camera_name(k) + " " + cameras[k].model.name);
    double rotation = 0, translation = 0;
    if (k > 0) {
      for (int j = 0; j < 3; ++j) {
        rotation = std::max(rotation, std::sqrt(full.covariance(pose_start[k] + j, pose_start[k] + j)));
        translation = std::max(translation, std::sqrt(full.covariance(pose_start[k] + 3 + j, pose_start[k] + 3 + j)));
      }
    }
    out.rotation_sigma_rad.push_back(rotation);
    out.translation_sigma.push_back(translation);
    for (const auto& w : r.warnings) out.warnings.push_back(camera_name(k) + ": " + w);
    out.cameras.push_back(std::move(r));
  }
  for (const Eigen::VectorXd& direction : full.undetermined) {
    bool intrinsic = false;
    for (size_t k = 0; k < n; ++k) {
      intrinsic = intrinsic || direction.segment(intrinsic_start[k], Eigen::Index(out.cameras[k].parameters.size())).norm() >= 0.1;
    }
    if (!intrinsic) out.warnings.push_back("the data do not determine the cameras' relative poses fully (a direction of the joint solve has no curvature)");
  }
  return out;
}

Eigen::Matrix2d projection_covariance(const Camera& camera, const Eigen::Vector2d& pixel,
                                      std::optional<double> distance) {
  const auto& record = camera.parameters().calibration;
  if (!record || record->covariance.size() == 0) {
    throw Error("projection uncertainty: the camera carries no calibration covariance (fishcam calibrate writes one "
                "into fishcam JSON)");
  }
  if (distance && !(*distance > 0 && std::isfinite(*distance))) {
    throw Error("projection uncertainty: the distance must be finite and > 0");
  }
  Eigen::Vector3d ray;
  if (!camera.unproject(pixel, &ray)) return Eigen::Matrix2d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d point = distance ? Eigen::Vector3d(*distance * ray) : ray;
  std::vector<double> model = model_params(camera.model());
  Eigen::Vector2d center = camera.principal_point();
  double ay = camera.pixel_scale().y();
  const int n = int(model.size());
  Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor> d_model(2, n);
  Eigen::Matrix<double, 2, 2, Eigen::RowMajor> d_center;
  Eigen::Matrix<double, 2, 1> d_ay;
  Eigen::Matrix<double, 2, 3, Eigen::RowMajor> d_point;
  const std::string name(model_name(camera.model()));
  with_model_class(name, [&]<template <typename> class Model>() {
    ceres::DynamicAutoDiffCostFunction<PointProjection<Model>, 8> f(
        new PointProjection<Model>{n, camera.pixel_scale().x()});
    f.AddParameterBlock(n);
    f.AddParameterBlock(2);
    f.AddParameterBlock(1);
    f.AddParameterBlock(3);
    f.SetNumResiduals(2);
    const double* blocks[4] = {model.data(), center.data(), &ay, point.data()};
    double* jacobians[4] = {d_model.data(), d_center.data(), d_ay.data(), d_point.data()};
    double q[2];
    f.Evaluate(blocks, q, jacobians);
  });
  // d pixel / d (model, cx, cy, a_y, w, t): a board-fixed point moves to p + w x p + t.
  Eigen::MatrixXd jacobian(2, n + 9);
  jacobian << d_model, d_center, d_ay, -d_point * cross_matrix(point), (distance ? d_point : Eigen::Matrix<double, 2, 3, Eigen::RowMajor>::Zero());
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
