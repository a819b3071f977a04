#include "fishcam/fit/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <numeric>
#include <optional>
#include <set>

#include "calibration_internal.hpp"

namespace fishcam {

using detail::check_solution;
using detail::ParameterCovariance;
using detail::pose_block;
using detail::pose_of;
using detail::Solve;
using detail::undetermined_text;

namespace {

// The joint solve is said to hide inconsistent data when a camera's joint RMS is more
// than this factor of its own calibration's, or its joint intrinsics lie more than
// kIntrinsicsMoveSigmas of their own sigma from its own calibration's (docs/fitting.md).
constexpr double kJointRmsFactor = 1.5;
constexpr double kIntrinsicsMoveSigmas = 3;
// The error of a corner whose board point does not project at the joint solution.
constexpr double kUnprojectedError = std::numeric_limits<double>::infinity();

// A number for a warning, to 3 significant digits.
std::string three_digits(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

// The warnings of camera `name` whose joint solution is `joint` and own calibration `own`.
std::vector<std::string> joint_solve_warnings(const std::string& name, const CalibrationResult& own,
                                              const CalibrationResult& joint) {
  std::vector<std::string> warnings;
  if (joint.rms_px > kJointRmsFactor * own.rms_px) {
    warnings.push_back(name + ": the joint solve's rms " + three_digits(joint.rms_px) + " px is " +
                       three_digits(joint.rms_px / own.rms_px) + " times its own calibration's (" +
                       three_digits(own.rms_px) +
                       " px): its boards do not agree with the other cameras' at the same instants (pairs not "
                       "taken together, a camera that moved, a board that bent?)");
  }
  double worst = 0;
  std::string worst_name;
  for (size_t i = 0; i < own.parameters.size() && i < joint.parameters.size(); ++i) {
    const double moved = std::abs(joint.parameters[i] - own.parameters[i]) / own.sigmas[i];
    if (std::isfinite(moved) && moved > worst) worst = moved, worst_name = own.parameter_names[i];
  }
  if (worst > kIntrinsicsMoveSigmas) {
    warnings.push_back(name + ": the joint solve moves " + worst_name + " by " + three_digits(worst) +
                       " sigma from the camera's own calibration: the other cameras' boards pull its intrinsics");
  }
  return warnings;
}

// One corner of a rig camera at one instant: p[0..2] the camera's intrinsics, then
// (cameras other than 0) camera 0 -> this camera, then the board -> camera 0, then
// (with warp factors) the boards' warp (x2, y2).
template <template <typename> class Model>
struct RigCornerResidual {
  Eigen::Vector3d point;
  Eigen::Vector2d corner;
  int params;
  bool moved;  // false for camera 0, whose frame is the rig's
  std::optional<Eigen::Vector2d> warp = std::nullopt;

  template <typename T>
  bool operator()(T const* const* p, T* residuals) const {
    const Model<T> model = detail::model_from_block<Model>(p[0], params);
    const T mapping[4] = {p[1][0], p[1][1], T(1.0), p[2][0]};
    T board[3], camera[3];
    detail::warped_point(point, warp, warp ? p[moved ? 5 : 4] : static_cast<const T*>(nullptr), board);
    detail::board_point_in_camera(moved ? p[4] : p[3], moved ? p[3] : static_cast<const T*>(nullptr), board, camera);
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

// Two views of one board with the same corners (within 0.5 px everywhere).
bool same_corners(const BoardObservation& a, const BoardObservation& b) {
  if (a.corners.size() != b.corners.size() || a.ids != b.ids) return false;
  for (size_t c = 0; c < a.corners.size(); ++c) {
    if (!((a.corners[c] - b.corners[c]).cwiseAbs().maxCoeff() < 0.5)) return false;
  }
  return true;
}

// Two cameras of a rig see one board from different places: the same corners at
// most of their shared instants are one camera's corners given twice.
void check_distinct_cameras(const std::vector<std::map<int, const BoardObservation*>>& observed) {
  for (size_t b = 1; b < observed.size(); ++b) {
    for (size_t a = 0; a < b; ++a) {
      long shared = 0, same = 0;
      for (const auto& [i, view] : observed[b]) {
        const auto other = observed[a].find(i);
        if (other == observed[a].end()) continue;
        ++shared;
        same += same_corners(*view, *other->second);
      }
      if (shared > 0 && 2 * same >= shared) {
        throw Error("calibrate rig: camera " + std::to_string(b) + " has the same corners as camera " +
                    std::to_string(a) + " at " + std::to_string(same) + " of their " + std::to_string(shared) +
                    " shared instants: the same corners given for both cameras? (each camera needs its own)");
      }
    }
  }
}

// A chessboard looks the same turned by 180 deg about its normal, so a detector may
// number its corners from either end: corner m is then the board's point N-1-m, the
// board's points moved by this half turn about the board's centre.
Pose board_half_turn(const BoardSpec& board) {
  return {Eigen::Quaterniond(Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitZ())),
          Eigen::Vector3d(board.width(), board.height(), 0)};
}

// Relative poses of one camera pair that describe the same mounting, each estimated
// from one board at distance `distance`: a per-view pose errs by a fraction of a
// degree, so its translation by a share of the board's distance (not of the baseline,
// which may be centimetres). A view numbered from the other end gives an estimate a
// half turn away, far outside this.
bool same_mounting(const Pose& a, const Pose& b, double distance) {
  constexpr double kAngle = 10 * std::numbers::pi / 180, kShare = 0.25;
  return a.rotation.angularDistance(b.rotation) < kAngle &&
         (a.translation - b.translation).norm() <=
             kShare * std::max({a.translation.norm(), b.translation.norm(), distance});
}

// What the instants camera k shares with camera 0 say about their relative pose.
struct InstantConsensus {
  std::vector<int> renumbered;   // instants whose board camera k numbers from the other end
  std::vector<int> disagreeing;  // instants that agree with the consensus in neither numbering
  long shared = 0;
};

// The per-instant relative poses (camera 0 -> k) agree with each other only when
// both cameras number each board alike and saw it at the same time; the estimate
// with the most agreeing instants (as given or renumbered) is the consensus.
InstantConsensus instant_consensus(const std::map<int, Pose>& seen0, const std::map<int, Pose>& seen_k,
                                   const Pose& half_turn) {
  InstantConsensus out;
  std::vector<int> instants;
  std::vector<Pose> as_given, renumbered;
  std::vector<double> distance;  // the board's, from camera 0
  for (const auto& [i, pose_k] : seen_k) {
    const auto pose_0 = seen0.find(i);
    if (pose_0 == seen0.end()) continue;
    instants.push_back(i);
    distance.push_back(pose_0->second.translation.norm());
    as_given.push_back(compose(pose_k, inverse(pose_0->second)));
    renumbered.push_back(compose(compose(pose_k, half_turn), inverse(pose_0->second)));
  }
  out.shared = long(instants.size());
  if (instants.size() < 2) return out;
  const auto support = [&](const Pose& candidate) {
    long agreeing = 0;
    for (size_t j = 0; j < instants.size(); ++j) {
      agreeing +=
          same_mounting(as_given[j], candidate, distance[j]) || same_mounting(renumbered[j], candidate, distance[j]);
    }
    return agreeing;
  };
  const Pose* best = &as_given[0];
  long best_support = -1;
  for (const auto* list : {&as_given, &renumbered}) {
    for (const Pose& candidate : *list) {
      if (const long s = support(candidate); s > best_support) best = &candidate, best_support = s;
    }
  }
  for (size_t j = 0; j < instants.size(); ++j) {
    const Pose* agreeing = same_mounting(as_given[j], *best, distance[j])     ? &as_given[j]
                           : same_mounting(renumbered[j], *best, distance[j]) ? &renumbered[j]
                                                                              : nullptr;
    if (!agreeing) {
      out.disagreeing.push_back(instants[j]);
      continue;
    }
    if (agreeing == &renumbered[j]) out.renumbered.push_back(instants[j]);
  }
  return out;
}

// The joint problem's parameters: every camera's intrinsics, cameras 1.. relative
// to camera 0 (camera 0 -> camera k; camera 0's block is the identity), and each
// instant's board relative to camera 0.
struct JointParameters {
  std::vector<Solve> intrinsics;  // unused for a camera held fixed
  std::vector<std::array<double, 6>> cameras, boards;
  std::vector<std::shared_ptr<const Camera>> fixed;  // per camera: its intrinsics held fixed, or null
  // The boards' warp (x2, y2), one for every board as in one camera's solve; empty: flat.
  std::vector<double> warp = {};
  BoardSpec board = {};
  std::optional<Eigen::Vector2d> warp_factors_of(const Eigen::Vector3d& point) const {
    return warp.empty() ? std::nullopt : std::optional(warp_factors(board, point));
  }
};

// Corners left out of the joint solve, per camera: (image, corner).
using CornerSet = std::set<std::pair<std::string, int>>;

// Camera k's corners not in `excluded` as residuals of `problem`, its intrinsics held
// fixed (p->fixed[k]): over its pose relative to camera 0 (k > 0) and the boards.
long add_fixed_camera_residuals(ceres::Problem* problem, JointParameters* p, size_t k,
                                const std::map<int, const BoardObservation*>& observed,
                                const std::vector<Eigen::Vector3d>& points, const CornerSet& excluded,
                                ceres::LossFunction* loss) {
  long corners = 0;
  for (const auto& [i, o] : observed) {
    for (size_t c = 0; c < o->corners.size(); ++c) {
      if (excluded.count({o->filename, o->id(c)})) continue;
      const Eigen::Vector3d& point = points[size_t(o->id(c))];
      auto* cost = new ceres::DynamicAutoDiffCostFunction<detail::FixedCameraCornerResidual, 6>(
          new detail::FixedCameraCornerResidual(p->fixed[k].get(), point, o->corners[c], k > 0,
                                                p->warp_factors_of(point)));
      std::vector<double*> blocks;
      if (k > 0) cost->AddParameterBlock(6), blocks.push_back(p->cameras[k].data());
      cost->AddParameterBlock(6);
      blocks.push_back(p->boards[size_t(i)].data());
      if (!p->warp.empty()) cost->AddParameterBlock(2), blocks.push_back(p->warp.data());
      cost->SetNumResiduals(2);
      problem->AddResidualBlock(cost, loss, blocks);
      ++corners;
    }
  }
  return corners;
}

// Every corner of every camera not in `excluded`, as residuals of `problem` over
// `p` (under `loss`; nullptr: plain least squares). Returns the corners used per
// camera.
std::vector<long> add_joint_residuals(ceres::Problem* problem, JointParameters* p,
                                      const std::vector<RigCamera>& cameras,
                                      const std::vector<std::map<int, const BoardObservation*>>& observed,
                                      const std::vector<Eigen::Vector3d>& points,
                                      const std::vector<CornerSet>& excluded, ceres::LossFunction* loss) {
  std::vector<long> corners_of(cameras.size(), 0);
  for (size_t k = 0; k < cameras.size(); ++k) {
    if (p->fixed[k]) {
      corners_of[k] = add_fixed_camera_residuals(problem, p, k, observed[k], points, excluded[k], loss);
      continue;
    }
    const int params = int(p->intrinsics[k].model.size());
    with_model_class(cameras[k].model.name, [&]<template <typename> class Model>() {
      for (const auto& [i, o] : observed[k]) {
        for (size_t c = 0; c < o->corners.size(); ++c) {
          if (excluded[k].count({o->filename, o->id(c)})) continue;
          const Eigen::Vector3d& point = points[size_t(o->id(c))];
          auto* cost = new ceres::DynamicAutoDiffCostFunction<RigCornerResidual<Model>, 8>(
              new RigCornerResidual<Model>{point, o->corners[c], params, k > 0, p->warp_factors_of(point)});
          cost->AddParameterBlock(params);
          cost->AddParameterBlock(2);
          cost->AddParameterBlock(1);
          Solve& intrinsics = p->intrinsics[k];
          std::vector<double*> blocks = {intrinsics.model.data(), intrinsics.center.data(), &intrinsics.ay};
          if (k > 0) cost->AddParameterBlock(6), blocks.push_back(p->cameras[k].data());
          cost->AddParameterBlock(6);
          blocks.push_back(p->boards[size_t(i)].data());
          if (!p->warp.empty()) cost->AddParameterBlock(2), blocks.push_back(p->warp.data());
          cost->SetNumResiduals(2);
          problem->AddResidualBlock(cost, loss, blocks);
          ++corners_of[k];
        }
      }
      detail::bound_model_block<Model>(problem, p->intrinsics[k].model.data(), params);
    });
  }
  return corners_of;
}

// Camera k's camera at the joint solution `p`.
Camera joint_camera(const JointParameters& p, const std::vector<RigCamera>& cameras, size_t k) {
  if (p.fixed[k]) return *p.fixed[k];
  CameraParameters c;
  c.width = cameras[k].width, c.height = cameras[k].height;
  c.model = make_model(cameras[k].model.name, p.intrinsics[k].model);
  c.grid.principal_point = p.intrinsics[k].center;
  c.grid.pixel_scale = {1.0, p.intrinsics[k].ay};
  return Camera(c);
}

// The joint solve's outliers, per camera: corners of the robust joint solution `p`
// beyond outlier_limit_px of that camera's errors, as one camera's calibration finds
// its own; a corner that agrees with its camera's
// boards but not with the other cameras' at the same instant is one (mrcal's joint
// solve drops them likewise).
std::vector<std::vector<CalibrationResult::Outlier>> joint_outliers(
    const JointParameters& p, const std::vector<RigCamera>& cameras,
    const std::vector<std::map<int, const BoardObservation*>>& observed, const std::vector<Eigen::Vector3d>& points,
    const std::vector<CornerSet>& excluded) {
  std::vector<std::vector<CalibrationResult::Outlier>> out(cameras.size());
  for (size_t k = 0; k < cameras.size(); ++k) {
    const Camera camera = joint_camera(p, cameras, k);
    const Pose rig_to_camera = pose_of(p.cameras[k]);
    std::vector<CalibrationResult::Outlier> errors;
    for (const auto& [i, o] : observed[k]) {
      const Pose board_pose = compose(rig_to_camera, pose_of(p.boards[size_t(i)]));
      for (size_t c = 0; c < o->corners.size(); ++c) {
        if (excluded[k].count({o->filename, o->id(c)})) continue;
        Eigen::Vector2d q;
        const Eigen::Vector3d point = detail::warped(p.board, p.warp, points[size_t(o->id(c))]);
        const bool seen = camera.project(board_pose.rotation * point + board_pose.translation, &q);
        errors.push_back({o->filename, o->id(c), seen ? (q - o->corners[c]).norm() : kUnprojectedError});
      }
    }
    if (errors.empty()) continue;
    std::vector<double> sorted;  // outlier_limit_px sorts them
    for (const auto& e : errors) sorted.push_back(e.error_px);
    const double limit = detail::outlier_limit_px(std::move(sorted));
    for (const auto& e : errors) {
      if (!(e.error_px <= limit)) out[k].push_back(e);
    }
  }
  return out;
}

std::string camera_name(size_t k) { return "camera " + std::to_string(k); }

// What the cameras saw, by instant: each camera's board poses (in its own frame) and
// views, the views renumbered from the other end, and the warnings so far.
struct RigViews {
  std::map<std::string, int> instant_index;  // instant (file name) -> index
  std::vector<std::map<int, Pose>> seen;
  std::vector<std::map<int, const BoardObservation*>> observed;
  std::deque<BoardObservation> renumbered_views;  // what observed points to for those
  std::vector<std::set<std::string>> renumbered_images;
  std::vector<std::string> warnings;
};

// Step 1: each camera alone (intrinsics, its boards' poses, its outliers), its boards
// warped or flat as the joint solve has them (its numbers are the joint solve's start
// and what its warnings compare it with).
std::vector<CalibrationResult> calibrate_each(const std::vector<RigCamera>& cameras, const BoardSpec& board,
                                              const CalibrationOptions& options) {
  std::vector<CalibrationResult> singles;
  for (size_t k = 0; k < cameras.size(); ++k) {
    try {
      if (const auto& fixed = cameras[k].fixed_intrinsics) {
        if (fixed->width != cameras[k].width || fixed->height != cameras[k].height) {
          throw Error("its fixed intrinsics are for " + std::to_string(fixed->width) + "x" +
                      std::to_string(fixed->height) + " images, its corners for " + std::to_string(cameras[k].width) +
                      "x" + std::to_string(cameras[k].height));
        }
        singles.push_back(locate_boards(cameras[k].observations, board, Camera(*fixed)));
        continue;
      }
      singles.push_back(
          calibrate(cameras[k].observations, board, cameras[k].width, cameras[k].height, cameras[k].model, options));
    } catch (const Error& e) {
      throw Error(camera_name(k) + ": " + e.what());
    }
  }
  return singles;
}

// The instants, and which camera saw which board; refuses two cameras with one's corners.
void index_views(const std::vector<RigCamera>& cameras, const std::vector<CalibrationResult>& singles, RigViews* v) {
  const size_t n = cameras.size();
  v->seen.resize(n), v->observed.resize(n), v->renumbered_images.resize(n);
  for (size_t k = 0; k < n; ++k) {
    std::map<std::string, const BoardObservation*> by_name;
    for (const auto& o : cameras[k].observations) by_name[o.filename] = &o;
    for (size_t b = 0; b < singles[k].used_images.size(); ++b) {
      const std::string instant = instant_of(singles[k].used_images[b]);
      const int i = v->instant_index.emplace(instant, int(v->instant_index.size())).first->second;
      if (v->seen[k].count(i)) throw Error(camera_name(k) + ": two images of the instant " + instant);
      v->seen[k][i] = singles[k].poses[b];
      v->observed[k][i] = by_name.at(singles[k].used_images[b]);
    }
  }
  check_distinct_cameras(v->observed);
}

// Views a camera numbers from the other end than camera 0: renumbered (corners
// reversed, pose turned, outliers' corner numbers mirrored later), and said; pairs
// whose relative poses mostly disagree refused as unsynchronised.
void resolve_numbering(const BoardSpec& board, RigViews* v) {
  // A grid of tags (an AprilGrid) names its corners by their tags: it cannot be read
  // turned, so a view that only agrees turned disagrees.
  const Pose half_turn = board.gap > 0 ? Pose{} : board_half_turn(board);
  std::map<int, std::string> instant_names;
  for (const auto& [name, i] : v->instant_index) instant_names[i] = name;
  for (size_t k = 1; k < v->seen.size(); ++k) {
    const InstantConsensus consensus = instant_consensus(v->seen[0], v->seen[k], half_turn);
    if (consensus.shared >= 3 && 2 * long(consensus.disagreeing.size()) > consensus.shared) {
      throw Error(
          "calibrate rig: " + camera_name(k) + " and camera 0 disagree on their relative pose at " +
          std::to_string(consensus.disagreeing.size()) + " of their " + std::to_string(consensus.shared) +
          " shared instants (more than 10 deg, or 25 % of the board distance, from the others): are images of the "
          "same name taken at the same time? (unsynchronised or mismatched pairs)");
    }
    if (!consensus.disagreeing.empty()) {
      std::string names;
      for (size_t j = 0; j < consensus.disagreeing.size() && j < 5; ++j) {
        names += (j ? ", " : "") + instant_names[consensus.disagreeing[j]];
      }
      v->warnings.push_back(camera_name(k) + ": " + std::to_string(consensus.disagreeing.size()) +
                            " instant(s) disagree " + "with the others on the pose relative to camera 0 (" + names +
                            (consensus.disagreeing.size() > 5 ? ", ..." : "") + "): not synchronised?");
    }
    for (const int i : consensus.renumbered) {
      v->renumbered_views.push_back(renumbered_from_other_end(board, *v->observed[k][i]));
      v->observed[k][i] = &v->renumbered_views.back();
      v->seen[k][i] = compose(v->seen[k][i], half_turn);
      v->renumbered_images[k].insert(v->renumbered_views.back().filename);
      v->warnings.push_back(camera_name(k) + ": image " + v->renumbered_views.back().filename +
                            ": the board's corners are numbered from the other end than in camera 0 (a chessboard "
                            "looks the same turned by 180 degrees): renumbered");
    }
  }
}

// Step 2: each camera's pose relative to camera 0 (camera 0 -> camera k), through
// shared instants, breadth first from camera 0; refuses a camera linked to none.
std::vector<Pose> relative_poses(const RigViews& v) {
  const size_t n = v.seen.size();
  std::vector<std::optional<Pose>> from_rig(n);
  from_rig[0] = Pose{};
  for (bool grew = true; grew;) {
    grew = false;
    for (size_t b = 0; b < n; ++b) {
      if (from_rig[b]) continue;
      for (size_t a = 0; a < n && !from_rig[b]; ++a) {
        if (!from_rig[a]) continue;
        std::vector<Pose> estimates;
        for (const auto& [i, pose_b] : v.seen[b]) {
          if (const auto it = v.seen[a].find(i); it != v.seen[a].end()) {
            estimates.push_back(compose(compose(pose_b, inverse(it->second)), *from_rig[a]));
          }
        }
        if (!estimates.empty()) from_rig[b] = mean_pose(estimates), grew = true;
      }
    }
  }
  std::vector<Pose> out;
  for (size_t k = 0; k < n; ++k) {
    if (!from_rig[k]) {
      throw Error(camera_name(k) +
                  " shares no board instant with camera 0 or the cameras linked to it (images of "
                  "the same instant must have the same file name)");
    }
    out.push_back(*from_rig[k]);
  }
  return out;
}

// Step 3's start: the single calibrations' intrinsics, the relative poses, each
// instant's board relative to camera 0 (placed from the first camera that saw it).
JointParameters joint_start(const std::vector<CalibrationResult>& singles, const std::vector<Pose>& from_rig,
                            const RigViews& v, const std::vector<RigCamera>& cameras, const BoardSpec& board,
                            bool warp) {
  JointParameters joint;
  joint.board = board;
  if (warp) joint.warp = {0.0, 0.0};
  for (size_t k = 0; k < singles.size(); ++k) {
    const auto& fixed = cameras[k].fixed_intrinsics;
    joint.fixed.push_back(fixed ? std::make_shared<const Camera>(*fixed) : nullptr);
    const auto& p = singles[k].camera;
    joint.intrinsics.push_back(Solve{model_params(p.model), p.grid.principal_point, p.grid.pixel_scale.y(), {}});
    joint.cameras.push_back(pose_block(from_rig[k]));
  }
  joint.boards.resize(v.instant_index.size());
  std::vector<bool> placed(v.instant_index.size(), false);
  for (size_t k = 0; k < singles.size(); ++k) {
    for (const auto& [i, pose] : v.seen[k]) {
      if (placed[size_t(i)]) continue;
      joint.boards[size_t(i)] = pose_block(compose(inverse(from_rig[k]), pose));
      placed[size_t(i)] = true;
    }
  }
  return joint;
}

// The robust joint solve (Cauchy), as one camera's: the corners that agree with their
// own camera but not with the others at the same instant are the joint outliers; added
// to `excluded` and said, per camera, naming the images that lost most of their board.
std::vector<std::vector<CalibrationResult::Outlier>> reject_joint_outliers(
    JointParameters* joint, const std::vector<RigCamera>& cameras, const RigViews& v,
    const std::vector<Eigen::Vector3d>& points, std::vector<CornerSet>* excluded, std::vector<std::string>* warnings) {
  ceres::Problem::Options robust_options;
  robust_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem robust(robust_options);
  ceres::CauchyLoss loss(1.0);
  add_joint_residuals(&robust, joint, cameras, v.observed, points, *excluded, &loss);
  ceres::Solver::Summary summary;
  ceres::Solve(detail::solver_options(ceres::DENSE_SCHUR), &robust, &summary);
  if (!summary.IsSolutionUsable()) throw Error("calibrate rig: the joint solve failed: " + summary.message);
  auto outliers = joint_outliers(*joint, cameras, v.observed, points, *excluded);
  for (size_t k = 0; k < cameras.size(); ++k) {
    std::map<std::string, int> per_image;
    for (const auto& o : outliers[k]) (*excluded)[k].insert({o.filename, o.corner}), ++per_image[o.filename];
    if (outliers[k].empty()) continue;
    std::map<std::string, size_t> corners_in;  // each image's corners (a partial board has fewer)
    for (const auto& [i, view] : v.observed[k]) corners_in[view->filename] = view->corners.size();
    std::string worst;
    for (const auto& [image, count] : per_image) {
      if (2 * size_t(count) > corners_in[image]) worst += (worst.empty() ? "" : ", ") + image;
    }
    warnings->push_back(camera_name(k) + ": the joint solve leaves out " + std::to_string(outliers[k].size()) +
                        " corner(s) that disagree with the other cameras' boards at the same instants" +
                        (worst.empty() ? "" : " (most of the board in " + worst + ": not taken at the same time?)"));
  }
  return outliers;
}

// The joint solution's covariance and where each camera's parameters lie in it:
// intrinsics, then cameras 1..'s poses, the boards' warp, then the boards that kept a corner.
struct JointCovariance {
  ParameterCovariance full;
  std::vector<Eigen::Index> intrinsic_start, pose_start;
  Eigen::Index warp_start = -1, boards_start = 0;  // warp: -1 for flat boards
  std::vector<std::array<double, 6>> used_boards;
};

JointCovariance joint_covariance(ceres::Problem* problem, JointParameters* joint) {
  const size_t n = joint->intrinsics.size();
  JointCovariance c;
  c.intrinsic_start.resize(n), c.pose_start.assign(n, -1);
  std::vector<double*> blocks;
  Eigen::Index column = 0;
  for (size_t k = 0; k < n; ++k) {
    Solve& s = joint->intrinsics[k];
    if (joint->fixed[k]) {
      c.intrinsic_start[k] = -1;  // held fixed: not a parameter
      continue;
    }
    c.intrinsic_start[k] = column;
    blocks.insert(blocks.end(), {s.model.data(), s.center.data(), &s.ay});
    column += Eigen::Index(s.model.size()) + 3;
  }
  for (size_t k = 1; k < n; ++k) c.pose_start[k] = column, blocks.push_back(joint->cameras[k].data()), column += 6;
  if (!joint->warp.empty()) c.warp_start = column, blocks.push_back(joint->warp.data()), column += 2;
  c.boards_start = column;
  // The instants whose board kept a corner (an instant only one camera saw may lose
  // them all to the joint outliers).
  std::vector<double*> boards;
  for (auto& b : joint->boards) {
    if (problem->HasParameterBlock(b.data())) boards.push_back(b.data()), c.used_boards.push_back(b);
  }
  c.full = detail::covariance_of(problem, blocks, boards);
  return c;
}

// The joint solve's warp (one for all boards) and its sigma in a camera's report;
// none for flat boards.
void report_joint_warp(const JointParameters& joint, const JointCovariance& c, CalibrationResult* r) {
  r->board_warp.reset();
  if (joint.warp.empty()) return;
  const auto sigma = [&](Eigen::Index i) { return std::sqrt(c.full.covariance(i, i)); };
  r->board_warp = BoardWarp{joint.warp[0], joint.warp[1]};
  r->board_warp_sigma = BoardWarp{sigma(c.warp_start), sigma(c.warp_start + 1)};
}

// A solved camera's intrinsics, their sigmas and what the joint solve does not determine.
void report_joint_intrinsics(size_t k, const Solve& s, const JointCovariance& c, const std::string& model,
                             CalibrationResult* r) {
  r->parameters = s.model;
  r->parameters.insert(r->parameters.end(), {s.center.x(), s.center.y(), s.ay});
  r->undetermined.clear();
  for (size_t i = 0; i < r->parameters.size(); ++i) {
    const Eigen::Index at = c.intrinsic_start[k] + Eigen::Index(i);
    r->sigmas[i] = std::sqrt(c.full.covariance(at, at));
  }
  for (const Eigen::VectorXd& direction : c.full.undetermined) {
    std::vector<std::string> names;
    for (size_t i = 0; i < r->parameters.size(); ++i) {
      if (std::abs(direction[c.intrinsic_start[k] + Eigen::Index(i)]) >= 0.1) {
        names.push_back(r->parameter_names[i]);
        r->sigmas[i] = std::numeric_limits<double>::quiet_NaN();
      }
    }
    if (!names.empty()) r->undetermined.push_back(undetermined_text(names, false, model, r->parameters));
  }
}

// Step 4 for camera k: its report from the joint solution -- intrinsics and sigmas,
// reprojection, board poses and observed angles in its frame, the record's
// covariance (its intrinsics, its pose relative to camera 0, every instant's board),
// its outliers numbered as in its corners file.
CalibrationResult joint_report(size_t k, const CalibrationResult& single, const RigCamera& rig_camera,
                               const JointParameters& joint, const JointCovariance& c, const RigViews& v,
                               const std::vector<Eigen::Vector3d>& points, const CornerSet& excluded,
                               const std::vector<CalibrationResult::Outlier>& outliers, long corners,
                               const BoardSpec& board) {
  CalibrationResult r = single;
  const Solve& s = joint.intrinsics[k];
  const Pose rig_to_camera = pose_of(joint.cameras[k]);
  CameraParameters p = r.camera;
  if (!joint.fixed[k]) {
    p.model = make_model(rig_camera.model.name, s.model);
    p.grid.principal_point = s.center;
    p.grid.pixel_scale = {1.0, s.ay};
  }
  p.pose = inverse(rig_to_camera);  // camera -> camera 0
  const Camera camera(p);
  r.poses.clear(), r.used_images.clear(), r.per_image_rms_px.clear();
  double sum2 = 0;
  // Intrinsics held fixed keep their own calibration's record (what determined them);
  // solved ones get the joint solve's.
  CalibrationRecord record = CalibrationRecord::nothing_observed();
  if (!joint.fixed[k]) {
    record.covariance = detail::projection_covariance_of(
        c.full,
        {c.intrinsic_start[k], Eigen::Index(s.model.size()) + 3, c.pose_start[k], c.boards_start, joint.cameras[k]},
        c.used_boards);
  }
  for (const auto& [i, o] : v.observed[k]) {
    const Pose board_pose = compose(rig_to_camera, pose_of(joint.boards[size_t(i)]));
    double board_sum2 = 0;
    long used = 0;
    for (size_t corner = 0; corner < o->corners.size(); ++corner) {
      if (excluded.count({o->filename, o->id(corner)})) continue;
      const Eigen::Vector3d point =
          board_pose.rotation * detail::warped(joint.board, joint.warp, points[size_t(o->id(corner))]) +
          board_pose.translation;
      Eigen::Vector2d q;
      camera.project(point, &q);
      board_sum2 += (q - o->corners[corner]).squaredNorm(), ++used;
      record.observe(point);
    }
    if (used == 0) continue;  // every corner an outlier of the joint solve
    sum2 += board_sum2;
    r.poses.push_back(board_pose);
    r.used_images.push_back(o->filename);
    r.per_image_rms_px.push_back(std::sqrt(board_sum2 / double(used)));
  }
  r.rms_px = std::sqrt(sum2 / double(std::max(1L, corners)));
  r.observations = corners;
  r.renumbered_images.assign(v.renumbered_images[k].begin(), v.renumbered_images[k].end());
  for (CalibrationResult::Outlier o : outliers) {  // numbered as in the corners file
    if (v.renumbered_images[k].count(o.filename)) o.corner = board.corners() - 1 - o.corner;
    r.outliers.push_back(o);
  }
  r.noise_px = std::sqrt(c.full.variance);
  report_joint_warp(joint, c, &r);
  if (joint.fixed[k]) {  // parameters as given, sigma 0
    r.camera = p;
    return r;
  }
  p.calibration = record;
  report_joint_intrinsics(k, s, c, rig_camera.model.name, &r);
  r.camera = p;
  check_solution(r, rig_camera.width, rig_camera.height, camera_name(k) + " " + rig_camera.model.name);
  return r;
}

}  // namespace

RigCalibrationResult calibrate_rig(const std::vector<RigCamera>& cameras, const BoardSpec& board,
                                   const CalibrationOptions& options) {
  const size_t n = cameras.size();
  if (n < 2) throw Error("calibrate rig: needs at least 2 cameras, got " + std::to_string(n));
  for (size_t k = 0; k < n; ++k) {
    if (!cameras[k].fixed_intrinsics &&
        (cameras[k].model.tangential_terms > 0 || !cameras[k].model.mrcal_lens.empty())) {
      throw Error("calibrate rig: camera " + std::to_string(k) + ": a rig's joint solve takes radial models only (" +
                  cameras[k].model.name +
                  " without +tangential/+thin-prism or an mrcal lens; or calibrate it alone and pass "
                  "--fix-intrinsics)");
    }
  }
  const std::vector<CalibrationResult> singles = calibrate_each(cameras, board, options);
  RigViews views;
  index_views(cameras, singles, &views);
  resolve_numbering(board, &views);
  JointParameters joint = joint_start(singles, relative_poses(views), views, cameras, board, options.board_warp);
  // 3. The joint solve, the outliers of step 1 left out, then the joint outliers.
  const auto points = board_points(board);
  std::vector<CornerSet> excluded(n);  // (image, corner) per camera
  for (size_t k = 0; k < n; ++k) {
    for (const auto& o : singles[k].outliers) {
      const bool renumbered = views.renumbered_images[k].count(o.filename) != 0;
      excluded[k].insert({o.filename, renumbered ? board.corners() - 1 - o.corner : o.corner});
    }
  }
  const auto outliers = reject_joint_outliers(&joint, cameras, views, points, &excluded, &views.warnings);
  ceres::Problem problem;  // plain least squares without them: the solution, its covariance
  const std::vector<long> corners_of =
      add_joint_residuals(&problem, &joint, cameras, views.observed, points, excluded, nullptr);
  ceres::Solver::Summary summary;
  ceres::Solve(detail::solver_options(ceres::DENSE_SCHUR), &problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("calibrate rig: the joint solve failed: " + summary.message);
  // 4. Covariance of everything; the report per camera.
  const JointCovariance covariance = joint_covariance(&problem, &joint);
  RigCalibrationResult out;
  out.warnings = views.warnings;
  out.instants = long(views.instant_index.size());
  out.rms_px = std::sqrt(2 * summary.final_cost /
                         double(std::max(1L, std::accumulate(corners_of.begin(), corners_of.end(), 0L))));
  for (size_t k = 0; k < n; ++k) {
    CalibrationResult r = joint_report(k, singles[k], cameras[k], joint, covariance, views, points, excluded[k],
                                       outliers[k], corners_of[k], board);
    double rotation = 0, translation = 0;
    for (int j = 0; j < 3 && k > 0; ++j) {
      const Eigen::Index at = covariance.pose_start[k] + j;
      rotation = std::max(rotation, std::sqrt(covariance.full.covariance(at, at)));
      translation = std::max(translation, std::sqrt(covariance.full.covariance(at + 3, at + 3)));
    }
    out.fixed_intrinsics.push_back(cameras[k].fixed_intrinsics.has_value());
    out.rotation_sigma_rad.push_back(rotation);
    out.translation_sigma.push_back(translation);
    for (const auto& w : r.warnings) out.warnings.push_back(camera_name(k) + ": " + w);
    for (std::string& w : joint_solve_warnings(camera_name(k), singles[k], r)) out.warnings.push_back(std::move(w));
    out.cameras.push_back(std::move(r));
  }
  for (const Eigen::VectorXd& direction : covariance.full.undetermined) {
    bool intrinsic = false;
    for (size_t k = 0; k < n; ++k) {
      if (covariance.intrinsic_start[k] < 0) continue;  // held fixed
      const Eigen::Index count = Eigen::Index(out.cameras[k].parameters.size());
      intrinsic = intrinsic || direction.segment(covariance.intrinsic_start[k], count).norm() >= 0.1;
    }
    if (!intrinsic) {
      out.warnings.push_back(
          "the data do not determine the cameras' relative poses fully (a direction of the joint solve has no "
          "curvature)");
    }
  }
  return out;
}

}  // namespace fishcam
