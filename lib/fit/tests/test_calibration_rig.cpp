// Camera rigs: a synthetic four-camera surround view (the WoodScape layout: front,
// rear, left and right mirrors) recovered from boards seen at shared instants.
#include <algorithm>
#include <numbers>
#include <optional>
#include <random>

#include <nlohmann/json.hpp>

#include "fishcam/fit/calibration.hpp"
#include "fishcam/io/corners.hpp"
#include "fishcam/testing/test_support.hpp"
#include "fishcam/testing/testing.hpp"

namespace fishcam {
namespace {

const BoardSpec kBoard{9, 6, 0.1};

Pose pose(double yaw_deg, const Eigen::Vector3d& position) {  // camera -> car (x right, y down, z forward)
  const double yaw = yaw_deg * std::numbers::pi / 180;
  // Each camera looks out and 15 degrees down.
  const Eigen::Matrix3d look = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(-15 * std::numbers::pi / 180, Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
  return {Eigen::Quaterniond(look), position};
}

struct SyntheticRig {
  std::vector<Pose> truth;  // camera -> car
  std::vector<RigCamera> cameras;
};

// Each camera's own boards (synthesize_boards: spread over its whole image),
// placed around the car; every camera that sees a board whole observes it at that
// instant (adjacent 190-degree cameras share the boards at their rims).
SyntheticRig surround_rig(double noise_px, std::uint64_t seed, const BoardWarp& bow = {}) {
  const CameraParameters full = read_camera(test::data_path("kannala_brandt.yaml")).parameters();
  const Camera lens(resized(full, 640, 483));
  SyntheticRig rig;
  rig.truth = {pose(0, {0, -0.6, 2.0}), pose(180, {0, -0.7, -2.5}), pose(-90, {-0.9, -1.0, 0.8}),
               pose(90, {0.9, -1.0, 0.8})};
  rig.cameras.resize(4, RigCamera{{}, lens.width(), lens.height(), {"kannala-brandt"}});
  std::mt19937_64 random(seed);
  std::normal_distribution<double> noise(0, noise_px);
  const auto points = board_points(kBoard, bow);
  int instant = 0;
  for (size_t k = 0; k < 4; ++k) {
    for (const BoardPose& in_k : testing::synthesize_boards(lens, kBoard, 16, 0.0, seed * 10 + k).poses) {
      const Pose in_car = {rig.truth[k].rotation * in_k.rotation,
                           rig.truth[k].rotation * in_k.translation + rig.truth[k].translation};
      const std::string name = "instant-" + std::to_string(instant++) + ".png";
      for (size_t j = 0; j < 4; ++j) {
        const Eigen::Quaterniond to_j = rig.truth[j].rotation.conjugate();
        std::vector<Eigen::Vector2d> corners;
        for (const auto& p : points) {
          Eigen::Vector2d q;
          const Eigen::Vector3d in_j = to_j * (in_car.rotation * p + in_car.translation - rig.truth[j].translation);
          if (!lens.project(in_j, &q) || q.x() < 0 || q.y() < 0 || q.x() > lens.width() - 1 ||
              q.y() > lens.height() - 1)
            break;
          corners.push_back(q + Eigen::Vector2d(noise(random), noise(random)));
        }
        if (corners.size() == points.size())
          rig.cameras[j].observations.push_back({"cam" + std::to_string(j) + "/" + name, corners});
      }
    }
  }
  return rig;
}

// Each camera's corners written to DIR/camK.vnl, as the program's --corners arguments.
std::string corners_arguments(const SyntheticRig& rig, const std::filesystem::path& dir) {
  std::string arguments;
  for (size_t k = 0; k < rig.cameras.size(); ++k) {
    const auto path = dir / ("cam" + std::to_string(k) + ".vnl");
    write_corners(path, rig.cameras[k].observations, kBoard);
    arguments += " --corners " + test::quoted(path);
  }
  return arguments;
}

// Camera k's pose relative to camera 0 (camera -> camera 0).
Pose relative(const std::vector<Pose>& truth, size_t k) {
  const Eigen::Quaterniond to_0 = truth[0].rotation.conjugate();
  return {to_0 * truth[k].rotation, to_0 * (truth[k].translation - truth[0].translation)};
}

TEST(Rig, NoiseFreeSurroundViewIsRecovered) {
  const SyntheticRig rig = surround_rig(0.0, 1);
  // Every camera shares instants with another (adjacent cameras see boards at their rims).
  for (size_t k = 0; k < 4; ++k) {
    int shared = 0;
    for (const auto& o : rig.cameras[k].observations) {
      const std::string instant = o.filename.substr(5);
      for (size_t j = 0; j < 4; ++j) {
        if (j == k) continue;
        for (const auto& other : rig.cameras[j].observations) shared += other.filename.substr(5) == instant;
      }
    }
    ASSERT_GE(shared, 2) << "camera " << k;
  }
  const RigCalibrationResult r = calibrate_rig(rig.cameras, kBoard, {2});
  ASSERT_EQ(r.cameras.size(), 4u);
  EXPECT_LT(r.rms_px, 1e-6);
  const double baseline = (rig.truth[1].translation - rig.truth[0].translation).norm();
  int checked = 0;
  for (size_t k = 0; k < 4; ++k) {
    const Pose expected = relative(rig.truth, k);
    const Pose& got = *r.cameras[k].camera.pose;
    EXPECT_LT(got.rotation.angularDistance(expected.rotation), 1e-4) << "camera " << k;
    EXPECT_LT((got.translation - expected.translation).norm(), 1e-4 * baseline) << "camera " << k;
    ++checked;
  }
  EXPECT_EQ(checked, 4);
  EXPECT_EQ(r.rotation_sigma_rad[0], 0);
}

TEST(Rig, WithNoiseThePosesSitWithinThreeSigma) {
  const SyntheticRig rig = surround_rig(0.3, 2);
  const RigCalibrationResult r = calibrate_rig(rig.cameras, kBoard, {2});
  for (size_t k = 1; k < 4; ++k) {
    const Pose expected = relative(rig.truth, k);
    const Pose& got = *r.cameras[k].camera.pose;
    ASSERT_GT(r.rotation_sigma_rad[k], 0);
    ASSERT_GT(r.translation_sigma[k], 0);
    // The sigmas are per component; the errors' norms against sqrt(3) times the largest.
    EXPECT_LT(got.rotation.angularDistance(expected.rotation), 3 * std::sqrt(3.0) * r.rotation_sigma_rad[k]) << k;
    EXPECT_LT((got.translation - expected.translation).norm(), 3 * std::sqrt(3.0) * r.translation_sigma[k]) << k;
  }
}

TEST(Rig, ACameraSharingNoInstantIsRefused) {
  SyntheticRig rig = surround_rig(0.0, 3);
  for (auto& o : rig.cameras[2].observations) o.filename = "cam2/lonely-" + o.filename.substr(5);
  // Camera 2 still shares nothing once its names differ from every other camera's.
  try {
    calibrate_rig(rig.cameras, kBoard);
    ADD_FAILURE() << "a camera without shared instants was calibrated into the rig";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera 2 shares no board instant"), std::string::npos) << e.what();
  }
  EXPECT_THROW(calibrate_rig({rig.cameras[0]}, kBoard), Error);
}

// A stereo pair looking forward, 0.12 m apart: every board of camera 0 that camera
// 1 sees whole is observed by both at that instant.
// wobble_rad: camera 1 turned about a random axis by a normal angle of that sigma at
// each instant (a camera loose in its mount; pairs not taken at the same moment).
// noise_seed: the corners' noise drawn apart from the boards (default: from seed too).
// Both cameras are `lens` (a Kannala-Brandt lens at 640 x 483 unless given), calibrated as `model`.
SyntheticRig stereo_rig(double noise_px, std::uint64_t seed, double baseline = 0.12, double wobble_rad = 0,
                        std::optional<std::uint64_t> noise_seed = std::nullopt,
                        const std::string& lens_file = "kannala_brandt.yaml",
                        const std::string& model = "kannala-brandt") {
  const CameraParameters full = read_camera(test::data_path(lens_file)).parameters();
  const Camera lens(resized(full, 640, 483));
  SyntheticRig rig;
  rig.truth = {pose(0, {0, 0, 0}),
               {Eigen::Quaterniond(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY())), {baseline, 0.003, 0}}};
  rig.cameras.resize(2, RigCamera{{}, lens.width(), lens.height(), {model}});
  std::mt19937_64 random(noise_seed.value_or(seed));
  std::normal_distribution<double> noise(0, noise_px);
  const auto points = board_points(kBoard);
  int instant = 0;
  for (const BoardPose& in_0 : testing::synthesize_boards(lens, kBoard, 24, 0.0, seed).poses) {
    const Pose in_rig = compose(rig.truth[0], in_0);
    const std::string name = "instant-" + std::to_string(instant++) + ".png";
    std::vector<std::vector<Eigen::Vector2d>> seen(2);
    std::vector<Pose> now = rig.truth;
    if (wobble_rad > 0) {
      std::normal_distribution<double> angle(0, wobble_rad);
      const Eigen::Vector3d axis = Eigen::Vector3d(noise(random), noise(random), noise(random)).normalized();
      now[1].rotation = now[1].rotation * Eigen::Quaterniond(Eigen::AngleAxisd(angle(random), axis));
    }
    for (size_t j = 0; j < 2; ++j) {
      for (const auto& p : points) {
        Eigen::Vector2d q;
        const Eigen::Vector3d in_j =
            inverse(now[j]).rotation * (in_rig.rotation * p + in_rig.translation) + inverse(now[j]).translation;
        if (!lens.project(in_j, &q) || q.x() < 0 || q.y() < 0 || q.x() > lens.width() - 1 || q.y() > lens.height() - 1)
          break;
        seen[j].push_back(q + Eigen::Vector2d(noise(random), noise(random)));
      }
    }
    if (seen[0].size() != points.size() || seen[1].size() != points.size()) continue;
    for (size_t j = 0; j < 2; ++j)
      rig.cameras[j].observations.push_back({"cam" + std::to_string(j) + "/" + name, seen[j]});
  }
  return rig;
}

void expect_rig_truth(const RigCalibrationResult& r, const SyntheticRig& rig, double angle_rad, double metres) {
  const Pose expected = relative(rig.truth, 1);
  const Pose& got = *r.cameras[1].camera.pose;
  EXPECT_LT(got.rotation.angularDistance(expected.rotation), angle_rad);
  EXPECT_LT((got.translation - expected.translation).norm(), metres);
}

// The rig file's record describes the intrinsics it holds: its covariance is the
// joint solve's (the intrinsic block equals the reported sigmas squared) and holds
// where the camera sits in the rig (camera 1 at infinity: at least the spread its
// rotation relative to camera 0 gives at the image centre).
TEST(Rig, TheRecordsCovarianceIsTheJointSolves) {
  const SyntheticRig rig = stereo_rig(0.3, 11);
  const RigCalibrationResult r = calibrate_rig(rig.cameras, kBoard);
  ASSERT_EQ(r.cameras.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    const CalibrationResult& c = r.cameras[k];
    const Eigen::MatrixXd& covariance = c.camera.calibration->covariance;
    ASSERT_EQ(covariance.rows(), Eigen::Index(c.parameters.size()) + 6) << k;
    for (size_t i = 0; i < c.parameters.size(); ++i) {
      EXPECT_NEAR(std::sqrt(covariance(Eigen::Index(i), Eigen::Index(i))), c.sigmas[i], 1e-9 * c.sigmas[i])
          << "camera " << k << " " << c.parameter_names[i];
    }
  }
  const Camera right(r.cameras[1].camera);
  const Eigen::Vector2d centre = right.principal_point();
  const double focal = right.parameters().grid.pixel_scale.x() * model_params(right.parameters().model)[0];
  const double at_infinity = projection_uncertainty(right, centre, std::nullopt);
  EXPECT_GE(at_infinity, focal * r.rotation_sigma_rad[1]);
}

// The rig's covariance predicts the spread of the relative pose: the same boards
// calibrated 60 times with fresh 0.3 px noise, the spread of camera 1's pose
// parameters (camera 0 -> camera 1: angle-axis and translation, the joint solve's
// block) against the sigmas each calibration reports (its largest component).
TEST(RigSweep, TheReportedSigmasPredictTheSpreadOfReNoisedCalibrations) {
  constexpr int kRuns = 60;
  std::vector<Eigen::Matrix<double, 6, 1>> errors;
  double rotation_sigma = 0, translation_sigma = 0;
  Pose truth;
  for (int run = 0; run < kRuns; ++run) {
    const SyntheticRig rig = stereo_rig(0.3, 21, 0.12, 0, 1000 + run);
    truth = inverse(relative(rig.truth, 1));  // camera 0 -> camera 1
    const RigCalibrationResult r = calibrate_rig(rig.cameras, kBoard);
    const Pose got = inverse(*r.cameras[1].camera.pose);
    const Eigen::AngleAxisd turned(got.rotation * truth.rotation.conjugate());
    Eigen::Matrix<double, 6, 1> e;
    e << turned.angle() * turned.axis(), got.translation - truth.translation;
    errors.push_back(e);
    rotation_sigma += r.rotation_sigma_rad[1] / kRuns, translation_sigma += r.translation_sigma[1] / kRuns;
  }
  ASSERT_EQ(int(errors.size()), kRuns);
  Eigen::Matrix<double, 6, 1> mean = Eigen::Matrix<double, 6, 1>::Zero(), spread = mean;
  for (const auto& e : errors) mean += e / kRuns;
  for (const auto& e : errors) spread += (e - mean).cwiseAbs2() / (kRuns - 1);
  spread = spread.cwiseSqrt();
  const double rotation = spread.head<3>().maxCoeff(), translation = spread.tail<3>().maxCoeff();
  std::printf("  spread / reported sigma: rotation %.3g / %.3g rad, translation %.3g / %.3g m\n", rotation,
              rotation_sigma, translation, translation_sigma);
  // 60 runs estimate a spread to ~9 %: within 0.7-1.4 of the prediction.
  EXPECT_GT(rotation / rotation_sigma, 0.7);
  EXPECT_LT(rotation / rotation_sigma, 1.4);
  EXPECT_GT(translation / translation_sigma, 0.7);
  EXPECT_LT(translation / translation_sigma, 1.4);
}

// The same corners of a stereo pair through mrcal-calibrate-cameras' joint solve
// (LENSMODEL_STEREOGRAPHIC, no board warp; images of one instant matched by the
// glob's *): the relative poses agree within 0.5 mm and 0.1 deg, and both sit near
// the truth.
TEST(Rig, AgreesWithMrcalsJointSolve) {
  const SyntheticRig rig = stereo_rig(0.3, 31, 0.12, 0, std::nullopt, "stereographic.cameramodel", "stereographic");
  const auto dir = test::scratch_dir("rig_mrcal");
  std::vector<BoardObservation> all;
  for (const auto& camera : rig.cameras) all.insert(all.end(), camera.observations.begin(), camera.observations.end());
  ASSERT_GE(rig.cameras[0].observations.size(), 10u);
  write_corners(dir / "corners.vnl", all, kBoard);
  const std::string command =
      "cd '" + dir.string() +
      "' && /usr/bin/mrcal-calibrate-cameras --corners-cache corners.vnl --lensmodel LENSMODEL_STEREOGRAPHIC "
      "--focal 165 --object-spacing 0.1 --object-width-n 9 --object-height-n 6 --imagersize 640 483 --outdir . "
      "--skip-calobject-warp-solve 'cam0/*.png' 'cam1/*.png' > log.txt 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << test::read_file(dir / "log.txt");
  const Camera theirs = read_camera(dir / "camera-1.cameramodel");  // camera 1 -> camera 0 (mrcal's reference)
  ASSERT_TRUE(theirs.parameters().pose.has_value());
  const Pose their_pose = *theirs.parameters().pose;
  const RigCalibrationResult ours = calibrate_rig(rig.cameras, kBoard);
  const Pose& our_pose = *ours.cameras[1].camera.pose;
  const double baseline_mm = 1e3 * (our_pose.translation - their_pose.translation).norm();
  const double rotation_deg = our_pose.rotation.angularDistance(their_pose.rotation) * 180 / std::numbers::pi;
  std::printf("  fishcam vs mrcal's joint solve: translation %.3g mm apart, rotation %.3g deg apart\n", baseline_mm,
              rotation_deg);
  EXPECT_LT(baseline_mm, 0.5);
  EXPECT_LT(rotation_deg, 0.1);
  expect_rig_truth(ours, rig, 2e-3, 2e-3);
}

// One view of camera 1 not taken with camera 0's (its board 6 px away from where
// camera 0's board puts it; on its own the view is a consistent board): the joint
// solve leaves its corners out, says which image, and the rig stays within 3 sigma.
TEST(Rig, CornersThatDisagreeWithTheOtherCamerasAreLeftOut) {
  SyntheticRig rig = stereo_rig(0.2, 12);
  ASSERT_GE(rig.cameras[1].observations.size(), 8u);
  BoardObservation& late = rig.cameras[1].observations[3];
  for (auto& c : late.corners) c += Eigen::Vector2d(6, -2);
  const RigCalibrationResult r = calibrate_rig(rig.cameras, kBoard);
  long in_late = 0;
  for (const auto& o : r.cameras[1].outliers) {
    EXPECT_EQ(o.filename, late.filename);
    in_late += o.filename == late.filename;
  }
  EXPECT_GE(in_late, 45) << "of 54 corners";
  bool said = false;
  for (const auto& w : r.warnings) said = said || w.find("most of the board in " + late.filename) != std::string::npos;
  EXPECT_TRUE(said);
  const Pose expected = relative(rig.truth, 1);
  const Pose& got = *r.cameras[1].camera.pose;
  EXPECT_LT(got.rotation.angularDistance(expected.rotation), 3 * std::sqrt(3.0) * r.rotation_sigma_rad[1]);
  EXPECT_LT((got.translation - expected.translation).norm(), 3 * std::sqrt(3.0) * r.translation_sigma[1]);
}

// The same corners given for both cameras (one file twice) would make a rig with no
// baseline: refused naming both cameras.
TEST(Rig, IdenticalCamerasAreRefused) {
  SyntheticRig rig = stereo_rig(0.1, 5);
  ASSERT_GE(rig.cameras[0].observations.size(), 8u);
  rig.cameras[1].observations = rig.cameras[0].observations;
  for (auto& o : rig.cameras[1].observations) o.filename = "cam1/" + o.filename.substr(5);
  try {
    calibrate_rig(rig.cameras, kBoard);
    ADD_FAILURE() << "a rig of one camera's corners twice was calibrated";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera 1 has the same corners as camera 0"), std::string::npos) << e.what();
  }
}

// A chessboard looks the same turned by 180 degrees: one camera's detector numbered
// some boards from the other end. Each such view is renumbered (and said), and the
// rig is the one the consistently numbered corners give.
TEST(Rig, BoardsNumberedFromTheOtherEndAreRenumbered) {
  const SyntheticRig rig = stereo_rig(0.1, 6);
  const RigCalibrationResult reference = calibrate_rig(rig.cameras, kBoard);
  expect_rig_truth(reference, rig, 2e-3, 2e-3);
  EXPECT_TRUE(reference.warnings.empty()) << reference.warnings.front();
  SyntheticRig flipped = rig;
  const std::vector<size_t> views{1, 4, 7};
  for (size_t v : views) {
    auto& corners = flipped.cameras[1].observations.at(v).corners;
    std::reverse(corners.begin(), corners.end());
  }
  const RigCalibrationResult r = calibrate_rig(flipped.cameras, kBoard);
  expect_rig_truth(r, rig, 2e-3, 2e-3);
  EXPECT_NEAR(r.rms_px, reference.rms_px, 1e-5);
  int said = 0;
  for (const std::string& w : r.warnings) said += w.find("numbered from the other end") != std::string::npos;
  EXPECT_EQ(said, int(views.size()));
}

// A short baseline (2 cm) with noisy corners: per-instant pose estimates scatter by
// a share of the boards' distance, far more than the baseline; still one mounting.
TEST(Rig, ShortBaselinesAreNotTakenForUnsynchronisedPairs) {
  const SyntheticRig rig = stereo_rig(0.5, 8, 0.02);
  const RigCalibrationResult r = calibrate_rig(rig.cameras, kBoard);
  expect_rig_truth(r, rig, 5e-3, 5e-3);
  for (const std::string& w : r.warnings) EXPECT_EQ(w.find("disagree"), std::string::npos) << w;
}

// Camera 1 wobbling by ~0.5 degrees from instant to instant: each camera calibrates
// on its own, the joint solve cannot explain both with one mounting. It says so: its
// rms is several times the camera's own, and it pulls the intrinsics; the consistent
// rig (BoardsNumberedFromTheOtherEndAreRenumbered) gives no warning.
TEST(Rig, AJointSolveThatHidesInconsistentDataSaysSo) {
  const SyntheticRig rig = stereo_rig(0.1, 9, 0.12, 0.5 * std::numbers::pi / 180);
  const RigCalibrationResult r = calibrate_rig(rig.cameras, kBoard);
  int rms_said = 0;
  for (const std::string& w : r.warnings) {
    rms_said +=
        w.starts_with("camera 1: the joint solve's rms ") && w.find("times its own calibration's") != std::string::npos;
  }
  EXPECT_GE(rms_said, 1) << ::testing::PrintToString(r.warnings);
  EXPECT_GT(r.cameras[1].rms_px, 1.5 * 0.1);
}

// Camera 1's images paired with the next instant's of camera 0 (an unsynchronised
// or mismatched pair list): refused saying so, not blamed on a camera's board.
TEST(Rig, UnsynchronisedPairsAreRefusedSayingSo) {
  SyntheticRig rig = stereo_rig(0.1, 7);
  auto& views = rig.cameras[1].observations;
  ASSERT_GE(views.size(), 8u);
  const std::string first = views.front().filename;
  for (size_t v = 0; v + 1 < views.size(); ++v) views[v].filename = views[v + 1].filename;
  views.back().filename = first;
  try {
    calibrate_rig(rig.cameras, kBoard);
    ADD_FAILURE() << "unsynchronised pairs were calibrated";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera 1 and camera 0 disagree on their relative pose"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("unsynchronised"), std::string::npos) << e.what();
  }
}

// Through the program: one --corners per camera, one file for the rig in each
// format that holds rigs (read back: every camera and its pose), refused in one line
// by a format that holds one camera.
TEST(Rig, TheProgramWritesTheRigInEveryFormatThatHoldsOne) {
  const SyntheticRig rig = surround_rig(0.2, 4);
  const auto dir = test::scratch_dir("rig_cli");
  const std::string corners = corners_arguments(rig, dir);
  const std::string base =
      "calibrate" + corners + " --board 9x6 --spacing 0.1 --imagersize 640x483 --model kannala-brandt ";
  int formats = 0;
  std::vector<Pose> first;
  for (const CameraFormat f : camera_formats()) {  // every format of the table that holds a rig, fishcam first
    if (!camera_format_holds_rig(f)) continue;
    const std::string format(to_string(f)), name = "rig_" + format + ".out";
    const auto r = test::run_fishcam(base + "--format " + format + " --out " + test::quoted(dir / name));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    for (size_t k = 0; k < 4; ++k) {
      CameraReadOptions options;
      options.camera = std::to_string(k);
      const Camera camera = read_camera(dir / name, options);
      ASSERT_TRUE(camera.parameters().pose) << name << " camera " << k;
      const Pose& pose = *camera.parameters().pose;
      if (formats == 0) {
        first.push_back(pose);
        EXPECT_EQ(camera.parameters().calibration.has_value(), true);
        continue;
      }
      EXPECT_LT(pose.rotation.angularDistance(first[k].rotation), 1e-9) << name << " camera " << k;
      EXPECT_LT((pose.translation - first[k].translation).norm(), 1e-9) << name << " camera " << k;
    }
    ++formats;
  }
  EXPECT_EQ(formats, 3);
  EXPECT_LT(first[1].rotation.angularDistance(relative(rig.truth, 1).rotation), 0.01);
  auto r = test::run_fishcam(base + "--out " + test::quoted(dir / "rig_opencv.yaml") + " --format opencv");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("holds one camera, not a rig"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "rig_opencv.yaml"));
  r = test::run_fishcam("calibrate" + corners +
                        " --board 9x6 --spacing 0.1 --imagersize 640x483 --model "
                        "kannala-brandt,equidistant --out " +
                        test::quoted(dir / "bad.json"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("one per camera (4)"), std::string::npos) << r.err;
  // The joint solve's warp: solved by default, as one camera's; flat when told.
  r = test::run_fishcam(base + "--out " + test::quoted(dir / "warped.json") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(nlohmann::json::parse(r.out)["board_warp"]["x2"]["sigma"].get<double>() > 0) << r.out;
  r = test::run_fishcam(base + "--board-warp off --out " + test::quoted(dir / "flat.json") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(nlohmann::json::parse(r.out)["board_warp"].is_null()) << r.out;
}

// Boards bowed as mrcal models them (BoardWarp) seen by the surround rig: the joint
// solve recovers the warp within 3 sigma, every camera's report carries it; held
// flat, the same corners fit worse.
TEST(Rig, TheBoardsWarpIsSolvedJointly) {
  const BoardWarp bow{-0.004, 0.0025};  // 4 and 2.5 mm on a board 0.8 m wide
  const SyntheticRig rig = surround_rig(0.2, 5, bow);
  const RigCalibrationResult r = calibrate_rig(rig.cameras, kBoard, {2});
  for (const CalibrationResult& camera : r.cameras) {
    ASSERT_TRUE(camera.board_warp.has_value());
    EXPECT_EQ(camera.board_warp->x2, r.cameras[0].board_warp->x2);
  }
  const CalibrationResult& c = r.cameras[0];
  EXPECT_LT(std::abs(c.board_warp->x2 - bow.x2), 3 * c.board_warp_sigma.x2) << c.board_warp->x2;
  EXPECT_LT(std::abs(c.board_warp->y2 - bow.y2), 3 * c.board_warp_sigma.y2) << c.board_warp->y2;
  EXPECT_LT(c.board_warp_sigma.x2, 0.001);
  EXPECT_LT(relative(rig.truth, 1).rotation.angularDistance(r.cameras[1].camera.pose->rotation), 3e-3);
  CalibrationOptions held;
  held.threads = 2, held.board_warp = false;
  const RigCalibrationResult flat = calibrate_rig(rig.cameras, kBoard, held);
  EXPECT_FALSE(flat.cameras[0].board_warp.has_value());
  std::printf("  rig rms: warp solved %.4f px (x2 %.5f +- %.2g, y2 %.5f +- %.2g), boards held flat %.4f px\n", r.rms_px,
              c.board_warp->x2, c.board_warp_sigma.x2, c.board_warp->y2, c.board_warp_sigma.y2, flat.rms_px);
  EXPECT_GT(flat.rms_px, 1.03 * r.rms_px);  // 0.2914 against 0.2793 on 2026-12-07
  const auto json = nlohmann::json::parse(rig_calibration_report_json(r, {}, "rig.json"));
  EXPECT_NEAR(json["board_warp"]["x2"]["value"].get<double>(), c.board_warp->x2, 1e-15);
}

}  // namespace
}  // namespace fishcam

namespace fishcam {
namespace {

// The truth's lens of stereo_rig, as a camera file would give it.
CameraParameters stereo_lens() {
  return resized(read_camera(test::data_path("kannala_brandt.yaml")).parameters(), 640, 483);
}

// Intrinsics held fixed (OpenCV's CALIB_FIX_INTRINSIC): only where each camera sits
// is solved. With the true lenses the relative pose sits within 3 sigma of the
// truth, its sigma below the free solve's (the intrinsics' uncertainty no longer
// enters); the cameras keep their intrinsics exactly; one camera may stay free.
TEST(Rig, IntrinsicsHeldFixedSolveOnlyWhereTheCamerasSit) {
  SyntheticRig rig = stereo_rig(0.3, 11);
  const RigCalibrationResult free = calibrate_rig(rig.cameras, kBoard);
  for (auto& camera : rig.cameras) camera.fixed_intrinsics = stereo_lens();
  const RigCalibrationResult fixed = calibrate_rig(rig.cameras, kBoard);
  EXPECT_EQ(fixed.fixed_intrinsics, (std::vector<bool>{true, true}));
  EXPECT_EQ(free.fixed_intrinsics, (std::vector<bool>{false, false}));
  const Pose expected = relative(rig.truth, 1);
  const Pose& got = *fixed.cameras[1].camera.pose;
  EXPECT_LT(got.rotation.angularDistance(expected.rotation), 3 * std::sqrt(3.0) * fixed.rotation_sigma_rad[1]);
  EXPECT_LT((got.translation - expected.translation).norm(), 3 * std::sqrt(3.0) * fixed.translation_sigma[1]);
  EXPECT_LT(fixed.rotation_sigma_rad[1], free.rotation_sigma_rad[1]);
  EXPECT_GT(fixed.rotation_sigma_rad[1], 0);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(model_params(fixed.cameras[k].camera.model), model_params(stereo_lens().model)) << k;
    EXPECT_EQ(fixed.cameras[k].camera.grid, stereo_lens().grid) << k;
    for (const double sigma : fixed.cameras[k].sigmas) EXPECT_EQ(sigma, 0) << k;
  }
  EXPECT_LT(fixed.rms_px, 0.3 * 1.2 * std::sqrt(2.0));
  rig.cameras[0].fixed_intrinsics.reset();  // camera 0 solved, camera 1 held
  const RigCalibrationResult mixed = calibrate_rig(rig.cameras, kBoard);
  EXPECT_EQ(mixed.fixed_intrinsics, (std::vector<bool>{false, true}));
  EXPECT_GT(mixed.cameras[0].sigmas[0], 0);
  expect_rig_truth(mixed, rig, 3e-3, 3e-3);
}

TEST(Rig, IntrinsicsHeldFixedMustBeForTheCornersImageSize) {
  SyntheticRig rig = stereo_rig(0.1, 12);
  rig.cameras[1].fixed_intrinsics = resized(stereo_lens(), 1280, 966);
  try {
    calibrate_rig(rig.cameras, kBoard);
    ADD_FAILURE() << "intrinsics of another image size were used";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("camera 1: its fixed intrinsics are for 1280x966 images, its corners for 640x483"),
        std::string::npos)
        << e.what();
  }
}

// Through the program: --fix-intrinsics FILE|free per --corners; the report says
// which are fixed; a count that does not match is refused in one line.
TEST(Rig, TheProgramHoldsIntrinsicsFixed) {
  const SyntheticRig rig = stereo_rig(0.2, 13);
  const auto dir = test::scratch_dir("rig_fixed_cli");
  const std::string corners = corners_arguments(rig, dir);
  write_camera(stereo_lens(), dir / "lens.json", CameraFormat::fishcam);
  const std::string base =
      "calibrate" + corners + " --board 9x6 --spacing 0.1 --imagersize 640x483 --model kannala-brandt --json ";
  auto r = test::run_fishcam(base + "--fix-intrinsics free " + test::quoted(dir / "lens.json") + " --out " +
                             test::quoted(dir / "rig.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"intrinsics\": \"solved\""), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"intrinsics\": \"fixed\""), std::string::npos) << r.out;
  r = test::run_fishcam(base + "--fix-intrinsics " + test::quoted(dir / "lens.json") + " --out " +
                        test::quoted(dir / "rig2.json"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--fix-intrinsics: give one camera file (or 'free') per --corners (2), not 1"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "rig2.json"));
}

}  // namespace
}  // namespace fishcam
