// Boards seen in part: ChArUco and AprilGrid targets (detected with their corner ids, rendered
// through a fisheye) and partial observations in calibration, which let the corners
// reach the rim of a lens that sees more than 180 degrees.
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "fishcam/augment/aprilgrid.hpp"
#include "fishcam/augment/charuco.hpp"
#include "fishcam/fit/calibration.hpp"
#include "fishcam/testing/test_support.hpp"
#include "fishcam/testing/testing.hpp"

namespace fishcam {
namespace {

constexpr double kDeg = 180 / std::numbers::pi;
const CharucoSpec kTarget{6, 5, 0.1, 0.07, "4X4_50"};

// The shared test lens (Kannala-Brandt, 190 degrees) at 640 x 483.
Camera small_fisheye() {
  return Camera(resized(read_camera(test::data_path("kannala_brandt.yaml")).parameters(), 640, 483));
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Charuco, TargetsParseAndBadOnesAreRefused) {
  const CharucoSpec spec = parse_charuco("charuco:8x6:0.04:0.03:5X5_100");
  EXPECT_EQ(spec.cols, 8);
  EXPECT_EQ(spec.rows, 6);
  EXPECT_EQ(spec.square, 0.04);
  EXPECT_EQ(spec.marker, 0.03);
  EXPECT_EQ(spec.dictionary, "5X5_100");
  EXPECT_EQ(spec.board().cols, 7);
  EXPECT_EQ(spec.board().rows, 5);
  EXPECT_EQ(parse_charuco("charuco:5x5:1:0.5").dictionary, "4X4_50");
  EXPECT_EQ(charuco_dictionaries().size(), 21u);
  const struct {
    const char* text;
    const char* expected;
  } bad[] = {
      {"charuco:8x6:0.04", "expected charuco:COLSxROWS"},
      {"aprilgrid:8x6:0.04:0.03", "expected charuco:COLSxROWS"},
      {"charuco:8by6:0.04:0.03", "expected charuco:COLSxROWS"},
      {"charuco:8x6:0.04:0.05", "markers' side must lie between 0 and the squares'"},
      {"charuco:2x6:0.04:0.03", "3 to 1000 squares per side"},
      {"charuco:8x6:0.04:0.03:9X9_50", "unknown dictionary '9X9_50'"},
      {"charuco:20x20:0.04:0.03:4X4_50", "needs 200 markers; the dictionary 4X4_50 has 50"},
      {"charuco:8x6:nan:0.03", "the squares' side must be a finite number > 0"},
  };
  for (const auto& c : bad) {
    const std::string said = message_of([&] { parse_charuco(c.text); });
    EXPECT_NE(said.find(c.expected), std::string::npos) << c.text << ": " << said;
  }
}

// Rendered through the fisheye (boards partly outside the image among them), the
// detector finds corners where the camera projects them, each under its own id.
TEST(Charuco, DetectsPartialBoardsWithTheirIds) {
  // At full size: the markers' bits need ~3 px each.
  const Camera camera = read_camera(test::data_path("kannala_brandt.yaml"));
  const CharucoSpec target{8, 6, 0.1, 0.06, "4X4_50"};
  const BoardSpec board = target.board();
  const auto synthetic = testing::synthesize_boards(camera, board, 6, 0.0, 5, /*partial=*/true);
  const CharucoTexture texture(target);
  const auto points = board_points(board);
  int found = 0, partial = 0;
  double worst = 0;
  for (size_t b = 0; b < synthetic.poses.size(); ++b) {
    auto pixels = testing::render_target_image(camera, texture, synthetic.poses[b], 3, 0.8, 2.0, b);
    const cv::Mat image(camera.height(), camera.width(), CV_8UC1, pixels.data());
    const auto view = detect_charuco(image, target);
    if (!view) continue;
    ++found;
    partial += view->ids.empty() ? 0 : 1;
    EXPECT_GE(view->corners.size(), 6u);
    for (size_t k = 0; k < view->corners.size(); ++k) {
      Eigen::Vector2d truth;
      const BoardPose& pose = synthetic.poses[b];
      ASSERT_TRUE(camera.project(pose.rotation * points[size_t(view->id(k))] + pose.translation, &truth));
      worst = std::max(worst, (view->corners[k] - truth).norm());
    }
  }
  EXPECT_GE(found, 5);
  EXPECT_GE(partial, 2);
  EXPECT_LT(worst, 0.35);  // OpenCV 4.6's own result is off by +0.5 px in x and y
  EXPECT_FALSE(detect_charuco(cv::Mat(200, 300, CV_8UC1, cv::Scalar(128)), kTarget));
  EXPECT_THROW(detect_charuco(cv::Mat(200, 300, CV_8UC3), kTarget), Error);
  EXPECT_THROW(CharucoTexture(kTarget, 4), Error);
}

TEST(AprilGrid, TargetsParseAndBadOnesAreRefused) {
  const AprilGridSpec spec = parse_aprilgrid("aprilgrid:6x5:0.088:0.3");
  EXPECT_EQ(spec.cols, 6);
  EXPECT_EQ(spec.rows, 5);
  EXPECT_EQ(spec.size, 0.088);
  EXPECT_EQ(spec.spacing, 0.3);
  const BoardSpec board = spec.board();
  EXPECT_EQ(board.cols, 12);
  EXPECT_EQ(board.rows, 10);
  // A tag's two edges `size` apart, the next tag's edge the gap further.
  EXPECT_NEAR(board.coordinate(1) - board.coordinate(0), 0.088, 1e-15);
  EXPECT_NEAR(board.coordinate(2) - board.coordinate(1), 0.3 * 0.088, 1e-15);
  EXPECT_NEAR(board.width(), 5 * 1.3 * 0.088 + 0.088, 1e-15);
  const struct {
    const char* text;
    const char* expected;
  } bad[] = {
      {"aprilgrid:6x6:0.088", "expected aprilgrid:COLSxROWS:SIZE:SPACING"},
      {"charuco:6x6:0.088:0.3", "expected aprilgrid:COLSxROWS:SIZE:SPACING"},
      {"aprilgrid:6by6:0.088:0.3", "expected aprilgrid:COLSxROWS:SIZE:SPACING"},
      {"aprilgrid:0x6:0.088:0.3", "1 to 100 tags per side"},
      {"aprilgrid:30x30:0.088:0.3", "900 tags; the 36h11 family has 587"},
      {"aprilgrid:1x1:0.088:0.3", "2 tags or more"},
      {"aprilgrid:6x6:0.088:0", "spacing (the gap between tags over their side) must lie within (0, 1]"},
      {"aprilgrid:6x6:0.088:1.5", "must lie within (0, 1]"},
      {"aprilgrid:6x6:inf:0.3", "the tags' side must be a finite number > 0"},
  };
  for (const auto& c : bad) {
    const std::string said = message_of([&] { parse_aprilgrid(c.text); });
    EXPECT_NE(said.find(c.expected), std::string::npos) << c.text << ": " << said;
  }
  EXPECT_NE(message_of([] {
              check_board({3, 4, 0.1, 0.03});
            }).find("even number of corners per side"),
            std::string::npos);
}

// Rendered as Kalibr prints it through the fisheye (boards partly outside the image
// among them), the detector finds corners where the camera projects them, each under
// its own id.
TEST(AprilGrid, DetectsPartialBoardsWithTheirIds) {
  const Camera camera = read_camera(test::data_path("kannala_brandt.yaml"));
  const AprilGridSpec target{6, 5, 0.1, 0.3};
  const BoardSpec board = target.board();
  const auto synthetic = testing::synthesize_boards(camera, board, 6, 0.0, 5, /*partial=*/true);
  const AprilGridTexture texture(target);
  const auto points = board_points(board);
  int found = 0, partial = 0;
  size_t visible = 0;
  std::vector<double> errors;
  for (size_t b = 0; b < synthetic.poses.size(); ++b) {
    auto pixels = testing::render_target_image(camera, texture, synthetic.poses[b], 3, 0.8, 2.0, b);
    const cv::Mat image(camera.height(), camera.width(), CV_8UC1, pixels.data());
    visible += synthetic.observations[b].corners.size();
    const auto view = detect_aprilgrid(image, target);
    if (!view) continue;
    ++found;
    partial += view->ids.empty() ? 0 : 1;
    for (size_t k = 0; k < view->corners.size(); ++k) {
      Eigen::Vector2d truth;
      const BoardPose& pose = synthetic.poses[b];
      ASSERT_TRUE(camera.project(pose.rotation * points[size_t(view->id(k))] + pose.translation, &truth));
      errors.push_back((view->corners[k] - truth).norm());
    }
  }
  // The release build finds all 6 boards and 93 % of the corners in view; the
  // sanitizer build (clang) draws other boards and found 5 and 60 % (349 of 585). Tags
  // cut by the image's edge are not found.
  EXPECT_GE(found, 5);
  EXPECT_GE(partial, 2);
  EXPECT_GE(errors.size(), visible * 50 / 100) << errors.size() << " of " << visible;
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.06);
  EXPECT_LT(errors.back(), 0.35);
  EXPECT_FALSE(detect_aprilgrid(cv::Mat(200, 300, CV_8UC1, cv::Scalar(128)), target));
  EXPECT_THROW(detect_aprilgrid(cv::Mat(200, 300, CV_8UC3), target), Error);
  // The chessboard renderer refuses a grid of tags rather than drawing squares.
  EXPECT_THROW(testing::render_board_image(camera, board, synthetic.poses[0], 1, 0, 0, 0), Error);
}

// Partial boards let the corners reach the rim: the calibration recovers the lens
// from boards cut by the image's edges and observes angles past 90 degrees.
TEST(PartialBoards, CalibrationReachesTheRim) {
  const Camera truth = small_fisheye();
  const BoardSpec board = kTarget.board();
  const auto partial = testing::synthesize_boards(truth, board, 40, 0.1, 6, /*partial=*/true);
  const long cut = std::count_if(partial.observations.begin(), partial.observations.end(),
                                 [](const BoardObservation& o) { return !o.ids.empty(); });
  EXPECT_GE(cut, 10);
  const CalibrationResult r = calibrate(partial.observations, board, truth.width(), truth.height(), {"kannala-brandt"});
  // The truth in the solve's terms (resized: f scaled by the grid's x scale, a_y the
  // ratio of its scales).
  const CameraParameters& p = truth.parameters();
  std::vector<double> expected = model_params(p.model);
  expected[0] *= p.grid.pixel_scale.x();
  expected.insert(expected.end(), {p.grid.principal_point.x(), p.grid.principal_point.y(),
                                   p.grid.pixel_scale.y() / p.grid.pixel_scale.x()});
  ASSERT_EQ(r.parameters.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_NEAR(r.parameters[i], expected[i], 4 * r.sigmas[i]) << r.parameter_names[i];
  }
  EXPECT_LT(r.rms_px, 0.2);
  const double reached = r.camera.calibration->theta_max * kDeg;
  EXPECT_GT(reached, 95);  // past the image's half horizontal field of view
  // Boards located through a known camera take partial views too.
  const CalibrationResult located = locate_boards(partial.observations, board, truth);
  EXPECT_EQ(located.poses.size(), partial.observations.size());
  EXPECT_LT(located.rms_px, 0.2);
}

TEST(PartialBoards, ViewsThatCannotPlaceABoardAreRefusedNamingThem) {
  const Camera truth = small_fisheye();
  const BoardSpec board = kTarget.board();  // 5 x 4
  auto views = testing::synthesize_boards(truth, board, 6, 0.1, 7).observations;
  const auto with = [&](std::vector<int> ids) {
    auto changed = views;
    BoardObservation& o = changed[2];
    std::vector<Eigen::Vector2d> corners;
    for (int id : ids) corners.push_back(o.corners[size_t(std::clamp(id, 0, 19))]);
    o.corners = corners, o.ids = ids;
    return message_of([&] { calibrate(changed, board, truth.width(), truth.height(), {"kannala-brandt"}); });
  };
  EXPECT_NE(with({0, 1, 5}).find("image synth-002.png: its 3 corners (of a partial board) span 2 column(s)"),
            std::string::npos)
      << with({0, 1, 5});
  EXPECT_NE(with({0, 1, 2, 3, 4}).find("span 5 column(s) and 1 row(s)"), std::string::npos);
  EXPECT_NE(with({0, 8, 7, 9}).find("corner id 7 at position 2 is not within 0..19 in increasing order"),
            std::string::npos)
      << with({0, 8, 7, 9});
  EXPECT_NE(with({0, 1, 7, 20}).find("corner id 20"), std::string::npos);
  // Ids and corners of different lengths.
  auto mismatched = views;
  mismatched[1].ids = {0, 1, 2};
  EXPECT_NE(message_of([&] {
              calibrate(mismatched, board, truth.width(), truth.height(), {"kannala-brandt"});
            }).find("calibrate: image synth-001.png: 3 corner ids for 20 corners"),
            std::string::npos);
  // A whole board given with fewer corners and no ids.
  auto short_view = views;
  short_view[0].corners.pop_back();
  EXPECT_NE(message_of([&] {
              calibrate(short_view, board, truth.width(), truth.height(), {"kannala-brandt"});
            }).find("19 corners without ids; a whole 5x4 board has 20"),
            std::string::npos);
}

// The same partial view under two names is the same photo twice; the same corners
// under other ids are not.
TEST(PartialBoards, DuplicatesAreToldByTheirIds) {
  const Camera truth = small_fisheye();
  const BoardSpec board = kTarget.board();
  auto views = testing::synthesize_boards(truth, board, 12, 0.1, 8, /*partial=*/true).observations;
  auto twice = views;
  twice.push_back(views[3]);
  twice.back().filename = "copy.png";
  EXPECT_NE(message_of([&] {
              calibrate(twice, board, truth.width(), truth.height(), {"kannala-brandt"});
            }).find("have the same corners"),
            std::string::npos);
}

}  // namespace
}  // namespace fishcam
