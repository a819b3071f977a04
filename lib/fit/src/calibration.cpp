#include "fishcam/fit/calibration.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

#include "calibration_internal.hpp"
#include "fishcam/core/parallel.hpp"

namespace fishcam {
namespace detail {

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

Eigen::Vector3d warped(const BoardSpec& board, const std::vector<double>& warp, const Eigen::Vector3d& point) {
  if (warp.empty()) return point;
  return point + Eigen::Vector3d(0, 0, Eigen::Vector2d(warp[0], warp[1]).dot(warp_factors(board, point)));
}

void board_jacobians(const Eigen::Matrix<double, 2, 3>& dpixel, const Eigen::Vector3d& rotated, const double* pose,
                     const std::optional<Eigen::Vector2d>& warp, double* d_pose, double* d_warp) {
  if (d_pose) {
    Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> d(d_pose);
    d.leftCols<3>() = -dpixel * cross_matrix(rotated) * left_jacobian({pose[0], pose[1], pose[2]});
    d.rightCols<3>() = dpixel;
  }
  if (d_warp && warp) {  // the point moves along the board's z, R e_z per unit of warp
    const double unit_z[3] = {0, 0, 1};
    Eigen::Vector3d normal;
    ceres::AngleAxisRotatePoint(pose, unit_z, normal.data());
    Eigen::Map<Eigen::Matrix<double, 2, 2, Eigen::RowMajor>>(d_warp, 2, 2) = (dpixel * normal) * warp->transpose();
  }
}

double principal_point_offset(const Eigen::Vector2d& p, int width, int height) {
  return std::max(std::abs(p.x() - (width - 1) / 2.0) / width, std::abs(p.y() - (height - 1) / 2.0) / height);
}

// A solve whose result cannot be right is an error, not a camera.
void check_solution(const CalibrationResult& r, int width, int height, const std::string& model) {
  const std::string what = "calibrate (" + model + "): ";
  const auto& p = r.camera.grid.principal_point;
  if (!std::isfinite(r.rms_px) ||
      !std::all_of(r.parameters.begin(), r.parameters.end(), [](double v) { return std::isfinite(v); })) {
    throw Error(what +
                "the solve ended without a finite cost or parameters (check --board, --imagersize and the "
                "corners)");
  }
  char text[200];
  if (!(p.x() >= 0 && p.x() <= width - 1 && p.y() >= 0 && p.y() <= height - 1)) {
    std::snprintf(text, sizeof text, "the principal point (%.1f, %.1f) lies outside the %dx%d image", p.x(), p.y(),
                  width, height);
    throw Error(what + text + " (check --imagersize and --board; the data do not determine this model)");
  }
  const double off = principal_point_offset(p, width, height);
  if (off > kPrincipalPointRefused) {
    std::snprintf(text, sizeof text,
                  "the principal point (%.1f, %.1f) lies %.0f %% of the image size from the centre of the %dx%d "
                  "image (more than %.0f %%)",
                  p.x(), p.y(), 100 * off, width, height, 100 * kPrincipalPointRefused);
    throw Error(what + text + ": check --imagersize (the size the corners were detected in)");
  }
  const double ay = r.camera.grid.pixel_scale.y();
  if (!(ay >= 0.5 && ay <= 2.0)) {
    std::snprintf(text, sizeof text, "the pixel aspect a_y = %.3g is outside [0.5, 2]", ay);
    throw Error(what + text + " (check --imagersize and --board; the data do not determine this model)");
  }
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
    text += " (xi ~ 0, where the " + model +
            " model's xi acts as a combination of its other parameters; a model "
            "without xi, such as kannala-brandt, determines this lens)";
  }
  return text;
}

double outlier_limit_px(std::vector<double> errors_px) {
  if (errors_px.empty()) return std::numeric_limits<double>::infinity();
  const auto middle = errors_px.begin() + long(errors_px.size() / 2);
  std::nth_element(errors_px.begin(), middle, errors_px.end());
  const double sigma = std::max(1.4826 * *middle, 1e-9);
  return std::max(5 * sigma, 0.1);
}

// A view whose corners cannot place a board: ids that do not fit it, or a partial
// board with fewer than 4 corners or all in one row or one column (its pose turns
// freely about that line).
void check_placeable(const BoardSpec& board, const BoardObservation& o, const std::string& what) {
  try {
    check_observation(board, o);
  } catch (const Error& e) {
    throw Error(what + ": " + e.what());
  }
  if (o.ids.empty() || o.corners.empty()) return;
  std::set<int> columns, rows;
  for (int id : o.ids) columns.insert(id % board.cols), rows.insert(id / board.cols);
  if (o.corners.size() < 4 || columns.size() < 2 || rows.size() < 2) {
    throw Error(what + ": image " + text_for_message(o.filename) + ": its " + std::to_string(o.corners.size()) +
                " corners (of a partial board) span " + std::to_string(columns.size()) + " column(s) and " +
                std::to_string(rows.size()) +
                " row(s); a board pose needs at least 4 corners in 2 of each (leave the image out)");
  }
}

}  // namespace detail

namespace {

using detail::check_solution;
using detail::CornerCost;
using detail::LensCornerCost;
using detail::LensRegularisation;
using detail::ParameterCovariance;
using detail::pose_block;
using detail::pose_of;
using detail::projection_covariance_of;
using detail::Solve;
using detail::TangentialCornerResidual;
using detail::undetermined_text;

Eigen::Vector3d to_camera(const BoardPose& pose, const Eigen::Vector3d& p) {
  return pose.rotation * p + pose.translation;
}

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
std::optional<BoardPose> pose_from_rays(const std::vector<Eigen::Vector3d>& rays,
                                        const std::vector<Eigen::Vector3d>& points, const BoardSpec& board) {
  // The distance from the angle between neighbours along a row (consecutive points one
  // spacing apart); a partial board without such neighbours: between any
  // consecutive points.
  const auto angle_between = [&](size_t k) {
    return std::atan2(rays[k].cross(rays[k + 1]).norm(), rays[k].dot(rays[k + 1]));
  };
  double angle = 0, length = 0;
  for (size_t k = 0; k + 1 < rays.size(); ++k) {
    const double step = (points[k + 1] - points[k]).norm();
    if (std::abs(step - board.spacing) <= 1e-9 * board.spacing) angle += angle_between(k), length += board.spacing;
  }
  for (size_t k = 0; length == 0 && k + 1 < rays.size(); ++k) {
    angle += angle_between(k), length += (points[k + 1] - points[k]).norm();
  }
  if (!(angle > 0)) return std::nullopt;
  const double distance = length / angle;
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

// One residual block per corner, in board order then corner order (the order
// fixes the Jacobian's rows, and so every sum over them).
template <template <typename> class Model>
void add_corner_residuals(ceres::Problem* problem, Solve* s, const std::vector<std::vector<Eigen::Vector3d>>& points,
                          const std::vector<std::vector<Eigen::Vector2d>>& corners, ceres::LossFunction* loss) {
  const int n = static_cast<int>(s->model.size()), terms = static_cast<int>(s->tangential.size());
  const bool warped = !s->warp.empty();
  for (size_t b = 0; b < corners.size(); ++b) {
    for (size_t i = 0; i < corners[b].size(); ++i) {
      const std::optional<Eigen::Vector2d> factors =
          warped ? std::optional(warp_factors(s->board, points[b][i])) : std::nullopt;
      if (s->lens) {
        auto* cost = new LensCornerCost(s->lens.get(), points[b][i], corners[b][i], factors);
        std::vector<double*> blocks = {s->model.data(), s->lens_values.data(), s->center.data(), &s->ay,
                                       s->poses[b].data()};
        if (warped) blocks.push_back(s->warp.data());
        problem->AddResidualBlock(cost, loss, blocks);
        continue;
      }
      if (terms == 0) {
        auto* cost = new CornerCost<Model>(points[b][i], corners[b][i], n, factors);
        std::vector<double*> blocks = {s->model.data(), s->center.data(), &s->ay, s->poses[b].data()};
        if (warped) blocks.push_back(s->warp.data());
        problem->AddResidualBlock(cost, loss, blocks);
        continue;
      }
      auto* cost = new ceres::DynamicAutoDiffCostFunction<TangentialCornerResidual<Model>, 8>(
          new TangentialCornerResidual<Model>{points[b][i], corners[b][i], n, terms, factors});
      for (const int size : {n, terms, 2, 1, 6}) cost->AddParameterBlock(size);
      std::vector<double*> blocks = {s->model.data(), s->tangential.data(), s->center.data(), &s->ay,
                                     s->poses[b].data()};
      if (warped) cost->AddParameterBlock(2), blocks.push_back(s->warp.data());
      cost->SetNumResiduals(2);
      problem->AddResidualBlock(cost, loss, blocks);
    }
  }
}

// The intrinsics' blocks of a solve, in the order of its parameters and covariance.
std::vector<double*> intrinsic_blocks(Solve* s) {
  std::vector<double*> blocks = {s->model.data(), s->center.data(), &s->ay};
  if (!s->tangential.empty()) blocks.insert(blocks.begin() + 1, s->tangential.data());
  if (s->lens) blocks.insert(blocks.begin() + 1, s->lens_values.data());
  return blocks;
}

// An mrcal lens's regularisation for a solve over these corners (none without a lens).
std::unique_ptr<LensRegularisation> lens_regularisation(const Solve& s,
                                                        const std::vector<std::vector<Eigen::Vector2d>>& corners) {
  if (!s.lens) return nullptr;
  long count = 0;
  for (const auto& board : corners) count += long(board.size());
  return std::make_unique<LensRegularisation>(*s.lens, count);
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
  if (s->lens && !s->lens_values_held) {  // the problem owns its cost functions
    problem.AddResidualBlock(lens_regularisation(*s, corners).release(), nullptr, s->lens_values.data());
  }
  detail::bound_model_block<Model>(&problem, s->model.data(), int(s->model.size()));
  if (intrinsics_fixed) {
    for (double* block : intrinsic_blocks(s)) problem.SetParameterBlockConstant(block);
    if (!s->warp.empty()) problem.SetParameterBlockConstant(s->warp.data());
  }
  if (s->core_held) {
    for (double* block : {s->model.data(), s->center.data(), &s->ay}) problem.SetParameterBlockConstant(block);
  }
  if (s->lens && s->lens_values_held) problem.SetParameterBlockConstant(s->lens_values.data());
  ceres::Solver::Summary summary;
  ceres::Solver::Options options = detail::solver_options(ceres::DENSE_SCHUR);
  options.max_num_iterations = max_iterations;
  options.function_tolerance = options.parameter_tolerance = tolerance;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("calibrate: the solve failed: " + summary.message);
  return summary;
}

template <template <typename> class Model>
ParameterCovariance parameter_covariance(Solve s, const std::vector<std::vector<Eigen::Vector3d>>& points,
                                         const std::vector<std::vector<Eigen::Vector2d>>& corners) {
  ceres::Problem problem;
  add_corner_residuals<Model>(&problem, &s, points, corners, nullptr);
  std::vector<double*> poses, kept = intrinsic_blocks(&s);
  for (auto& pose : s.poses) poses.push_back(pose.data());
  if (!s.warp.empty()) kept.push_back(s.warp.data());  // after the intrinsics (projection_covariance_of)
  if (!s.core_held) return detail::covariance_of(&problem, kept, poses);
  // A lens's values over a held core: the solve's covariance (regularised as solved),
  // the core's rows and columns 0 where the record has them.
  const Eigen::Index n = Eigen::Index(s.model.size()), k = Eigen::Index(s.lens_values.size());
  std::vector<double*> solved = {s.lens_values.data()};
  if (!s.warp.empty()) solved.push_back(s.warp.data());
  ParameterCovariance c = detail::covariance_of(&problem, solved, poses, lens_regularisation(s, corners)->normal());
  std::vector<Eigen::Index> place(size_t(c.covariance.rows()));
  for (Eigen::Index i = 0; i < c.covariance.rows(); ++i) place[size_t(i)] = i < k ? n + i : n + i + 3;
  const Eigen::Index size = c.covariance.rows() + n + 3;
  c.covariance = detail::embedded(c.covariance, place, size);
  for (Eigen::VectorXd& direction : c.undetermined) {
    Eigen::VectorXd full = Eigen::VectorXd::Zero(size);
    for (size_t i = 0; i < place.size(); ++i) full[place[i]] = direction[Eigen::Index(i)];
    direction = full;
  }
  return c;
}

// How far corners, read as a cols x rows grid in board order, are from a grid: the
// median over the corners of the larger of their second differences along the row
// and along the column, over the mean step. A lens bends a board smoothly, so
// neighbouring steps along a row or a column stay alike (well under 0.25 even at a
// fisheye's rim); corners read with the wrong row length jump back and forth
// between rows along the columns and give 1 or more. On a grid whose steps alternate
// (an AprilGrid's tag sides and gaps: BoardSpec::gap) the middle corner is compared
// with where it divides its neighbours' segment on the board.
std::vector<double> grid_bends(const BoardObservation& view, const BoardSpec& board) {
  const int cols = board.cols, rows = board.rows;
  // Each board corner's detection, if the view has it (a partial board: the triples it
  // has whole).
  std::vector<const Eigen::Vector2d*> by_id(size_t(cols * rows), nullptr);
  for (size_t k = 0; k < view.corners.size(); ++k) by_id[size_t(view.id(k))] = &view.corners[k];
  const auto has = [&](int i, int j) { return by_id[size_t(j * cols + i)] != nullptr; };
  const auto at = [&](int i, int j) { return *by_id[size_t(j * cols + i)]; };
  // `share`: where `here` lies between `before` and `after` on the board (1/2 on a chessboard).
  const auto bend = [](const Eigen::Vector2d& before, const Eigen::Vector2d& here, const Eigen::Vector2d& after,
                       double share) {
    const double step = ((here - before).norm() + (after - here).norm()) / 2;
    return step > 0 ? 2 * (here - before - share * (after - before)).norm() / step
                    : std::numeric_limits<double>::infinity();
  };
  const auto share_at = [&](int i) {
    return (board.coordinate(i) - board.coordinate(i - 1)) / (board.coordinate(i + 1) - board.coordinate(i - 1));
  };
  std::vector<double> points;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      double worst = -1;
      if (!has(i, j)) continue;
      if (i > 0 && i + 1 < cols && has(i - 1, j) && has(i + 1, j)) {
        worst = std::max(worst, bend(at(i - 1, j), at(i, j), at(i + 1, j), share_at(i)));
      }
      if (j > 0 && j + 1 < rows && has(i, j - 1) && has(i, j + 1)) {
        worst = std::max(worst, bend(at(i, j - 1), at(i, j), at(i, j + 1), share_at(j)));
      }
      if (worst >= 0) points.push_back(worst);
    }
  }
  return points;
}

double median_of(std::vector<double> values) {
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + long(values.size() / 2), values.end());
  return values[values.size() / 2];
}

// The median over boards of their median bend (a 2 x 2 board: nothing to tell, 0).
double median_grid_disorder(const std::vector<const BoardObservation*>& boards, const BoardSpec& board) {
  std::vector<double> disorder;
  for (const auto* b : boards) disorder.push_back(median_of(grid_bends(*b, board)));
  return median_of(disorder);
}

// The median over boards of the share of corners that bend by more than half a step.
// A board read with a row length that divides neither its rows nor its corner count
// evenly (2 x 27 for a 9 x 6 board) keeps a low median bend -- most triples lie in one
// row -- but every wrap from one row to the next bends by a step or more.
double median_disordered_share(const std::vector<const BoardObservation*>& boards, const BoardSpec& board) {
  std::vector<double> shares;
  for (const auto* b : boards) {
    const std::vector<double> bends = grid_bends(*b, board);
    const auto bent = std::count_if(bends.begin(), bends.end(), [](double v) { return !(v <= 0.5); });
    shares.push_back(bends.empty() ? 0 : double(bent) / double(bends.size()));
  }
  return median_of(shares);
}

// Refuses corners whose order contradicts the board: most often a W x H board given
// as --board HxW, which has the same corner count and so reads without complaint.
void check_board_order(const std::vector<const BoardObservation*>& boards, const BoardSpec& board) {
  constexpr double kOrdered = 0.25, kDisordered = 0.5;
  // A board size with the right corner count but another row length (2x27 for 9x6)
  // keeps most triples in a row, so its median bend may pass; the wraps between rows
  // (the share of corners bent by more than half a step) do not.
  constexpr double kWrapped = 0.1, kClean = 0.02;
  const double given = median_grid_disorder(boards, board);
  const double share = given > kDisordered ? 1.0 : median_disordered_share(boards, board);
  if (share <= kWrapped) return;
  const std::string as_given = std::to_string(board.cols) + "x" + std::to_string(board.rows);
  const int n = board.cols * board.rows;
  for (int cols = 2; cols <= n / 2; ++cols) {  // the row length that explains the corners
    if (n % cols != 0 || cols == board.cols || n / cols < 2) continue;
    const BoardSpec other{cols, n / cols, 1.0};  // a chessboard of that row length
    if (median_grid_disorder(boards, other) <= kOrdered && median_disordered_share(boards, other) <= kClean) {
      const std::string fits = std::to_string(cols) + "x" + std::to_string(n / cols);
      throw Error("calibrate: the corners are ordered as a " + fits + " board, not " + as_given + " (rows of " +
                  std::to_string(cols) + "): pass --board " + fits);
    }
  }
  char measure[64];
  if (given > kDisordered) {
    std::snprintf(measure, sizeof measure, "median cell distortion %.2f", given);
  } else {
    std::snprintf(measure, sizeof measure, "%.0f %% of corners off the grid", 100 * share);
  }
  throw Error(
      "calibrate: the corners are not in the board order of a " + as_given + " board (" + measure +
      ", a grid gives < 0.25 and none): check --board (or --target) and that each image lists its corners row by row");
}

// Corners outside the image cannot have been detected in it: the image size given
// is not the one the corners were found in (a resized image, another camera's size).
void check_corners_in_image(const std::vector<BoardObservation>& observations, int width, int height) {
  long outside = 0, total = 0;
  const BoardObservation* first_image = nullptr;
  Eigen::Vector2d first{};
  for (const auto& o : observations) {
    for (const auto& c : o.corners) {
      ++total;
      if (c.x() >= -detail::kCornerMarginPx && c.x() <= width - 1 + detail::kCornerMarginPx &&
          c.y() >= -detail::kCornerMarginPx && c.y() <= height - 1 + detail::kCornerMarginPx) {
        continue;
      }
      if (outside++ == 0) first_image = &o, first = c;
    }
  }
  if (outside == 0) return;
  char text[320];
  std::snprintf(text, sizeof text,
                "calibrate: %ld of %ld corners lie outside the %dx%d image (first: image %s at (%.1f, %.1f)): "
                "check --imagersize (the size of the images the corners were detected in)",
                outside, total, width, height, text_for_message(first_image->filename).c_str(), first.x(), first.y());
  throw Error(text);
}

// The same photo under two names (or the same corners file lines twice) would count
// its corners twice: the solve then claims more certainty than the data hold.
void check_no_duplicate_views(const std::vector<const BoardObservation*>& boards) {
  // Sorted by the first corner, so only neighbours in that order are compared.
  std::vector<const BoardObservation*> order(boards);
  std::sort(order.begin(), order.end(),
            [](const auto* a, const auto* b) { return a->corners[0].x() < b->corners[0].x(); });
  for (size_t a = 0; a < order.size(); ++a) {
    for (size_t b = a + 1; b < order.size() && order[b]->corners[0].x() - order[a]->corners[0].x() <= 0.01; ++b) {
      bool same = order[a]->corners.size() == order[b]->corners.size() && order[a]->ids == order[b]->ids;
      for (size_t c = 0; same && c < order[a]->corners.size(); ++c) {
        same = (order[a]->corners[c] - order[b]->corners[c]).cwiseAbs().maxCoeff() <= 0.01;
      }
      if (same) {
        const bool in_order = order[a] < order[b];
        throw Error("calibrate: images " + text_for_message((in_order ? order[a] : order[b])->filename) + " and " +
                    text_for_message((in_order ? order[b] : order[a])->filename) +
                    " have the same corners (within 0.01 px): the same photo twice? (remove one)");
      }
    }
  }
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

// One board's pose through `camera` from `start`, over the corners not in `left_out`
// (under `loss`; nullptr: plain least squares).
ceres::Solver::Summary solve_board_pose(const Camera& camera, const std::vector<Eigen::Vector3d>& points,
                                        const BoardObservation& view, const std::vector<bool>& left_out,
                                        ceres::LossFunction* loss, std::array<double, 6>* pose) {
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (size_t i = 0; i < points.size(); ++i) {
    if (left_out[i]) continue;
    auto* cost = new ceres::DynamicAutoDiffCostFunction<detail::FixedCameraCornerResidual, 6>(
        new detail::FixedCameraCornerResidual(&camera, points[i], view.corners[i], false));
    cost->AddParameterBlock(6);
    cost->SetNumResiduals(2);
    problem.AddResidualBlock(cost, loss, pose->data());
  }
  ceres::Solver::Summary summary;
  ceres::Solve(detail::solver_options(ceres::DENSE_QR), &problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("locate boards: image " + view.filename + ": " + summary.message);
  return summary;
}

// Each corner's error at `pose` (infinite where the point does not project).
std::vector<double> corner_errors(const Camera& camera, const std::vector<Eigen::Vector3d>& points,
                                  const BoardObservation& view, const std::array<double, 6>& pose) {
  std::vector<double> errors;
  const BoardPose board_pose = pose_of(pose);
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d q;
    errors.push_back(camera.project(to_camera(board_pose, points[i]), &q) ? (q - view.corners[i]).norm()
                                                                          : std::numeric_limits<double>::infinity());
  }
  return errors;
}

// What every step of one calibration reads: the boards' corners and the board's
// points (the same for every board), and the image size.
struct Observations {
  const std::vector<const BoardObservation*>& boards;
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<Eigen::Vector3d>> all_points;  // the points each board's corners are
  std::vector<std::vector<Eigen::Vector2d>> corners;
  int width, height;
  int threads;  // for independent solves (starts); each solve runs on one thread

  Observations(const std::vector<const BoardObservation*>& b, const BoardSpec& board, int w, int h, int t)
      : boards(b), points(board_points(board)), width(w), height(h), threads(t) {
    for (const auto* o : boards) corners.push_back(o->corners), all_points.push_back(observed_points(points, *o));
  }
  CameraParameters camera(const Solve& s, const RadialModel& model) const {
    CameraParameters p;
    p.width = width, p.height = height, p.grid.principal_point = s.center, p.grid.pixel_scale = {1.0, s.ay},
    p.model = model;
    if (!s.tangential.empty()) {
      std::array<double, 6> terms{};
      std::copy(s.tangential.begin(), s.tangential.end(), terms.begin());
      p.distortion = TangentialDistortion{TangentialTerms::from_values(terms)};
    }
    if (s.lens)
      p.distortion = MrcalLensDistortion{std::make_shared<const MrcalLens>(s.lens->lensmodel(), s.lens_values)};
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
      const auto pose = pose_from_rays(rays, o.all_points[b], board);
      if (!pose) return;
      s.poses.push_back(pose_block(*pose));
    }
    // Score: the robust (truncated at 20 px) reprojection error of these poses.
    double cost = 0;
    for (size_t b = 0; b < o.boards.size(); ++b) {
      const BoardPose pose = pose_of(s.poses[b]);
      for (size_t i = 0; i < o.all_points[b].size(); ++i) {
        Eigen::Vector2d q;
        const double e = guess.project(to_camera(pose, o.all_points[b][i]), &q) ? (q - o.corners[b][i]).norm() : 20.0;
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
      ModelSpec radial = spec;  // the start is the radial model's; tangential terms join later
      radial.tangential_terms = 0;
      starts.push_back(
          model_params(fit_camera(sample_image(polynomial, std::max(8, o.width / 40), 4), radial, p).model));
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
    costs[size_t(k)] =
        solve<Model>(&candidates[size_t(k)], o.all_points, o.corners, false, &loss, kScreening).final_cost;
  });
  // Finished to 1e-9: the robust solution only decides the outliers; the final
  // plain solve (step 4) polishes.
  Solve best = std::move(candidates[size_t(std::min_element(costs.begin(), costs.end()) - costs.begin())]);
  ceres::CauchyLoss loss(1.0);
  solve<Model>(&best, o.all_points, o.corners, false, &loss, 200, 1e-9);
  return best;
}

// Step 3, outliers: corners beyond outlier_limit_px of the robust solve's errors.
std::vector<CalibrationResult::Outlier> find_outliers(const Observations& o, const Camera& camera, const Solve& s) {
  std::vector<double> errors;
  std::vector<std::vector<double>> per_board(o.boards.size());
  for (size_t b = 0; b < o.boards.size(); ++b) {
    const BoardPose pose = pose_of(s.poses[b]);
    for (size_t i = 0; i < o.all_points[b].size(); ++i) {
      Eigen::Vector2d q;
      const double e = camera.project(to_camera(pose, o.all_points[b][i]), &q)
                           ? (q - o.corners[b][i]).norm()
                           : std::numeric_limits<double>::infinity();
      per_board[b].push_back(e);
      errors.push_back(e);
    }
  }
  const double limit = detail::outlier_limit_px(std::move(errors));
  std::vector<CalibrationResult::Outlier> outliers;
  for (size_t b = 0; b < o.boards.size(); ++b) {
    for (size_t i = 0; i < per_board[b].size(); ++i) {
      if (per_board[b][i] > limit) outliers.push_back({o.boards[b]->filename, o.boards[b]->id(i), per_board[b][i]});
    }
  }
  return outliers;
}

// The parameters' sigmas, the warp's, and what the data do not determine, from the
// final solve's covariance (parameters, the warp, then the poses).
void report_uncertainty(const ParameterCovariance& full, const Solve& s, const ModelSpec& spec,
                        CalibrationResult* result) {
  const size_t intrinsics = result->parameters.size();
  result->noise_px = std::sqrt(full.variance);
  result->sigmas.assign(intrinsics, 0);
  for (size_t i = 0; i < intrinsics; ++i)
    result->sigmas[i] = std::sqrt(full.covariance(Eigen::Index(i), Eigen::Index(i)));
  const size_t warps = s.warp.size();
  if (!s.warp.empty()) {
    const auto sigma = [&](size_t i) { return std::sqrt(full.covariance(Eigen::Index(i), Eigen::Index(i))); };
    result->board_warp = BoardWarp{s.warp[0], s.warp[1]};
    result->board_warp_sigma = BoardWarp{sigma(intrinsics), sigma(intrinsics + 1)};
  }
  for (const Eigen::VectorXd& direction : full.undetermined) {
    std::vector<std::string> names;
    for (size_t i = 0; i < intrinsics; ++i) {
      if (std::abs(direction[Eigen::Index(i)]) >= 0.1) {
        names.push_back(result->parameter_names[i]);
        result->sigmas[i] = std::numeric_limits<double>::quiet_NaN();
      }
    }
    for (size_t i = 0; i < warps; ++i) {
      if (std::abs(direction[Eigen::Index(intrinsics + i)]) >= 0.1) {
        names.push_back(i == 0 ? "the board warp x2" : "the board warp y2");
        (i == 0 ? result->board_warp_sigma.x2 : result->board_warp_sigma.y2) = std::numeric_limits<double>::quiet_NaN();
      }
    }
    const bool poses = direction.tail(direction.size() - Eigen::Index(intrinsics + warps)).norm() >= 0.1;
    result->undetermined.push_back(undetermined_text(names, poses, spec.name, result->parameters));
  }
}

// Boards the robust solve left in a wrong basin (most of their corners outliers: a
// close board at the rim placed from the equidistant start can settle mirrored or
// far off) placed again from their rays through the robust solve's camera, the
// pose taken when it reprojects better (errors truncated at 20 px, as the start is
// scored). Whether any board moved.
bool relocate_lost_boards(const Observations& o, const BoardSpec& board, const Camera& camera,
                          const std::vector<CalibrationResult::Outlier>& outliers, Solve* s) {
  const auto robust_cost = [&](size_t b, const std::array<double, 6>& pose) {
    double cost = 0;
    for (const double e : corner_errors(camera, o.all_points[b], *o.boards[b], pose)) cost += std::min(e, 20.0);
    return cost;
  };
  bool moved = false;
  for (size_t b = 0; b < o.boards.size(); ++b) {
    const auto lost = std::count_if(outliers.begin(), outliers.end(),
                                    [&](const auto& x) { return x.filename == o.boards[b]->filename; });
    if (2 * size_t(lost) < o.corners[b].size()) continue;
    std::vector<Eigen::Vector3d> rays(o.corners[b].size());
    bool all_rays = true;
    for (size_t i = 0; i < rays.size() && all_rays; ++i) all_rays = camera.unproject(o.corners[b][i], &rays[i]);
    if (!all_rays) continue;
    const auto placed = pose_from_rays(rays, o.all_points[b], board);
    if (!placed) continue;
    std::array<double, 6> pose = pose_block(*placed);
    ceres::CauchyLoss loss(1.0);
    try {
      solve_board_pose(camera, o.all_points[b], *o.boards[b], std::vector<bool>(rays.size(), false), &loss, &pose);
    } catch (const Error&) {
      continue;
    }
    if (robust_cost(b, pose) < robust_cost(b, s->poses[b])) s->poses[b] = pose, moved = true;
  }
  return moved;
}

// Step 4, the final plain least squares without the outliers (with the boards' warp
// when asked: it starts flat), its covariance, and the report: per-image and overall
// RMS (2-D norm), parameters and their sigmas.
template <template <typename> class Model>
void final_solve(const Observations& o, Solve s, const ModelSpec& spec, bool warp, CalibrationResult* result) {
  // The corners that are not outliers, per board; a board left with fewer than 3
  // has no determined pose and is left out (and said so).
  std::vector<std::vector<Eigen::Vector3d>> kept_points;
  std::vector<std::vector<Eigen::Vector2d>> kept_corners;
  std::vector<size_t> used;  // index into o.boards of each kept board
  std::vector<std::array<double, 6>> poses;
  for (size_t b = 0; b < o.boards.size(); ++b) {
    std::vector<Eigen::Vector3d> points;
    std::vector<Eigen::Vector2d> corners;
    for (size_t i = 0; i < o.all_points[b].size(); ++i) {
      const bool outlier = std::any_of(result->outliers.begin(), result->outliers.end(), [&](const auto& x) {
        return x.filename == o.boards[b]->filename && x.corner == o.boards[b]->id(i);
      });
      if (outlier) continue;
      points.push_back(o.all_points[b][i]);
      corners.push_back(o.corners[b][i]);
    }
    if (points.size() < 3) {
      result->warnings.push_back("image " + o.boards[b]->filename + ": " +
                                 std::to_string(o.all_points[b].size() - points.size()) +
                                 " of its corners are outliers; the image is left out");
      continue;
    }
    kept_points.push_back(std::move(points)), kept_corners.push_back(std::move(corners));
    used.push_back(b), poses.push_back(s.poses[b]);
  }
  if (used.size() < 3) throw Error("calibrate: fewer than 3 images keep enough corners after the outliers are removed");
  s.poses = std::move(poses);
  if (s.lens) {  // mrcal-calibrate-cameras' order: the core solved with the lens at 0 on flat boards, then held
    std::fill(s.lens_values.begin(), s.lens_values.end(), 0.0);
    s.core_held = false, s.lens_values_held = true;
    solve<Model>(&s, kept_points, kept_corners, false, nullptr);
    s.core_held = true, s.lens_values_held = false;
  }
  if (warp) s.warp = {0.0, 0.0};
  solve<Model>(&s, kept_points, kept_corners, false, nullptr);
  result->observations = 0;
  for (const auto& corners : kept_corners) result->observations += long(corners.size());
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
      const Eigen::Vector3d point = to_camera(pose, detail::warped(s.board, s.warp, kept_points[b][i]));
      Eigen::Vector2d q;
      if (!final_camera.project(point, &q) && s.lens) {  // the solve has no such limit: the spline's own fold
        throw Error("calibrate (" + s.lens->lensmodel() + "): the solved spline folds inside the data (image " +
                    o.boards[used[b]]->filename +
                    " lies past where it is one-to-one): try more knots, another fov_x_deg or another model");
      }
      board_sum2 += (q - kept_corners[b][i]).squaredNorm();
      record.observe(point);
    }
    sum2 += board_sum2;
    result->per_image_rms_px.push_back(std::sqrt(board_sum2 / double(std::max<size_t>(1, kept_points[b].size()))));
  }
  result->rms_px = std::sqrt(sum2 / double(std::max(1L, result->observations)));
  result->parameter_names = model_param_names(spec.name, int(s.model.size()));
  if (s.lens) {
    const std::vector<std::string> names = std::get<MrcalLensDistortion>(result->camera.distortion).parameter_names();
    result->parameter_names.insert(result->parameter_names.end(), names.begin(), names.end());
  }
  for (size_t i = 0; i < s.tangential.size(); ++i) result->parameter_names.emplace_back(TangentialTerms::kNames[i]);
  result->parameter_names.insert(result->parameter_names.end(), {"cx", "cy", "a_y"});
  result->parameters = s.model;
  result->parameters.insert(result->parameters.end(), s.lens_values.begin(), s.lens_values.end());
  result->parameters.insert(result->parameters.end(), s.tangential.begin(), s.tangential.end());
  result->parameters.insert(result->parameters.end(), {s.center.x(), s.center.y(), s.ay});

  const ParameterCovariance full = parameter_covariance<Model>(s, kept_points, kept_corners);
  report_uncertainty(full, s, spec, result);
  record.covariance = projection_covariance_of(full, s);
  result->camera.calibration = record;
}

template <template <typename> class Model>
CalibrationResult calibrate_with(const std::vector<const BoardObservation*>& boards, const BoardSpec& board, int width,
                                 int height, const ModelSpec& spec, const CalibrationOptions& options) {
  const Observations o(boards, board, width, height, options.threads);
  Solve robust = robust_solve<Model>(o, initial_solve(o, board), spec);
  if (spec.tangential_terms > 0) {  // from the radial solution, under the same robust loss
    robust.tangential.assign(size_t(spec.tangential_terms), 0.0);
    ceres::CauchyLoss loss(1.0);
    solve<Model>(&robust, o.all_points, o.corners, false, &loss, 200, 1e-9);
  }
  if (!spec.mrcal_lens.empty()) {  // from the base model's solution (the lens at zero), its core held
    robust.lens = MrcalLens::with_zero_values(spec.mrcal_lens);
    robust.lens_values = robust.lens->values();
    robust.core_held = true;
    ceres::CauchyLoss loss(1.0);
    solve<Model>(&robust, o.all_points, o.corners, false, &loss, 200, 1e-9);
  }
  CalibrationResult result;
  const Camera robust_camera(o.camera(robust, make_model(spec.name, robust.model)));
  result.outliers = find_outliers(o, robust_camera, robust);
  if (!result.outliers.empty() &&
      relocate_lost_boards(o, board, robust_camera, result.outliers, &robust)) {  // solved again, those boards placed
    ceres::CauchyLoss loss(1.0);
    solve<Model>(&robust, o.all_points, o.corners, false, &loss, 200, 1e-9);
    result.outliers = find_outliers(o, Camera(o.camera(robust, make_model(spec.name, robust.model))), robust);
  }
  if (!result.outliers.empty()) {
    // The robust loss can settle where a whole board near the rim is ignored (a local
    // minimum: seen with the rational `opencv` and with `mei`); the plain solve from
    // there is taken when it leaves fewer corners as outliers.
    Solve plain = robust;
    solve<Model>(&plain, o.all_points, o.corners, false, nullptr, 1000, 1e-12);
    try {
      auto outliers = find_outliers(o, Camera(o.camera(plain, make_model(spec.name, plain.model))), plain);
      if (outliers.size() < result.outliers.size()) robust = std::move(plain), result.outliers = std::move(outliers);
    } catch (const Error&) {  // the plain solve left the model's valid parameters: keep the robust one
    }
  }
  robust.board = board;
  final_solve<Model>(o, robust, spec, options.board_warp, &result);
  return result;
}

}  // namespace

CalibrationResult calibrate(const std::vector<BoardObservation>& observations, const BoardSpec& board, int width,
                            int height, const ModelSpec& spec, const CalibrationOptions& options) {
  check_board(board);
  if (options.threads < 1) throw Error("calibrate: threads must be >= 1, got " + std::to_string(options.threads));
  for (const auto& o : observations) detail::check_placeable(board, o, "calibrate");
  check_corners_in_image(observations, width, height);
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
  check_no_duplicate_views(boards);
  CalibrationResult result = with_model_class(spec.name, [&]<template <typename> class Model>() {
    return calibrate_with<Model>(boards, board, width, height, spec, options);
  });
  check_solution(result, width, height, spec.name);
  check_distinct_poses(result);
  if (const double off = detail::principal_point_offset(result.camera.grid.principal_point, width, height);
      off > detail::kPrincipalPointWarned) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "the principal point lies %.0f %% of the image size from the image centre (lenses are centred "
                  "within %.0f %%): check --imagersize",
                  100 * off, 100 * detail::kPrincipalPointWarned);
    result.warnings.push_back(text);
  }
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
    result.warnings.push_back(
        "the boards cover only " + std::to_string(100 * covered / 48) +
        "% of the image (8x6 grid): the model is extrapolated elsewhere; add boards near the rim");
  }
  return result;
}

CalibrationResult locate_boards(const std::vector<BoardObservation>& observations, const BoardSpec& board,
                                const Camera& camera) {
  check_board(board);
  for (const auto& o : observations) detail::check_placeable(board, o, "locate boards");
  check_corners_in_image(observations, camera.width(), camera.height());
  const std::vector<Eigen::Vector3d> all_points = board_points(board);
  std::vector<const BoardObservation*> views;
  std::vector<std::vector<Eigen::Vector3d>> view_points;  // the points each view's corners are
  std::vector<std::array<double, 6>> poses;
  ceres::CauchyLoss robust(1.0);
  for (const auto& o : observations) {
    if (o.corners.empty()) continue;
    std::vector<Eigen::Vector3d> rays(o.corners.size());
    for (size_t i = 0; i < rays.size(); ++i) {
      if (!camera.unproject(o.corners[i], &rays[i])) {
        throw Error("locate boards: image " + o.filename + ": corner " + std::to_string(i) +
                    " has no ray through the given camera (outside its valid domain: is it this camera's?)");
      }
    }
    const std::vector<Eigen::Vector3d> points = observed_points(all_points, o);
    const auto pose = pose_from_rays(rays, points, board);
    if (!pose) throw Error("locate boards: image " + o.filename + ": no board pose fits its corners' rays");
    views.push_back(&o), poses.push_back(pose_block(*pose)), view_points.push_back(points);
    solve_board_pose(camera, points, o, std::vector<bool>(points.size(), false), &robust, &poses.back());
  }
  if (views.empty()) throw Error("locate boards: no image with a board");
  // Outliers as calibrate finds them (outlier_limit_px).
  std::vector<std::vector<double>> errors;
  std::vector<double> all;
  for (size_t b = 0; b < views.size(); ++b) {
    errors.push_back(corner_errors(camera, view_points[b], *views[b], poses[b]));
    all.insert(all.end(), errors.back().begin(), errors.back().end());
  }
  const double limit = detail::outlier_limit_px(std::move(all));
  CalibrationResult result;
  result.camera = camera.parameters();
  double sum2 = 0;
  for (size_t b = 0; b < views.size(); ++b) {
    const std::vector<Eigen::Vector3d>& points = view_points[b];
    std::vector<bool> left_out(points.size(), false);
    long kept = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      left_out[i] = !(errors[b][i] <= limit);
      if (left_out[i]) result.outliers.push_back({views[b]->filename, views[b]->id(i), errors[b][i]});
      kept += !left_out[i];
    }
    if (kept < 3) {
      result.warnings.push_back("image " + views[b]->filename + ": " + std::to_string(points.size() - size_t(kept)) +
                                " of its corners are outliers; the image is left out");
      continue;
    }
    const double cost = solve_board_pose(camera, points, *views[b], left_out, nullptr, &poses[b]).final_cost;
    sum2 += 2 * cost;
    result.poses.push_back(pose_of(poses[b]));
    result.used_images.push_back(views[b]->filename);
    result.per_image_rms_px.push_back(std::sqrt(2 * cost / double(kept)));
    result.observations += kept;
  }
  if (result.poses.empty()) throw Error("locate boards: every image lost its board to the outliers");
  result.rms_px = std::sqrt(sum2 / double(result.observations));
  result.noise_px = result.rms_px / std::sqrt(2.0);
  const std::string model = std::string(model_name(result.camera.model));
  result.parameters = model_params(result.camera.model);
  result.parameter_names = model_param_names(model, int(result.parameters.size()));
  result.parameter_names.insert(result.parameter_names.end(), {"cx", "cy", "a_y"});
  const PixelGrid& grid = result.camera.grid;
  result.parameters.insert(result.parameters.end(),
                           {grid.principal_point.x(), grid.principal_point.y(), grid.pixel_scale.y()});
  result.sigmas.assign(result.parameters.size(), 0.0);
  return result;
}

}  // namespace fishcam
