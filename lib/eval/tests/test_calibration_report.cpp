// The calibration report (fishcam/eval/calibration_report.hpp): its residuals are the
// solve's, its figures decode and are all on the page, a rig's per-instant poses
// agree with the joint solve on consistent data and show a moved camera.
#include <opencv2/imgcodecs.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <regex>
#include <set>

#include "fishcam/eval/calibration_report.hpp"
#include "fishcam/io/camera_io.hpp"
#include "fishcam/testing/test_support.hpp"
#include "fishcam/testing/testing.hpp"

namespace fishcam {
namespace {

const BoardSpec kBoard{8, 6, 0.05};

Camera lens() { return Camera(resized(read_camera(test::data_path("kannala_brandt.yaml")).parameters(), 640, 483)); }

cv::Mat decoded(const ReportFile& file) {
  return cv::imdecode(std::vector<uchar>(file.bytes.begin(), file.bytes.end()), cv::IMREAD_UNCHANGED);
}

const ReportFile& page_of(const std::vector<ReportFile>& files) {
  EXPECT_EQ(files.at(0).name, "index.html");
  return files.at(0);
}

// Every figure decodes, the page shows each exactly once and counts them.
void expect_complete(const std::vector<ReportFile>& files) {
  const std::string& html = page_of(files).bytes;
  std::set<std::string> shown;
  const std::regex image("<img src=\"([^\"]+)\"");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), image); it != std::sregex_iterator(); ++it) {
    EXPECT_TRUE(shown.insert((*it)[1]).second) << (*it)[1];
  }
  int figures = 0;
  for (size_t i = 1; i < files.size(); ++i) {
    EXPECT_TRUE(files[i].name.ends_with(".png")) << files[i].name;
    EXPECT_EQ(shown.count(files[i].name), 1u) << files[i].name;
    const cv::Mat image = decoded(files[i]);
    EXPECT_EQ(image.type(), CV_8UC3) << files[i].name;
    EXPECT_GT(image.cols, 100) << files[i].name;
    ++figures;
  }
  EXPECT_EQ(shown.size(), size_t(figures));
  EXPECT_NE(html.find("data-figures=\"" + std::to_string(figures) + "\""), std::string::npos);
}

TEST(CalibrationReport, ResidualsAreTheSolvesAndEveryFigureIsOnThePage) {
  const Camera camera = lens();
  auto boards = testing::synthesize_boards(camera, kBoard, 12, 0.3, 5);
  boards.observations[4].corners[7] += Eigen::Vector2d(6, -4);  // an outlier
  const CalibrationResult result =
      calibrate(boards.observations, kBoard, camera.width(), camera.height(), ModelSpec{"kannala-brandt"});
  ASSERT_EQ(result.outliers.size(), 1u);
  const std::vector<CornerFit> fits = corner_fits(result, boards.observations, kBoard);
  ASSERT_EQ(fits.size(), result.used_images.size() * size_t(kBoard.corners()));
  double sum2 = 0;
  long used = 0, outliers = 0;
  for (const CornerFit& f : fits) {
    if (f.outlier) {
      ++outliers;
      // (error_px is the robust stage's; the final solve without it moves it a little)
      EXPECT_NEAR(f.residual.norm(), result.outliers[0].error_px, 0.1);
      continue;
    }
    sum2 += f.residual.squaredNorm(), ++used;
  }
  EXPECT_EQ(outliers, 1);
  EXPECT_EQ(used, result.observations);
  EXPECT_NEAR(std::sqrt(sum2 / double(used)), result.rms_px, 1e-9 * result.rms_px);

  const auto files = calibration_report(result, result.camera, boards.observations, kBoard, "boards <&> \"synthetic\"");
  expect_complete(files);
  std::set<std::string> names;
  for (const auto& f : files) names.insert(f.name);
  for (const char* name : {"residuals.png", "per-image-rms.png", "histogram.png", "coverage.png", "domain.png",
                           "uncertainty.png", "image-000.png", "image-011.png"}) {
    EXPECT_EQ(names.count(name), 1u) << name;
  }
  EXPECT_EQ(files.size(), 1 + 6 + result.used_images.size());
  const std::string& html = page_of(files).bytes;
  EXPECT_NE(html.find("boards &lt;&amp;&gt; &quot;synthetic&quot;"), std::string::npos);  // the title escaped
  EXPECT_EQ(html.find("<&>"), std::string::npos);
  EXPECT_NE(html.find(result.outliers[0].filename), std::string::npos);  // the outliers' table
}

TEST(CalibrationReport, ACameraWithoutCovarianceHasNoUncertaintyMapAndSaysSo) {
  const Camera camera = lens();
  const auto boards = testing::synthesize_boards(camera, kBoard, 6, 0.2, 7);
  const CalibrationResult located = locate_boards(boards.observations, kBoard, camera);  // the file's camera
  const auto files = calibration_report(located, camera.parameters(), boards.observations, kBoard, "located");
  expect_complete(files);
  for (const auto& f : files) EXPECT_NE(f.name, "uncertainty.png");
  EXPECT_NE(page_of(files).bytes.find("carries no covariance"), std::string::npos);
  // Corners from another calibration's images are refused, naming the image.
  auto other = boards.observations;
  other[2].filename = "elsewhere.png";
  try {
    corner_fits(located, other, kBoard);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(boards.observations[2].filename), std::string::npos) << e.what();
  }
}

// A stereo pair (camera 1 = camera 0 turned 8 degrees and moved 0.12 along x) seeing
// boards at shared instants, each board's corners at least 10 px inside both images;
// at the `moved`-th instant kept camera 1 sits 5 mm further along x.
std::vector<RigCamera> stereo(const Camera& camera, size_t moved) {
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(8 * std::numbers::pi / 180, Eigen::Vector3d::UnitY()));
  const Eigen::Vector3d shift(-0.12, 0, 0);  // camera 0 -> 1
  std::vector<RigCamera> rig(2, RigCamera{{}, camera.width(), camera.height(), {"kannala-brandt"}});
  const auto points = board_points(kBoard);
  const auto boards = testing::synthesize_boards(camera, kBoard, 30, 0, 11);
  const auto inside = [&](const Eigen::Vector2d& q) {
    return q.x() >= 10 && q.y() >= 10 && q.x() <= camera.width() - 11 && q.y() <= camera.height() - 11;
  };
  int instant = 0;
  for (const BoardPose& in0 : boards.poses) {
    const std::string name = "instant-" + std::to_string(instant++) + ".png";
    const bool is_moved = rig[0].observations.size() == moved;
    const Eigen::Vector3d extra = is_moved ? Eigen::Vector3d(0.005, 0, 0) : Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector2d> first, second;
    for (const auto& p : points) {
      const Eigen::Vector3d x0 = in0.rotation * p + in0.translation;
      Eigen::Vector2d q0, q1, unmoved;
      if (!camera.project(x0, &q0) || !camera.project(turn * x0 + shift, &unmoved) ||
          !camera.project(turn * x0 + shift + extra, &q1) || !inside(q0) || !inside(unmoved) || !inside(q1)) {
        break;
      }
      first.push_back(q0), second.push_back(q1);
    }
    if (first.size() != points.size() || second.size() != points.size()) continue;
    rig[0].observations.push_back({"left/" + name, first});
    rig[1].observations.push_back({"right/" + name, second});
  }
  return rig;
}

// The instants' table row of `instant`: its rotation and translation differences.
std::pair<double, double> instant_row(const std::string& html, const std::string& instant) {
  const std::regex row("<td>" + instant + "</td><td class=\"n\">([^<]+)</td><td class=\"n\">([^<]+)</td>");
  std::smatch m;
  if (!std::regex_search(html, m, row)) return {std::nan(""), std::nan("")};
  return {std::stod(m[1]), std::stod(m[2])};
}

TEST(CalibrationReport, ARigsInstantsAgreeWithTheJointSolveUnlessTheCameraMoved) {
  const Camera camera = lens();
  auto rig = stereo(camera, 3);
  ASSERT_GE(rig[0].observations.size(), 8u);
  const std::string moved_instant = std::filesystem::path(rig[0].observations[3].filename).filename().string();
  // One of camera 1's boards numbered from the other end: the joint solve renumbers it,
  // and the report must pair its corners as the solve did.
  BoardObservation& turned = rig[1].observations[5];
  std::reverse(turned.corners.begin(), turned.corners.end());
  const RigCalibrationResult solved = calibrate_rig(rig, kBoard);
  ASSERT_EQ(solved.cameras[1].renumbered_images, std::vector<std::string>{turned.filename});
  for (size_t k = 0; k < 2; ++k) {
    double sum2 = 0;
    long used = 0;
    for (const CornerFit& f : corner_fits(solved.cameras[k], rig[k].observations, kBoard)) {
      if (!f.outlier) sum2 += f.residual.squaredNorm(), ++used;
    }
    EXPECT_NEAR(std::sqrt(sum2 / double(used)), solved.cameras[k].rms_px, 1e-9) << "camera " << k;
  }
  std::vector<CameraParameters> written;
  std::vector<std::vector<BoardObservation>> observations;
  for (size_t k = 0; k < 2; ++k) {
    written.push_back(solved.cameras[k].camera), observations.push_back(rig[k].observations);
  }
  const auto files = rig_calibration_report(solved, written, observations, kBoard, {"left.vnl", "right.vnl"});
  expect_complete(files);
  const std::string& html = page_of(files).bytes;
  for (const char* name : {"instants.png", "camera0-residuals.png", "camera1-uncertainty.png"}) {
    EXPECT_NE(html.find(name), std::string::npos) << name;
  }
  int rows = 0, moved = 0;
  for (const auto& o : rig[0].observations) {
    const std::string instant = std::filesystem::path(o.filename).filename().string();
    const auto [degrees, translation] = instant_row(html, instant);
    ASSERT_FALSE(std::isnan(degrees)) << instant;
    if (instant == moved_instant) {
      EXPECT_GT(translation, 0.003) << instant;  // the moved camera stands out
      ++moved;
    } else {
      EXPECT_LT(degrees, 0.05) << instant;
      EXPECT_LT(translation, 0.0015) << instant;
    }
    ++rows;
  }
  EXPECT_EQ(rows, int(rig[0].observations.size()));
  EXPECT_EQ(moved, 1);
  EXPECT_THROW(rig_calibration_report(solved, {written[0]}, observations, kBoard, {"a", "b"}), Error);
}

}  // namespace
}  // namespace fishcam
