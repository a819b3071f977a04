// Camera rigs: a synthetic four-camera surround view (the WoodScape layout: front,
// rear, left and right mirrors) recovered from boards seen at shared instants.
#include <random>

#include "fishcam/calibration.hpp"
#include "fishcam/corners.hpp"
#include "fishcam/testing.hpp"
#include "test_support.hpp"

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
SyntheticRig surround_rig(double noise_px, std::uint64_t seed) {
  const CameraParameters full = read_camera(test::data_path("kannala_brandt.yaml")).parameters();
  const Camera lens(resized(full, 640, 483));
  SyntheticRig rig;
  rig.truth = {pose(0, {0, -0.6, 2.0}), pose(180, {0, -0.7, -2.5}), pose(-90, {-0.9, -1.0, 0.8}),
               pose(90, {0.9, -1.0, 0.8})};
  rig.cameras.resize(4, RigCamera{{}, lens.width(), lens.height(), {"kannala-brandt"}});
  std::mt19937_64 random(seed);
  std::normal_distribution<double> noise(0, noise_px);
  const auto points = board_points(kBoard);
  int instant = 0;
  for (size_t k = 0; k < 4; ++k) {
    for (const BoardPose& in_k : testing::synthesize_boards(lens, kBoard, 16, 0.0, seed * 10 + k).poses) {
      const Pose in_car = {rig.truth[k].rotation * in_k.rotation, rig.truth[k].rotation * in_k.translation + rig.truth[k].translation};
      const std::string name = "instant-" + std::to_string(instant++) + ".png";
      for (size_t j = 0; j < 4; ++j) {
        const Eigen::Quaterniond to_j = rig.truth[j].rotation.conjugate();
        std::vector<Eigen::Vector2d> corners;
        for (const auto& p : points) {
          Eigen::Vector2d q;
          const Eigen::Vector3d in_j = to_j * (in_car.rotation * p + in_car.translation - rig.truth[j].translation);
          if (!lens.project(in_j, &q) || q.x() < 0 || q.y() < 0 || q.x() > lens.width() - 1 || q.y() > lens.height() - 1) break;
          corners.push_back(q + Eigen::Vector2d(noise(random), noise(random)));
        }
        if (corners.size() == points.size()) rig.cameras[j].observations.push_back({"cam" + std::to_string(j) + "/" + name, corners});
      }
    }
  }
  return rig;
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

// Through the program: one --corners per camera, one file for the rig in each
// format that holds rigs (read back: every camera and its pose), refused in one line
// by a format that holds one camera.
TEST(Rig, TheProgramWritesTheRigInEveryFormatThatHoldsOne) {
  const SyntheticRig rig = surround_rig(0.2, 4);
  const auto dir = test::scratch_dir("rig_cli");
  std::string corners;
  for (size_t k = 0; k < 4; ++k) {
    const auto path = dir / ("cam" + std::to_string(k) + ".vnl");
    write_corners(path, rig.cameras[k].observations);
    corners += " --corners " + test::quoted(path);
  }
  const std::string base = "calibrate" + corners + " --board 9x6 --spacing 0.1 --imagersize 640x483 --model kannala-brandt ";
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
  r = test::run_fishcam("calibrate" + corners + " --board 9x6 --spacing 0.1 --imagersize 640x483 --model "
                        "kannala-brandt,equidistant --out " + test::quoted(dir / "bad.json"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("one per camera (4)"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace fishcam
