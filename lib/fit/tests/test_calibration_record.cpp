// What a calibration knows about its own data: projection uncertainty checked
// against re-noised calibrations, parameters the data do not determine, the observed
// angles and --theta-limit data, the record in files, and bit-identical results for
// any thread count.
#include <Eigen/Eigenvalues>
#include <nlohmann/json.hpp>
#include <random>

#include "fishcam/core/parallel.hpp"
#include "fishcam/fit/calibration.hpp"
#include "fishcam/io/corners.hpp"
#include "fishcam/testing/test_support.hpp"
#include "fishcam/testing/testing.hpp"

namespace fishcam {
namespace {

const BoardSpec kBoard{10, 10, 0.1};
constexpr double kDeg = 180 / std::numbers::pi;

// Synthetic boards all of whose corners lie within max_deg of the optical axis.
std::vector<BoardObservation> boards_within(const Camera& truth, double max_deg, int count, std::uint64_t seed) {
  std::vector<BoardObservation> inner;
  for (const auto& o : testing::synthesize_boards(truth, kBoard, count, 0.2, seed).observations) {
    const bool confined = std::all_of(o.corners.begin(), o.corners.end(), [&](const Eigen::Vector2d& c) {
      Eigen::Vector3d ray;
      return truth.unproject(c, &ray) && std::acos(ray.z()) < max_deg / kDeg;
    });
    if (confined) inner.push_back(o);
  }
  return inner;
}

std::vector<BoardObservation> renoised(const std::vector<BoardObservation>& clean, double sigma, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::normal_distribution<double> noise(0, sigma);
  auto out = clean;
  for (auto& o : out) {
    for (auto& c : o.corners) c += Eigen::Vector2d(noise(random), noise(random));
  }
  return out;
}

// The worst-direction standard deviation of a set of pixels.
double worst_direction_sigma(const std::vector<Eigen::Vector2d>& q) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& x : q) mean += x;
  mean /= double(q.size());
  Eigen::Matrix2d c = Eigen::Matrix2d::Zero();
  for (const auto& x : q) c += (x - mean) * (x - mean).transpose();
  c /= double(q.size() - 1);
  return std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(c).eigenvalues().maxCoeff());
}

// mrcal's definition, checked by experiment: calibrate 50 times from the same boards
// with fresh corner noise; project the point fixed relative to the (true) boards
// that the truth sees at pixel q through each calibration (the point in each
// calibration's camera frame: the mean over the boards of its solved pose applied
// to the point's board coordinates). The spread of those pixels is what the
// baseline calibration's covariance predicts, within 25 % at every pixel where
// boards were seen, at a distance and at infinity.
// How many pixels were compared (each an expectation).
int compare_with_renoised_calibrations(const Camera& truth, const ModelSpec& spec) {
  const auto clean = testing::synthesize_boards(truth, kBoard, 20, 0.0, 21);
  constexpr double kNoise = 0.3;
  constexpr int kRuns = 50;
  const CalibrationResult baseline =
      calibrate(renoised(clean.observations, kNoise, 1000), kBoard, truth.width(), truth.height(), spec);
  const Camera predicted(baseline.camera);
  std::vector<CalibrationResult> runs(kRuns);
  for_each_index(kRuns, 2, [&](int k) {
    runs[size_t(k)] =
        calibrate(renoised(clean.observations, kNoise, std::uint64_t(k)), kBoard, truth.width(), truth.height(), spec);
  });
  int compared = 0;
  for (const std::optional<double> distance : {std::optional(1.0), std::optional<double>()}) {
    for (int v = 60; v < truth.height(); v += 120) {
      for (int u = 60; u < truth.width(); u += 120) {
        const Eigen::Vector2d pixel(u, v);
        Eigen::Vector3d ray;
        if (!truth.unproject(pixel, &ray) || !baseline.camera.calibration->observed(ray)) continue;
        const Eigen::Vector3d point = distance ? Eigen::Vector3d(*distance * ray) : ray;
        std::vector<Eigen::Vector2d> projected;
        for (const auto& run : runs) {
          Eigen::Vector3d moved = Eigen::Vector3d::Zero();
          for (size_t b = 0; b < run.poses.size(); ++b) {
            const BoardPose& was = clean.poses[b];
            const BoardPose& now = run.poses[b];
            moved += distance ? Eigen::Vector3d(now.rotation * (was.rotation.inverse() * (point - was.translation)) +
                                                now.translation)
                              : Eigen::Vector3d(now.rotation * (was.rotation.inverse() * point));
          }
          Eigen::Vector2d q;
          EXPECT_TRUE(Camera(run.camera).project(moved / double(run.poses.size()), &q));
          projected.push_back(q);
        }
        const double measured = worst_direction_sigma(projected);
        const double expected = projection_uncertainty(predicted, pixel, distance);
        EXPECT_NEAR(measured / expected, 1.0, 0.25)
            << "pixel " << u << "," << v << " distance " << distance.value_or(-1) << ": measured " << measured
            << " px, predicted " << expected << " px";
        ++compared;
      }
    }
  }
  return compared;
}

TEST(ProjectionUncertainty, PredictsTheSpreadOfReNoisedCalibrations) {
  const Camera truth = read_camera(test::data_path("kannala_brandt.yaml"));
  EXPECT_GE(compare_with_renoised_calibrations(truth, {"kannala-brandt"}), 60);  // both distances
}

// The same with OpenCV's tangential terms solved (mei+tangential): their covariance
// enters the prediction.
TEST(ProjectionUncertainty, PredictsTheSpreadOfReNoisedCalibrationsWithTangentialTerms) {
  CameraParameters truth = read_camera(test::data_path("kannala_brandt.yaml")).parameters();
  for (const auto& [label, camera] : test::every_tangential_camera()) {
    if (model_name(camera.model) == "mei") truth = camera;
  }
  ASSERT_EQ(model_name(truth.model), "mei");
  EXPECT_GE(compare_with_renoised_calibrations(Camera(truth), {"mei", 4, 2}), 40);
}

TEST(ProjectionUncertainty, NeedsACovarianceAndIsNaNWithoutARay) {
  const Camera plain = read_camera(test::data_path("kannala_brandt.yaml"));
  try {
    projection_uncertainty(plain, {640, 480}, std::nullopt);
    ADD_FAILURE() << "a camera without a calibration record had an uncertainty";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("carries no calibration covariance"), std::string::npos) << e.what();
  }
  const auto boards = testing::synthesize_boards(plain, kBoard, 12, 0.3, 4);
  const Camera calibrated(calibrate(boards.observations, kBoard, 1280, 966, {"kannala-brandt"}).camera);
  EXPECT_TRUE(std::isnan(projection_uncertainty(calibrated, {-5000, 0}, std::nullopt)));
  EXPECT_THROW(projection_uncertainty(calibrated, {640, 480}, -1.0), Error);
  // Extrapolation (here past the observed angles, along the top edge) is less certain than the data.
  const double centre = projection_uncertainty(calibrated, calibrated.principal_point(), std::nullopt);
  const double corner = projection_uncertainty(calibrated, {0, 0}, std::nullopt);
  Eigen::Vector3d ray;
  ASSERT_TRUE(calibrated.unproject({0, 0}, &ray));
  EXPECT_FALSE(calibrated.parameters().calibration->observed(ray));
  EXPECT_GT(corner, 3 * centre);
}

// At xi = 0 the double-sphere model's xi is a combination of f and alpha: the
// Jacobian has a null direction there. Its sigmas were printed as tight numbers (f
// +- 4.8e-6 while f moved by 10 between halves of the data). Where the solve ends in
// that flat valley depends on rounding (xi ~ 1e-8 in the release build, 0.03 under
// the sanitizers), so the test holds for both: a parameter is either reported "not
// determined" (the combination named) or its sigma is honest -- the two halves of
// the boards (independent calibrations) differ by no more than a few sigmas.
TEST(Calibration, ParametersTheDataDoNotDetermineHaveNoSigma) {
  CameraParameters p;
  p.width = 960, p.height = 600, p.grid.principal_point = {478, 298};
  p.model = make_model("double-sphere", std::vector<double>{230, 0.0, 0.6});
  const BoardSpec board{9, 6, 0.1};
  const auto boards = testing::synthesize_boards(Camera(p), board, 30, 0.2, 3).observations;
  std::vector<BoardObservation> odd, even;
  for (size_t b = 0; b < boards.size(); ++b) (b % 2 ? odd : even).push_back(boards[b]);
  const CalibrationResult r = calibrate(boards, board, p.width, p.height, {"double-sphere"});
  const CalibrationResult a = calibrate(odd, board, p.width, p.height, {"double-sphere"});
  const CalibrationResult b = calibrate(even, board, p.width, p.height, {"double-sphere"});
  ASSERT_EQ(r.parameter_names, (std::vector<std::string>{"f", "xi", "alpha", "cx", "cy", "a_y"}));
  int undetermined = 0;
  for (size_t i = 0; i < 3; ++i) {
    if (std::isnan(r.sigmas[i])) {
      ++undetermined;
    } else {
      // Halves of the data: each sigma ~ sqrt(2) of the full one, their difference ~ 2 sigma.
      EXPECT_LE(std::abs(a.parameters[i] - b.parameters[i]), 12 * r.sigmas[i])
          << r.parameter_names[i] << " sigma " << r.sigmas[i] << " (xi = " << r.parameters[1] << ")";
    }
  }
  if (undetermined > 0) {
    EXPECT_EQ(undetermined, 3);
    ASSERT_EQ(r.undetermined.size(), 1u);
    EXPECT_NE(r.undetermined[0].find("f, xi and alpha trade against each other"), std::string::npos)
        << r.undetermined[0];
  }
  for (size_t i = 3; i < 6; ++i) EXPECT_TRUE(std::isfinite(r.sigmas[i]) && r.sigmas[i] > 0);
  std::printf("  double-sphere at xi = 0: the solve ended at xi = %.3g; %d of f, xi, alpha undetermined\n",
              r.parameters[1], undetermined);
  // A well-determined model reports every sigma, and nothing undetermined.
  p.width = 1280, p.height = 966, p.grid.principal_point = {643, 479};
  p.model = make_model("double-sphere", std::vector<double>{330, 0.3, 0.6});
  const auto determined = calibrate(testing::synthesize_boards(Camera(p), kBoard, 20, 0.2, 3).observations, kBoard,
                                    p.width, p.height, {"double-sphere"});
  EXPECT_TRUE(determined.undetermined.empty());
  for (double s : determined.sigmas) EXPECT_TRUE(std::isfinite(s) && s > 0);
}

// Boards confined to theta < 60 deg: the record says so, per azimuth too, and the
// camera capped at the data stops there (unprojection NaN beyond).
TEST(Calibration, RecordsTheObservedAnglesAndCapsTheDomainAtThem) {
  const Camera truth = read_camera(test::data_path("kannala_brandt.yaml"));
  const std::vector<BoardObservation> inner = boards_within(truth, 60, 80, 5);
  ASSERT_GE(inner.size(), 8u);
  const CalibrationResult r = calibrate(inner, kBoard, 1280, 966, {"kannala-brandt"});
  const CalibrationRecord& record = *r.camera.calibration;
  EXPECT_LT(record.theta_max * kDeg, 60.2);
  EXPECT_GT(record.theta_max * kDeg, 45);
  int observed_sectors = 0;
  for (double a : record.theta_max_by_azimuth) {
    if (std::isnan(a)) continue;
    EXPECT_LE(a, record.theta_max);
    ++observed_sectors;
  }
  EXPECT_GE(observed_sectors, 12);
  EXPECT_TRUE(record.observed({0, 0, 1}));
  EXPECT_FALSE(record.observed({1, 0, 0.1}));  // 84 deg
  const Camera capped(limited_to_observed(r.camera, 2 / kDeg));
  EXPECT_NEAR(capped.domain().theta_max, record.theta_max + 2 / kDeg, 1e-12);
  Eigen::Vector3d ray;
  Eigen::Vector2d beyond;
  ASSERT_TRUE(Camera(r.camera).project(Eigen::Vector3d(std::sin(70 / kDeg), 0, std::cos(70 / kDeg)), &beyond));
  EXPECT_FALSE(capped.unproject(beyond, &ray));
  EXPECT_THROW(limited_to_observed(truth.parameters(), 0), Error);  // no record
}

// Boards that reach 60 deg above the principal point but only 35 deg below it: the
// limit follows them per azimuth (one cap at the largest angle would let the bottom
// of the image unproject 25 deg past the data), and a pixel unprojects through the
// limited camera exactly when the record says its ray was observed.
TEST(Calibration, PerAzimuthLimitFollowsTheBoards) {
  const Camera truth = read_camera(test::data_path("kannala_brandt.yaml"));
  std::vector<BoardObservation> lopsided;
  for (const auto& o : boards_within(truth, 60, 120, 8)) {
    const bool shallow_below = std::all_of(o.corners.begin(), o.corners.end(), [&](const Eigen::Vector2d& c) {
      Eigen::Vector3d ray;
      return truth.unproject(c, &ray) && (ray.y() <= 0 || std::acos(ray.z()) < 35 / kDeg);
    });
    if (shallow_below) lopsided.push_back(o);
  }
  ASSERT_GE(lopsided.size(), 8u);
  const CalibrationResult r = calibrate(lopsided, kBoard, 1280, 966, {"kannala-brandt"});
  const CalibrationRecord& record = *r.camera.calibration;
  // Up: 48 deg in the sanitizer build (clang), where the boards selected differ in the last bits.
  ASSERT_GT(angle_near_azimuth(record.theta_max_by_azimuth, -M_PI / 2) * kDeg, 45);  // up
  ASSERT_LT(angle_near_azimuth(record.theta_max_by_azimuth, M_PI / 2) * kDeg, 35);   // down
  const Camera calibrated(r.camera), limited(limited_to_observed(r.camera, 0));
  EXPECT_EQ(limited.domain().theta_max, record.theta_max);
  for (const double azimuth : {-M_PI / 2, M_PI / 2}) {
    Eigen::Vector2d pixel;
    const Eigen::Vector3d ray(std::sin(40 / kDeg) * std::cos(azimuth), std::sin(40 / kDeg) * std::sin(azimuth),
                              std::cos(40 / kDeg));
    ASSERT_TRUE(calibrated.project(ray, &pixel));
    Eigen::Vector3d back;
    EXPECT_EQ(limited.unproject(pixel, &back), azimuth < 0) << "40 deg at azimuth " << azimuth * kDeg;
  }
  int agree = 0, observed = 0;
  for (int v = 0; v < 966; v += 23) {
    for (int u = 0; u < 1280; u += 23) {
      Eigen::Vector3d ray, limited_ray;
      if (!calibrated.unproject(Eigen::Vector2d(u, v), &ray)) continue;
      const bool inside = record.observed(ray);
      EXPECT_EQ(limited.unproject(Eigen::Vector2d(u, v), &limited_ray), inside) << u << "," << v;
      agree += 1, observed += inside;
    }
  }
  EXPECT_GE(agree, 1500);
  EXPECT_GE(observed, 300);
  // The corners lie inside the limit but for their noise (0.2 px): the record holds the
  // fitted boards' points, which the noisy corners scatter about (in azimuth too,
  // across into a sector pair with a smaller angle: measured up to 0.11 deg past).
  int corners = 0, past = 0;
  for (const auto& o : lopsided) {
    for (const auto& c : o.corners) {
      Eigen::Vector3d ray;
      ++corners;
      if (limited.unproject(c, &ray)) continue;
      ++past;
      ASSERT_TRUE(calibrated.unproject(c, &ray));
      const double cap = angle_near_azimuth(*limited.parameters().theta_limit_by_azimuth, std::atan2(ray.y(), ray.x()));
      EXPECT_LT(std::acos(ray.z()) - cap, 0.25 / kDeg) << o.filename << " " << c.transpose();
    }
  }
  EXPECT_LE(past, corners / 100) << past << " of " << corners;
}

// fishcam JSON keeps the record exactly; other formats leave it out (the tools say
// so); resizing re-expresses the covariance; a broken record is refused by name.
TEST(CalibrationRecord, LivesInFishcamJsonAndResizes) {
  const Camera truth = read_camera(test::data_path("kannala_brandt.yaml"));
  const auto boards = testing::synthesize_boards(truth, kBoard, 12, 0.3, 6);
  const CameraParameters calibrated = calibrate(boards.observations, kBoard, 1280, 966, {"kannala-brandt"}).camera;
  const CameraParameters back = parse_camera(format_camera(calibrated, CameraFormat::fishcam), "cal.json");
  ASSERT_TRUE(back.calibration);
  EXPECT_NEAR(back.calibration->theta_max, calibrated.calibration->theta_max, 1e-15);  // stored in degrees
  EXPECT_EQ(back.calibration->covariance, calibrated.calibration->covariance);
  for (size_t k = 0; k < CalibrationRecord::kAzimuthSectors; ++k) {
    const double a = calibrated.calibration->theta_max_by_azimuth[k], b = back.calibration->theta_max_by_azimuth[k];
    EXPECT_TRUE(std::abs(a - b) < 1e-15 || (std::isnan(a) && std::isnan(b))) << k;
  }
  EXPECT_TRUE(camera_format_holds_calibration_record(CameraFormat::fishcam));
  EXPECT_FALSE(camera_format_holds_calibration_record(CameraFormat::opencv));
  EXPECT_FALSE(parse_camera(format_camera(calibrated, CameraFormat::opencv), "cal.yaml").calibration);

  // Half the image size: the uncertainty halves in pixels at the same ray.
  const Camera full(calibrated), half(resized(calibrated, 640, 483));
  const Eigen::Vector2d q(700, 400);
  const Eigen::Vector2d q_half = (q.array() + 0.5) / 2 - 0.5;
  EXPECT_NEAR(projection_uncertainty(half, q_half, 1.0), projection_uncertainty(full, q, 1.0) / 2, 1e-9);

  std::string text = format_camera(calibrated, CameraFormat::fishcam);
  const auto theta = text.find("\"theta_max_deg\"");
  ASSERT_NE(theta, std::string::npos);
  std::string broken = text;
  broken.replace(theta, 15, "\"theta_max_degrees\"");
  EXPECT_THROW(parse_camera(broken, "cal.json"), Error);
  CameraParameters wrong = calibrated;
  wrong.calibration->covariance.conservativeResize(5, 5);
  try {
    Camera{wrong};
    ADD_FAILURE() << "a covariance of the wrong size was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("calibration.covariance: expected 14x14"), std::string::npos) << e.what();
  }
}

// The same inputs give the same bits whatever the thread count (Ceres on one
// thread per solve, starts combined in a fixed order): through the library, and
// the program's files.
TEST(Calibration, ThreadCountDoesNotChangeTheResult) {
  const Camera truth = read_camera(test::data_path("kannala_brandt.yaml"));
  const auto boards = testing::synthesize_boards(truth, kBoard, 15, 0.3, 7);
  const auto one = calibrate(boards.observations, kBoard, 1280, 966, {"mei"}, {1});
  const auto two = calibrate(boards.observations, kBoard, 1280, 966, {"mei"}, {2});
  EXPECT_EQ(one.parameters, two.parameters);
  EXPECT_EQ(one.camera.calibration->covariance, two.camera.calibration->covariance);

  const auto dir = test::scratch_dir("calibrate_threads");
  write_corners(dir / "c.vnl", boards.observations, kBoard);
  for (const char* threads : {"1", "2"}) {
    const auto r = test::run_fishcam("calibrate --corners " + test::quoted(dir / "c.vnl") +
                                     " --board 10x10 --spacing 0.1 --imagersize 1280x966 --model double-sphere "
                                     "--threads " +
                                     threads + " --out " + test::quoted(dir / ("t" + std::string(threads) + ".json")) +
                                     " --poses " + test::quoted(dir / ("p" + std::string(threads) + ".json")));
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  EXPECT_EQ(test::read_file(dir / "t1.json"), test::read_file(dir / "t2.json"));
  EXPECT_EQ(test::read_file(dir / "p1.json"), test::read_file(dir / "p2.json"));
}

// The program: --images selects, --theta-limit data caps, other formats drop the
// record with a note, bad values are refused in one line and write nothing.
TEST(Calibration, TheProgramSelectsImagesAndCapsAtTheData) {
  const auto dir = test::scratch_dir("calibrate_options");
  const Camera truth = read_camera(test::data_path("kannala_brandt.yaml"));
  write_corners(dir / "c.vnl", testing::synthesize_boards(truth, kBoard, 12, 0.3, 8).observations, kBoard);
  const std::string base = "calibrate --corners " + test::quoted(dir / "c.vnl") +
                           " --board 10x10 --spacing 0.1 --imagersize 1280x966 --model kannala-brandt ";
  auto r = test::run_fishcam(base + "--images 'synth-00[0-5].png,synth-011.png' --theta-limit data+3 --json --out " +
                             test::quoted(dir / "a.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["images"], 7);
  EXPECT_NEAR(report["theta_limit_deg"].get<double>(), report["observed_theta_max_deg"].get<double>() + 3, 1e-9);
  EXPECT_EQ(report["poses"].size(), 7u);
  const Camera capped = read_camera(dir / "a.json");
  EXPECT_NEAR(capped.domain().theta_max * kDeg, report["theta_limit_deg"].get<double>(), 1e-9);
  // Per azimuth: the written camera holds the report's limits, the largest of which is theta_limit_deg.
  const auto& by_azimuth = report["theta_limit_by_azimuth_deg"];
  ASSERT_EQ(by_azimuth.size(), size_t(kAzimuthSectors));
  double largest = 0;
  for (size_t k = 0; k < by_azimuth.size(); ++k) {
    largest = std::max(largest, by_azimuth[k].get<double>());
    EXPECT_NEAR((*capped.parameters().theta_limit_by_azimuth)[k] * kDeg, by_azimuth[k].get<double>(), 1e-12);
  }
  EXPECT_EQ(largest, report["theta_limit_deg"].get<double>());
  r = test::run_fishcam("info " + test::quoted(dir / "a.json"));
  EXPECT_NE(r.out.find("theta limit       per azimuth, "), std::string::npos) << r.out;

  r = test::run_fishcam(base + "--out " + test::quoted(dir / "b.yaml"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("the opencv format cannot hold the calibration record"), std::string::npos) << r.err;

  for (const std::string bad : {"--images 'nothing*.png'", "--theta-limit 70", "--theta-limit data+x", "--threads 0"}) {
    r = test::run_fishcam(base + bad + " --out " + test::quoted(dir / "c.json"));
    EXPECT_NE(r.exit_code, 0) << bad;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << bad << ": " << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "c.json")) << bad;
  }
  // A limit a format cannot hold is refused, not dropped.
  r = test::run_fishcam(base + "--theta-limit data --out " + test::quoted(dir / "d.yaml"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("theta_limit_by_azimuth: the opencv format cannot store a per-azimuth field-of-view limit"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "d.yaml"));
}

}  // namespace
}  // namespace fishcam

namespace fishcam {
namespace {

// info says what the data support beside the model's domain; uncertainty reports
// and draws it, and refuses a camera without a covariance.
TEST(Calibration, InfoAndUncertaintyShowWhatTheDataSupport) {
  const auto dir = test::scratch_dir("calibrate_info");
  const Camera truth = read_camera(test::data_path("kannala_brandt.yaml"));
  const std::vector<BoardObservation> inner = boards_within(truth, 55, 80, 9);
  ASSERT_GE(inner.size(), 6u);
  write_corners(dir / "c.vnl", inner, kBoard);
  auto r = test::run_fishcam("calibrate --corners " + test::quoted(dir / "c.vnl") +
                             " --board 10x10 --spacing 0.1 --imagersize 1280x966 --model polynomial --out " +
                             test::quoted(dir / "cal.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_fishcam("info --json " + test::quoted(dir / "cal.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto info = nlohmann::json::parse(r.out);
  const auto& observed = info["observed"];
  EXPECT_LT(observed["theta_max_deg"].get<double>(), 55.1);
  EXPECT_EQ(observed["theta_max_by_azimuth_deg"].size(), size_t(CalibrationRecord::kAzimuthSectors));
  EXPECT_TRUE(observed["has_covariance"].get<bool>());
  ASSERT_GE(observed["extrapolated"].size(), 2u);  // the 190-degree image spans far more than 110 degrees of data
  EXPECT_NE(observed["extrapolated"][0].get<std::string>().find("horizontal field of view"), std::string::npos);
  r = test::run_fishcam("info " + test::quoted(dir / "cal.json"));
  EXPECT_NE(r.out.find("extrapolated:"), std::string::npos) << r.out;
  r = test::run_fishcam("info --json " + test::quoted(test::data_path("kannala_brandt.yaml")));
  EXPECT_TRUE(nlohmann::json::parse(r.out)["observed"].is_null());

  r = test::run_fishcam("uncertainty --json --distance 2 --out " + test::quoted(dir / "u.png") + " " +
                        test::quoted(dir / "cal.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto u = nlohmann::json::parse(r.out);
  EXPECT_GT(u["observed"]["pixels"].get<long>(), 1000);
  EXPECT_LT(u["observed"]["p95_px"].get<double>(), u["valid_image"]["max_px"].get<double>());
  EXPECT_GT(u["at_principal_point_px"].get<double>(), 0);
  EXPECT_TRUE(std::filesystem::exists(dir / "u.png"));
  r = test::run_fishcam("uncertainty --out " + test::quoted(dir / "v.png") + " " +
                        test::quoted(test::data_path("kannala_brandt.yaml")));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("carries no calibration covariance"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "v.png"));
}

// diff as mrcal's projection_diff: two models of the same corners agree where the
// boards were and part in extrapolation; by default diff compares where the data
// are (and says so), weighting the rotation fit by the uncertainties.
TEST(Calibration, DiffComparesWhereTheBoardsWere) {
  const auto dir = test::scratch_dir("calibrate_diff");
  const Camera truth = read_camera(test::data_path("kannala_brandt.yaml"));
  const std::vector<BoardObservation> inner = boards_within(truth, 60, 80, 10);
  ASSERT_GE(inner.size(), 8u);
  write_corners(dir / "c.vnl", inner, kBoard);
  for (const char* model : {"kannala-brandt", "polynomial"}) {
    const auto r = test::run_fishcam("calibrate --corners " + test::quoted(dir / "c.vnl") +
                                     " --board 10x10 --spacing 0.1 --imagersize 1280x966 --model " + model + " --out " +
                                     test::quoted(dir / (std::string(model) + ".json")));
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  const std::string pair = test::quoted(dir / "kannala-brandt.json") + " " + test::quoted(dir / "polynomial.json");
  auto r = test::run_fishcam("diff --json " + pair);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto data = nlohmann::json::parse(r.out);
  EXPECT_NE(data["region"].get<std::string>().find("observed"), std::string::npos);
  EXPECT_EQ(data["weights"], "1 / (sigma_A^2 + sigma_B^2)");
  r = test::run_fishcam("diff --json --region all --weights none " + pair);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto all = nlohmann::json::parse(r.out);
  EXPECT_GT(all["pixels"].get<long>(), data["pixels"].get<long>());
  EXPECT_GT(all["rms_px"].get<double>(), 5 * data["rms_px"].get<double>());  // extrapolation dominates
  r = test::run_fishcam("diff --json --weights none --corners " + test::quoted(dir / "c.vnl") + " --board 10x10 " +
                        pair);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto hull = nlohmann::json::parse(r.out);
  EXPECT_NE(hull["region"].get<std::string>().find("convex hull"), std::string::npos);
  EXPECT_LT(hull["rms_px"].get<double>(), all["rms_px"].get<double>());
  // Refused in one line: weights without covariances, a data region nobody knows.
  const std::string plain = test::quoted(test::data_path("kannala_brandt.yaml"));
  for (const std::string& bad : {"--weights uncertainty " + plain + " " + plain, "--region data " + plain + " " + plain,
                                 "--corners " + test::quoted(dir / "c.vnl") + " " + pair}) {
    r = test::run_fishcam("diff " + bad);
    EXPECT_NE(r.exit_code, 0) << bad;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

// convert --theta-limit data: the converted camera keeps the observed angles (the
// same camera frame), drops the covariance, and stops at the data; a camera
// without a record is refused in one line, nothing written.
TEST(Calibration, ConvertCapsAtTheObservedAngles) {
  const auto dir = test::scratch_dir("convert_theta_limit");
  const Camera truth = read_camera(test::data_path("kannala_brandt.yaml"));
  write_corners(dir / "c.vnl", testing::synthesize_boards(truth, kBoard, 12, 0.3, 11).observations, kBoard);
  auto r = test::run_fishcam("calibrate --corners " + test::quoted(dir / "c.vnl") +
                             " --board 10x10 --spacing 0.1 --imagersize 1280x966 --model kannala-brandt --out " +
                             test::quoted(dir / "cal.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_fishcam("convert " + test::quoted(dir / "cal.json") + " --to polynomial --theta-limit data+2 --out " +
                        test::quoted(dir / "poly.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Camera calibrated = read_camera(dir / "cal.json"), converted = read_camera(dir / "poly.json");
  const auto& record = converted.parameters().calibration;
  ASSERT_TRUE(record);
  EXPECT_EQ(record->covariance.size(), 0);  // it belonged to the Kannala-Brandt parameters
  EXPECT_NEAR(record->theta_max, calibrated.parameters().calibration->theta_max, 1e-12);
  EXPECT_NEAR(converted.domain().theta_max, record->theta_max + 2 / kDeg, 1e-9);
  EXPECT_EQ(converted.domain().limited_by, ValidDomain::Limit::user);
  r = test::run_fishcam("convert " + test::quoted(test::data_path("kannala_brandt.yaml")) +
                        " --to polynomial --theta-limit data --out " + test::quoted(dir / "none.json"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("carries no calibration record"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "none.json"));
}

}  // namespace
}  // namespace fishcam
