// The street-scene renderer as ground truth: a rotation-only augmentation of a
// render equals the render from the rotated camera; with translations it measures
// how wrong each depth prior is.
#include <opencv2/imgproc.hpp>

#include <cstring>

#include "fishcam/augment/augmentation.hpp"
#include "fishcam/augment/scene.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

Camera front() { return read_camera(test::data_path("woodscape_front.json")); }

// Pixels whose 5x5 neighbourhood in `reference` holds one label only and that have a source.
cv::Mat away_from_boundaries(const cv::Mat& reference, const cv::Mat& valid) {
  cv::Mat low, high;
  const cv::Mat kernel = cv::Mat::ones(5, 5, CV_8U);
  cv::erode(reference, low, kernel);
  cv::dilate(reference, high, kernel);
  cv::Mat valid_inner;
  cv::erode(valid, valid_inner, kernel);
  return (low == high) & (valid_inner != 0);
}

double agreement(const cv::Mat& a, const cv::Mat& b, const cv::Mat& where) {
  const int total = cv::countNonZero(where);
  return double(cv::countNonZero((a == b) & where)) / std::max(total, 1);
}

TEST(Scene, RenderIsDeterministicAndHasEveryWoodScapeClass) {
  const Camera camera = front();
  const SceneRender a = render_street_scene(camera, *camera.parameters().pose);
  const SceneRender b = render_street_scene(camera, *camera.parameters().pose);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.labels, b.labels, cv::NORM_INF), 0);
  for (int label = 0; label < woodscape_class::kCount; ++label) {
    EXPECT_GT(cv::countNonZero(a.labels == label), 100) << woodscape_class_name(label);
  }
  double max_label;
  cv::minMaxLoc(a.labels, nullptr, &max_label);
  EXPECT_LT(max_label, woodscape_class::kCount);
  EXPECT_EQ(woodscape_class_name(woodscape_class::traffic_sign), "traffic sign");
}

TEST(Scene, MovedCameraSeesTheTransformedPoints) {
  const Pose mount = *front().parameters().pose;
  const RigidMotion change = RigidMotion::from_euler_deg({5, -10, 20}, {0.2, -0.1, 0.3});
  const Pose moved = moved_camera(mount, change);
  const Eigen::Vector3d p_cam(0.4, -0.3, 2.0);
  const Eigen::Vector3d p_vehicle = mount.rotation * p_cam + mount.translation;
  const Eigen::Vector3d p_moved = moved.rotation.conjugate() * (p_vehicle - moved.translation);
  EXPECT_LT((p_moved - (change.rotation * p_cam + change.translation)).norm(), 1e-14);
}

TEST(Scene, RotationOnlyAugmentationEqualsTheRotatedCameraRender) {
  const Camera camera = front();
  const Pose mount = *camera.parameters().pose;
  const SceneRender source = render_street_scene(camera, mount);
  const ViewpointWarp warp(camera);
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    ViewpointChange pose = random_change(*find_pose_preset("large"), seed);
    pose.translation.setZero();
    const RigidMotion change = pose.motion();
    const SceneRender truth = render_street_scene(camera, moved_camera(mount, change));
    for (DepthPrior prior : {DepthPrior::source_sphere, DepthPrior::infinity}) {
      WarpMaps maps;
      warp.compute(change, prior, &maps);
      cv::Mat labels, image;
      warp_labels(source.labels, maps, 255, &labels);
      warp_image(source.image, maps, &image);
      const cv::Mat where = away_from_boundaries(truth.labels, maps.validity());
      ASSERT_GT(cv::countNonZero(where), 300000);
      const double same = agreement(labels, truth.labels, where);
      EXPECT_GE(same, 0.995) << "seed " << seed << " " << to_string(prior);
      // The pictures too: bilinear resampling of a textured render, so not exact,
      // but close on average.
      cv::Mat difference;
      cv::absdiff(image, truth.image, difference);
      EXPECT_LT(cv::mean(difference, where)[0], 6.0) << "seed " << seed;
      std::printf("  rotation (%.1f, %.1f, %.1f) deg: labels %.4f%% identical away from boundaries (%s)\n",
                  pose.rotation_deg.x(), pose.rotation_deg.y(), pose.rotation_deg.z(), 100 * same,
                  std::string(to_string(prior)).c_str());
    }
  }
}

// With translation no prior is exact (the scene is not a sphere): how far off is each?
// Printed for docs/augmentation.md; asserted only loosely (the priors must still help).
TEST(Scene, TranslationShowsWhatEachDepthPriorCosts) {
  const Camera camera = front();
  const Pose mount = *camera.parameters().pose;
  const SceneRender source = render_street_scene(camera, mount);
  const ViewpointWarp warp(camera);
  std::printf("  preset  prior          label agreement away from boundaries (mean of 6 poses)\n");
  for (const char* preset : {"small", "medium", "large"}) {
    for (DepthPrior prior : {DepthPrior::source_sphere, DepthPrior::target_sphere, DepthPrior::infinity}) {
      double sum = 0;
      for (std::uint64_t seed = 1; seed <= 6; ++seed) {
        const RigidMotion change = random_change(*find_pose_preset(preset), seed).motion();
        const SceneRender truth = render_street_scene(camera, moved_camera(mount, change));
        WarpMaps maps;
        warp.compute(change, prior, &maps);
        cv::Mat labels;
        warp_labels(source.labels, maps, 255, &labels);
        sum += agreement(labels, truth.labels, away_from_boundaries(truth.labels, maps.validity()));
      }
      const double mean = sum / 6;
      std::printf("  %-7s %-14s %.2f%%\n", preset, std::string(to_string(prior)).c_str(), 100 * mean);
      EXPECT_GT(mean, 0.5);
    }
  }
}

// --- Seeded streets (StreetScene::generate) ---

Camera small_front() { return Camera(resized(front().parameters(), 320, 242)); }

// Four cameras around the vehicle (front, left, rear, right), each looking out
// and down like a surround-view rig's.
std::vector<Pose> surround_mounts() {
  const Pose front_mount = *front().parameters().pose;
  std::vector<Pose> out;
  for (const double yaw_deg : {0.0, 90.0, 180.0, 270.0}) {
    const Eigen::Quaterniond yaw(Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ()));
    out.push_back({yaw * front_mount.rotation, Eigen::Vector3d(1.5, 0, 0.8) + yaw * Eigen::Vector3d(1.0, 0, 0)});
  }
  return out;
}

TEST(SeededScene, TheSameSeedGivesTheSameBytesAndSeedsDiffer) {
  const Camera camera = small_front();
  const Pose mount = *camera.parameters().pose;
  const SceneRender a = StreetScene::generate(11).render(camera, mount, 2);
  const SceneRender b = StreetScene::generate(11).render(camera, mount, 2);
  const SceneRender c = StreetScene::generate(12).render(camera, mount, 2);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.labels, b.labels, cv::NORM_INF), 0);
  EXPECT_EQ(std::memcmp(a.range.data, b.range.data, a.range.total() * sizeof(float)), 0);
  EXPECT_GT(cv::countNonZero(a.labels != c.labels), int(a.labels.total() / 20))
      << "seeds 11 and 12 draw the same street";
  // The bundled street is not a seeded one.
  const SceneRender bundled = StreetScene::bundled().render(camera, mount);
  EXPECT_GT(cv::countNonZero(a.labels != bundled.labels), int(a.labels.total() / 20));
}

TEST(SeededScene, EveryWoodScapeClassOccursAcrossSeedsAndViews) {
  const Camera camera = small_front();
  std::array<long, woodscape_class::kCount> pixels{};
  int renders = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const StreetScene scene = StreetScene::generate(seed);
    for (const Pose& mount : surround_mounts()) {
      const SceneRender r = scene.render(camera, mount);
      for (int label = 0; label < woodscape_class::kCount; ++label)
        pixels[size_t(label)] += cv::countNonZero(r.labels == label);
      ++renders;
    }
  }
  EXPECT_EQ(renders, 24);
  for (int label = 0; label < woodscape_class::kCount; ++label) {
    EXPECT_GT(pixels[size_t(label)], 100) << woodscape_class_name(label);
  }
}

// The range is the distance along each pixel's ray: road pixels' points lie on the road plane.
TEST(SeededScene, RangePutsRoadPixelsOnTheRoadAndSupersamplingLeavesLabelsAlone) {
  const Camera camera = small_front();
  const Pose mount = *camera.parameters().pose;
  const SceneRender one = StreetScene::generate(5).render(camera, mount, 1);
  const SceneRender two = StreetScene::generate(5).render(camera, mount, 2);
  EXPECT_EQ(cv::norm(one.labels, two.labels, cv::NORM_INF), 0);
  EXPECT_EQ(std::memcmp(one.range.data, two.range.data, one.range.total() * sizeof(float)), 0);
  cv::Mat difference;
  cv::absdiff(one.image, two.image, difference);
  EXPECT_LT(cv::mean(difference)[0], 8.0);
  int checked = 0;
  for (int v = 0; v < camera.height(); v += 3) {
    for (int u = 0; u < camera.width(); u += 3) {
      if (one.labels.at<uchar>(v, u) != woodscape_class::road) continue;
      Eigen::Vector3d ray;
      ASSERT_TRUE(camera.unproject(Eigen::Vector2d(u, v), &ray));
      const Eigen::Vector3d point = mount.rotation * (double(one.range.at<float>(v, u)) * ray) + mount.translation;
      EXPECT_NEAR(point.z(), 0.0, 2e-6 * double(one.range.at<float>(v, u)) + 1e-6) << u << "," << v;
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
}

// For every registry model: a rotation-only augmentation of a seeded street's render
// equals the render from the rotated camera away from label boundaries.
class EveryModelSeededScene : public ::testing::TestWithParam<test::ModelCase> {};

TEST_P(EveryModelSeededScene, RotationOnlyAugmentationEqualsTheRotatedRender) {
  const Camera camera(resized(GetParam().second, 640, 483));
  const Pose mount = *front().parameters().pose;  // the lens of every model, mounted as the front camera
  const StreetScene scene = StreetScene::generate(21);
  const SceneRender source = scene.render(camera, mount);
  const ViewpointWarp warp(camera);
  ViewpointChange pose = random_change(*find_pose_preset("medium"), 3);
  pose.translation.setZero();
  const RigidMotion change = pose.motion();
  const SceneRender truth = scene.render(camera, moved_camera(mount, change));
  WarpMaps maps;
  warp.compute(change, DepthPrior::infinity, &maps);
  cv::Mat labels;
  warp_labels(source.labels, maps, 255, &labels);
  const cv::Mat where = away_from_boundaries(truth.labels, maps.validity());
  ASSERT_GT(cv::countNonZero(where), 20000);
  EXPECT_GE(agreement(labels, truth.labels, where), 0.995);
}

INSTANTIATE_TEST_SUITE_P(SeededScene, EveryModelSeededScene, ::testing::ValuesIn(test::every_model()),
                         test::model_case_name);

// The depth-map source (ViewpointWarp::compute with a DepthMap) with the renderer's own
// range: a translated camera's view agrees with the re-render where it has a source,
// and better than any sphere prior.
TEST(SeededScene, DepthMapPriorAgreesWithTheTranslatedRender) {
  const Camera camera(resized(front().parameters(), 640, 483));
  const Pose mount = *front().parameters().pose;
  const ViewpointWarp warp(camera);
  int compared = 0;
  // Valid: the share of output pixels with a source. The depth map leaves out what the
  // source never saw (disocclusions, ground the moved camera sees past the source's
  // field of view); a sphere prior samples something there.
  std::printf("  preset  seed  depth map: valid  agreement | sphere priors: best agreement, infinity's valid\n");
  for (const char* preset : {"small", "medium", "large"}) {
    for (std::uint64_t seed = 1; seed <= 2; ++seed) {
      const StreetScene scene = StreetScene::generate(30 + seed);
      const SceneRender source = scene.render(camera, mount);
      const RigidMotion change = random_change(*find_pose_preset(preset), seed).motion();  // t in metres
      const SceneRender truth = scene.render(camera, moved_camera(mount, change));
      WarpMaps maps;
      warp.compute(change, DepthMap{source.range, DepthValues::range}, &maps);
      cv::Mat labels;
      warp_labels(source.labels, maps, 255, &labels);
      const cv::Mat where = away_from_boundaries(truth.labels, maps.validity());
      ASSERT_GT(cv::countNonZero(where), 100000) << preset << " " << seed;
      const double same = agreement(labels, truth.labels, where);
      EXPECT_GE(same, 0.98) << preset << " seed " << seed;
      double best_sphere = 0, infinity_valid = 0;
      for (DepthPrior prior : {DepthPrior::source_sphere, DepthPrior::target_sphere, DepthPrior::infinity}) {
        WarpMaps sphere;
        warp.compute(change, prior, &sphere);
        cv::Mat sphere_labels;
        warp_labels(source.labels, sphere, 255, &sphere_labels);
        if (prior == DepthPrior::infinity)
          infinity_valid = cv::countNonZero(sphere.validity()) / double(sphere.map_x.total());
        best_sphere = std::max(
            best_sphere, agreement(sphere_labels, truth.labels, away_from_boundaries(truth.labels, sphere.validity())));
      }
      EXPECT_GT(same, best_sphere) << preset << " seed " << seed;
      std::printf("  %-7s %4d  %15.1f%%  %8.2f%% | %.2f%%, %.1f%%\n", preset, int(seed),
                  100.0 * cv::countNonZero(maps.validity()) / double(maps.map_x.total()), 100 * same, 100 * best_sphere,
                  100 * infinity_valid);
      ++compared;
    }
  }
  EXPECT_EQ(compared, 6);
  // A pure rotation needs no depth: the maps are the priors', complete at depth edges
  // (the triangles would drop a band there), whatever the depth map holds.
  {
    const StreetScene scene = StreetScene::generate(31);
    const SceneRender source = scene.render(camera, mount);
    const RigidMotion rotation = RigidMotion::from_euler_deg({4, -9, 3}, {0, 0, 0});
    WarpMaps from_depth, prior;
    warp.compute(rotation, DepthMap{source.range, DepthValues::range}, &from_depth, MapKind::geometric);
    warp.compute(rotation, DepthPrior::source_sphere, &prior, MapKind::geometric);
    EXPECT_EQ(from_depth.invalid_count, prior.invalid_count);
    EXPECT_LE(cv::norm(from_depth.map_x, prior.map_x, cv::NORM_INF, prior.validity()), 1e-3);
    EXPECT_LE(cv::norm(from_depth.map_y, prior.map_y, cv::NORM_INF, prior.validity()), 1e-3);
  }
  // Bad input: a depth map of the wrong size or type.
  WarpMaps maps;
  EXPECT_THROW(warp.compute(RigidMotion{}, DepthMap{cv::Mat(10, 10, CV_32FC1)}, &maps), Error);
  EXPECT_THROW(warp.compute(RigidMotion{}, DepthMap{cv::Mat(483, 640, CV_64FC1)}, &maps), Error);
}

}  // namespace
}  // namespace fishcam
