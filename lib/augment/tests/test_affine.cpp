// The affine baseline (paper §V.C.2): its maps, presets and fill rules.
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <set>

#include "fishcam/augment/affine.hpp"
#include "fishcam/core/error.hpp"

namespace fishcam {
namespace {

cv::Mat pattern(cv::Size size, int type) {
  cv::Mat image(size, type);
  cv::randu(image, 0, 255);
  return image;
}

TEST(Affine, IdentityIsAnExactCopy) {
  for (const cv::Size size : {cv::Size(64, 48), cv::Size(33, 17)}) {
    WarpMaps maps;
    affine_maps(AffineChange{}, size, &maps);
    EXPECT_EQ(maps.invalid_count, 0);
    for (const int type : {CV_8UC3, CV_16UC1, CV_32FC1}) {
      const cv::Mat image = pattern(size, type);
      cv::Mat out;
      warp_image(image, maps, &out);
      EXPECT_EQ(cv::norm(image, out, cv::NORM_INF), 0) << type;
    }
    const cv::Mat labels = pattern(size, CV_8UC1);
    cv::Mat out;
    warp_labels(labels, maps, 255, &out);
    EXPECT_EQ(cv::norm(labels, out, cv::NORM_INF), 0);
  }
}

// The maps are the inverse of cv::getRotationMatrix2D's forward transform (same
// sense of rotation) followed by the translation.
TEST(Affine, MapsInvertOpenCVsRotationMatrix) {
  const cv::Size size(160, 120);
  const AffineChange change{23.0, {0.1, -0.2}, 1.3};
  WarpMaps maps;
  affine_maps(change, size, &maps);
  cv::Mat forward = cv::getRotationMatrix2D(cv::Point2f(79.5f, 59.5f), change.rotation_deg, change.scale);
  forward.at<double>(0, 2) += change.translation.x() * size.width;
  forward.at<double>(1, 2) += change.translation.y() * size.height;
  int checked = 0;
  for (int v = 0; v < size.height; v += 7) {
    for (int u = 0; u < size.width; u += 7) {
      const float x = maps.map_x.at<float>(v, u), y = maps.map_y.at<float>(v, u);
      if (x == kOutsideSource) continue;
      if (x <= 0 || y <= 0 || x >= size.width - 1 || y >= size.height - 1) continue;  // clamped at the rim
      const cv::Matx23d m(forward);
      const double fx = m(0, 0) * x + m(0, 1) * y + m(0, 2), fy = m(1, 0) * x + m(1, 1) * y + m(1, 2);
      EXPECT_NEAR(fx, u, 2e-4);
      EXPECT_NEAR(fy, v, 2e-4);
      ++checked;
    }
  }
  EXPECT_GT(checked, 150);
  // And the images agree with cv::warpAffine's where the sources are inside: on a
  // linear ramp (bilinear interpolation reproduces it) each rounds its coordinates
  // to 1/32 px, so they differ by at most 2 x (0.8 + 0.6) / 64.
  cv::Mat image(size, CV_32FC1);
  for (int v = 0; v < size.height; ++v) {
    for (int u = 0; u < size.width; ++u) image.at<float>(v, u) = 0.8f * u + 0.6f * v;
  }
  cv::Mat ours, theirs;
  warp_image(image, maps, &ours, 0);
  cv::warpAffine(image, theirs, forward, size, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  // Away from the source's outer half pixel (clamped by fishcam, blended with the border by OpenCV).
  const cv::Mat interior =
      (maps.map_x >= 1) & (maps.map_x <= size.width - 2) & (maps.map_y >= 1) & (maps.map_y <= size.height - 2);
  cv::Mat difference;
  cv::absdiff(ours, theirs, difference);
  double worst = 0;
  cv::minMaxLoc(difference, nullptr, &worst, nullptr, nullptr, interior);
  EXPECT_GT(cv::countNonZero(interior), size.area() / 3);
  EXPECT_LE(worst, 2 * 1.4 / 64 + 1e-4);
}

TEST(Affine, LabelsKeepTheirValuesPlusFill) {
  const cv::Size size(97, 71);
  cv::Mat labels(size, CV_8UC1);
  for (int v = 0; v < size.height; ++v) {
    for (int u = 0; u < size.width; ++u) labels.at<uchar>(v, u) = uchar(3 * ((u / 9 + v / 7) % 5));
  }
  for (std::uint64_t seed = 0; seed < 20; ++seed) {
    WarpMaps maps;
    affine_maps(random_affine(*find_affine_preset("train"), seed), size, &maps);
    cv::Mat out;
    warp_labels(labels, maps, 255, &out);
    std::set<int> values(out.begin<uchar>(), out.end<uchar>());
    for (int value : values) EXPECT_TRUE(value == 255 || (value % 3 == 0 && value <= 12)) << value;
    EXPECT_EQ(cv::countNonZero(out == 255), maps.invalid_count);
  }
}

TEST(Affine, PresetsAreTheirRangesAndSeedsReproduce) {
  const AffinePreset train = *find_affine_preset("train");
  EXPECT_EQ(train.max_rotation_deg, 30);
  EXPECT_EQ(train.max_translation, 0.3);
  EXPECT_EQ(train.min_scale, 0.5);
  EXPECT_EQ(train.max_scale, 1.5);
  EXPECT_FALSE(find_affine_preset("huge").has_value());
  for (const AffinePreset& preset : affine_presets()) {
    double max_rotation = 0, min_scale = 10, max_scale = 0;
    for (std::uint64_t seed = 0; seed < 2000; ++seed) {
      const AffineChange c = random_affine(preset, seed);
      EXPECT_LE(std::abs(c.rotation_deg), preset.max_rotation_deg);
      EXPECT_LE(c.translation.cwiseAbs().maxCoeff(), preset.max_translation);
      max_rotation = std::max(max_rotation, std::abs(c.rotation_deg));
      min_scale = std::min(min_scale, c.scale), max_scale = std::max(max_scale, c.scale);
    }
    // Uniform over the whole range: 2000 draws come within 1 % of each end.
    EXPECT_GT(max_rotation, 0.99 * preset.max_rotation_deg) << preset.name;
    EXPECT_LT(min_scale, preset.min_scale + 0.01 * (preset.max_scale - preset.min_scale)) << preset.name;
    EXPECT_GT(max_scale, preset.max_scale - 0.01 * (preset.max_scale - preset.min_scale)) << preset.name;
  }
  const AffineChange a = random_affine(train, 42), b = random_affine(train, 42);
  EXPECT_EQ(a.rotation_deg, b.rotation_deg);
  EXPECT_EQ(a.translation, b.translation);
  EXPECT_EQ(a.scale, b.scale);
}

TEST(Affine, BadChangesAreRefused) {
  WarpMaps maps;
  EXPECT_THROW(affine_maps(AffineChange{std::nan(""), {0, 0}, 1}, cv::Size(4, 4), &maps), Error);
  EXPECT_THROW(affine_maps(AffineChange{0, {INFINITY, 0}, 1}, cv::Size(4, 4), &maps), Error);
  EXPECT_THROW(affine_maps(AffineChange{0, {0, 0}, 0}, cv::Size(4, 4), &maps), Error);
  EXPECT_THROW(affine_maps(AffineChange{0, {0, 0}, -1}, cv::Size(4, 4), &maps), Error);
  EXPECT_THROW(affine_maps(AffineChange{}, cv::Size(0, 4), &maps), Error);
}

}  // namespace
}  // namespace fishcam
