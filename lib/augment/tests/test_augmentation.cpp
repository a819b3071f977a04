// The viewpoint warp: its defining equation, the float kernel against the double
// reference, identity, inverse, label handling, and a brute-force forward splat of
// the paper's eqs. 6-10.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstring>
#include <random>

#include "fishcam/augment/augmentation.hpp"
#include "fishcam/augment/scene.hpp"
#include "fishcam/io/npy.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

constexpr DepthPrior kPriors[] = {DepthPrior::source_sphere, DepthPrior::target_sphere, DepthPrior::infinity};
constexpr double kDeg = 180 / M_PI;

Camera woodscape() { return read_camera(test::data_path("woodscape_front.json")); }

// A smooth, textured 8-bit test image (bilinear sampling of it is well-behaved).
cv::Mat test_image(int width, int height, int type) {
  cv::Mat image(height, width, type);
  const int channels = image.channels();
  const double scale = type == CV_16UC3 || CV_MAT_DEPTH(type) == CV_16U ? 257 : 1;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      for (int c = 0; c < channels; ++c) {
        const double value = 127.5 + 120 * std::sin(0.05 * u + 0.7 * c) * std::cos(0.043 * v - 0.3 * c);
        if (CV_MAT_DEPTH(type) == CV_8U) {
          image.ptr<uchar>(v)[u * channels + c] = cv::saturate_cast<uchar>(value);
        } else {
          image.ptr<ushort>(v)[u * channels + c] = cv::saturate_cast<ushort>(value * scale);
        }
      }
    }
  }
  return image;
}

TEST(Augmentation, SourcePointSatisfiesItsDefiningEquation) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uniform(-1, 1);
  int checked = 0, missed = 0;
  for (int i = 0; i < 20000; ++i) {
    const double scale = i % 2 ? 0.99 : 1.6;  // inside the unit sphere and outside
    const Eigen::Vector3d t =
        scale * Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)).normalized() * std::abs(uniform(rng));
    const RigidMotion change =
        RigidMotion::from_euler_deg({30 * uniform(rng), 30 * uniform(rng), 30 * uniform(rng)}, t);
    const Eigen::Vector3d d = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)).normalized();
    const auto p = source_point(d, change, DepthPrior::source_sphere);
    if (!p) {
      ASSERT_GE(t.norm(), 1.0) << "inside the sphere every ray has a source point";
      ++missed;
      continue;
    }
    const Eigen::Vector3d moved = change.rotation * *p + change.translation;  // = s d
    EXPECT_NEAR(p->norm(), 1.0, 1e-12);
    EXPECT_LT(moved.cross(d).norm(), 1e-9);
    EXPECT_GT(moved.dot(d), 0);
    // |t| >= 1: the nearer of the two intersections.
    if (t.norm() >= 1) {
      const double s = moved.dot(d), b = d.dot(t);
      EXPECT_LE(s, b + 1e-9);
    }
    ++checked;
  }
  EXPECT_GT(checked, 15000);
  EXPECT_GT(missed, 100);
}

// Every output pixel of a (small) WoodScape-lens camera, for poses inside and
// outside the unit sphere: the source point satisfies R P + t = s d, s > 0, |P| = 1,
// and the fast map points where the source camera projects it.
TEST(Augmentation, EveryValidMapEntrySatisfiesItsDefiningEquation) {
  CameraParameters p = test::woodscape_front();
  p.width = 320, p.height = 242;
  p.grid.principal_point = {159.5 + 3.942 / 4, 120.5 - 3.093 / 4};
  p.model = Polynomial<double>({339.749 / 4, -31.988 / 4, 48.275 / 4, -7.201 / 4});
  const Camera camera(p);
  const ViewpointWarp warp(camera);
  for (const auto& change : {random_change(*find_pose_preset("train"), 3).motion(),
                             RigidMotion::from_euler_deg({5, 10, -20}, {0.6, -0.7, 0.5})}) {  // |t| > 1
    WarpMaps maps;
    warp.compute(change, DepthPrior::source_sphere, &maps, MapKind::geometric);
    long checked = 0;
    for (int v = 0; v < p.height; ++v) {
      for (int u = 0; u < p.width; ++u) {
        Eigen::Vector3d d;
        ASSERT_TRUE(camera.unproject({double(u), double(v)}, &d));
        const auto source = source_point(d, change, DepthPrior::source_sphere);
        if (!std::isfinite(maps.map_x.at<float>(v, u))) continue;
        ASSERT_TRUE(source.has_value()) << u << "," << v;
        const Eigen::Vector3d moved = change.rotation * *source + change.translation;
        ASSERT_NEAR(source->norm(), 1.0, 1e-12);
        ASSERT_LT(moved.cross(d).norm(), 1e-9);
        ASSERT_GT(moved.dot(d), 0);
        Eigen::Vector2d pixel;
        ASSERT_TRUE(camera.project(*source, &pixel));
        // Where the ray grazes the sphere (|t| > 1, b^2 - c -> 0) s depends on d like a
        // square root: float maps lose digits there, and only there.
        const double b = d.dot(change.translation), disc = b * b - (change.translation.squaredNorm() - 1);
        const double tolerance = disc > 1e-2 ? 1e-3 : 2e-2;
        ASSERT_LT(std::hypot(pixel.x() - maps.map_x.at<float>(v, u), pixel.y() - maps.map_y.at<float>(v, u)), tolerance)
            << "disc " << disc;
        ++checked;
      }
    }
    EXPECT_GT(checked, p.width * p.height / 3);
  }
}

TEST(Augmentation, PriorsAgreeWithoutTranslationAndDifferWithIt) {
  const Eigen::Vector3d d = Eigen::Vector3d(0.2, -0.1, 1).normalized();
  const auto rotation_only = RigidMotion::from_euler_deg({5, -7, 12});
  const Eigen::Vector3d a = *source_point(d, rotation_only, DepthPrior::source_sphere);
  for (DepthPrior prior : kPriors) EXPECT_LT((*source_point(d, rotation_only, prior) - a).norm(), 1e-15);
  const auto moved = RigidMotion::from_euler_deg({5, -7, 12}, {0.3, 0, 0});
  EXPECT_GT((*source_point(d, moved, DepthPrior::source_sphere) - *source_point(d, moved, DepthPrior::infinity)).norm(),
            0.1);
}

TEST(Augmentation, EulerAnglesAreZYXAndRoundTrip) {
  const auto change = RigidMotion::from_euler_deg({90, 0, 0});
  // A rotation of +90 deg about x takes the y axis to z.
  EXPECT_LT((change.rotation * Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitZ()).norm(), 1e-15);
  const Eigen::Vector3d angles(12, -25, 33);
  EXPECT_LT((RigidMotion::from_euler_deg(angles).euler_deg() - angles).norm(), 1e-12);
  const Eigen::Matrix3d rz = Eigen::AngleAxisd(33 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d ry = Eigen::AngleAxisd(-25 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d rx = Eigen::AngleAxisd(12 * M_PI / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_LT((RigidMotion::from_euler_deg(angles).rotation - rz * ry * rx).norm(), 1e-15);
  const Eigen::Vector3d r(0.1, -0.2, 0.3);
  EXPECT_LT((RigidMotion::from_rodrigues(r).rotation -
             RigidMotion::from_quaternion(Eigen::Quaterniond(Eigen::AngleAxisd(r.norm(), r.normalized()))).rotation)
                .norm(),
            1e-15);
}

TEST(Augmentation, RandomPosesAreReproducibleAndInRange) {
  const PosePreset train = *find_pose_preset("train");
  const ViewpointChange a = random_change(train, 42), b = random_change(train, 42), c = random_change(train, 43);
  EXPECT_EQ(a.rotation_deg, b.rotation_deg);
  EXPECT_EQ(a.translation, b.translation);
  EXPECT_NE(a.rotation_deg, c.rotation_deg);
  // Fixed by std::mt19937_64's specified output and our own mapping to [0, 1):
  // these digits must be the same on every platform.
  EXPECT_NEAR(random_change(*find_pose_preset("small"), 1).rotation_deg.x(),
              10 * (2 * double(std::mt19937_64(1)() >> 11) * 0x1.0p-53 - 1), 0);
  double max_rotation = 0, max_translation = 0;
  for (std::uint64_t seed = 0; seed < 2000; ++seed) {
    const ViewpointChange p = random_change(*find_pose_preset("medium"), derive_seed(7, "frame", seed));
    max_rotation = std::max(max_rotation, p.rotation_deg.cwiseAbs().maxCoeff());
    max_translation = std::max(max_translation, p.translation.cwiseAbs().maxCoeff());
  }
  EXPECT_LE(max_rotation, 20);
  EXPECT_GT(max_rotation, 19.9);
  EXPECT_LE(max_translation, 0.3);
  EXPECT_GT(max_translation, 0.29);
  EXPECT_FALSE(find_pose_preset("huge").has_value());
  EXPECT_NE(derive_seed(7, "a", 0), derive_seed(7, "b", 0));
  EXPECT_NE(derive_seed(7, "a", 0), derive_seed(7, "a", 1));
}

// compute() (float kernel) against compute_exact: the worst distance where both
// are valid, the pixels whose validity differs, and the pixels valid in both.
struct MapAgreement {
  double worst_px;
  long validity_differs, both_valid;
};
MapAgreement fast_against_exact(const ViewpointWarp& warp, const RigidMotion& change, DepthPrior prior) {
  WarpMaps fast, exact;
  warp.compute(change, prior, &fast, MapKind::geometric);
  warp.compute_exact(change, prior, &exact);
  MapAgreement a{0, 0, 0};
  for (int v = 0; v < exact.map_x.rows; ++v) {
    for (int u = 0; u < exact.map_x.cols; ++u) {
      a.validity_differs += fast.valid.at<uchar>(v, u) != exact.valid.at<uchar>(v, u);
      if (!exact.valid.at<uchar>(v, u) || !fast.valid.at<uchar>(v, u)) continue;
      ++a.both_valid;
      a.worst_px = std::max<double>(a.worst_px, std::hypot(fast.map_x.at<float>(v, u) - exact.map_x.at<float>(v, u),
                                                           fast.map_y.at<float>(v, u) - exact.map_y.at<float>(v, u)));
    }
  }
  return a;
}

// The float SIMD kernel against the double reference, every prior, every source model kind.
TEST(Augmentation, FastMapsAgreeWithTheExactReference) {
  const Camera ws = woodscape();
  const std::pair<const char*, Camera> targets[] = {
      {"woodscape", ws},
      {"stereographic", read_camera(test::data_path("stereographic.cameramodel"))},
      {"pinhole", read_camera(test::data_path("pinhole.cameramodel"))},
  };
  for (const auto& [name, other] : targets) {
    // Both directions: woodscape -> other and other -> woodscape.
    for (const auto& [source, target] : {std::pair{ws, other}, std::pair{other, ws}}) {
      const ViewpointWarp warp(source, target);
      for (std::uint64_t seed = 0; seed < 3; ++seed) {
        const RigidMotion change = random_change(*find_pose_preset("train"), seed).motion();
        for (DepthPrior prior : kPriors) {
          const auto [worst, disagree, both] = fast_against_exact(warp, change, prior);
          EXPECT_LE(worst, 1e-3) << name << " " << to_string(prior);
          EXPECT_LE(disagree, 20) << name << " " << to_string(prior) << ": validity differs (only on the image border)";
          EXPECT_GT(both, 50000);
        }
      }
    }
  }
}

// Every registry model as the source (the kernel evaluates the source's
// projection), one test each: the float kernel against the double reference.
class EveryModelSource : public ::testing::TestWithParam<test::ModelCase> {};

TEST_P(EveryModelSource, FastMapsAgreeWithTheExactReference) {
  const ViewpointWarp warp(Camera(GetParam().second), woodscape());
  ASSERT_EQ(warp.float_kernel(), test::float_kernel_form(GetParam().second));
  if (!warp.float_kernel()) return;  // the exact path: nothing else to compare
  const RigidMotion change = random_change(pose_preset("train"), 4).motion();
  int priors = 0;
  for (DepthPrior prior : kPriors) {
    const auto [worst, disagree, both] = fast_against_exact(warp, change, prior);
    EXPECT_LE(worst, 1e-3) << to_string(prior);
    EXPECT_LE(disagree, 20) << to_string(prior) << ": validity differs (only on the image border)";
    EXPECT_GT(both, 50000) << to_string(prior);
    ++priors;
  }
  EXPECT_EQ(priors, 3);
}

// The same lens written three ways (order 4, order 16 with k5..k16 = 0; f theta as
// equidistant, polynomial and Kannala-Brandt with zero k) gives bit-identical maps:
// the kernel sees one input. Run on both kernels (FISHCAM_NO_AVX2).
TEST(Augmentation, FastMapsOfEquivalentParameterisationsAreIdentical) {
  const CameraParameters ws = test::woodscape_front();
  std::vector<double> k16 = {339.749, -31.988, 48.275, -7.201};
  k16.resize(16, 0.0);
  const std::vector<std::vector<RadialModel>> groups = {
      {Polynomial<double>({339.749, -31.988, 48.275, -7.201}), Polynomial<double>(k16)},
      {Equidistant<double>(340.0), Polynomial<double>({340.0}), Polynomial<double>({340.0, 0.0, 0.0}),
       KannalaBrandt<double>(340.0, 0, 0, 0, 0)},
  };
  const RigidMotion change = random_change(*find_pose_preset("large"), 3).motion();
  for (const auto& group : groups) {
    WarpMaps first;
    for (size_t i = 0; i < group.size(); ++i) {
      const ViewpointWarp warp(Camera(test::with_model(ws, group[i])));
      EXPECT_TRUE(warp.float_kernel()) << model_name(group[i]);
      WarpMaps maps;
      warp.compute(change, DepthPrior::source_sphere, &maps, MapKind::geometric);
      if (i == 0) {
        first = maps;
        continue;
      }
      EXPECT_EQ(std::memcmp(first.map_x.data, maps.map_x.data, maps.map_x.total() * sizeof(float)), 0)
          << model_name(group[i]) << " " << group[i].index();
      EXPECT_EQ(cv::norm(first.valid, maps.valid, cv::NORM_INF), 0);
    }
  }
}

// Maps from compute() against compute_exact, whichever path compute() chose.
double worst_fast_vs_exact(const ViewpointWarp& warp, const RigidMotion& change, long* validity_differs) {
  WarpMaps fast, exact;
  warp.compute(change, DepthPrior::source_sphere, &fast, MapKind::geometric);
  warp.compute_exact(change, DepthPrior::source_sphere, &exact);
  double worst = 0;
  *validity_differs = 0;
  for (int v = 0; v < fast.map_x.rows; ++v) {
    for (int u = 0; u < fast.map_x.cols; ++u) {
      *validity_differs += fast.valid.at<uchar>(v, u) != exact.valid.at<uchar>(v, u);
      if (!exact.valid.at<uchar>(v, u)) continue;
      const double error = std::hypot(fast.map_x.at<float>(v, u) - exact.map_x.at<float>(v, u),
                                      fast.map_y.at<float>(v, u) - exact.map_y.at<float>(v, u));
      if (fast.valid.at<uchar>(v, u)) worst = std::max(worst, error);
    }
  }
  return worst;
}

// Cameras the float kernel cannot evaluate to 1e-3 px take the exact path, and
// their maps stay right (they were 723 px off, all-NaN, or 94 % wrong at identity).
// A flipped image with its camera (a mirrored pixel grid, fishcam::mirrored) augmented
// by a change is the flip of the augmented image: the maps agree pixel for pixel, on
// the float kernel as on the exact path, for every prior and flip.
TEST(Augmentation, MirroredCamerasWarpTheFlippedImage) {
  int compared = 0;
  for (const auto& [name, p] : {std::pair{std::string("woodscape"), resized(test::woodscape_front(), 320, 242)},
                                test::every_tangential_camera().front(), test::skewed_camera()}) {
    const CameraParameters small = resized(p, 320, 242);
    const ViewpointWarp warp{Camera(small)};
    const RigidMotion change = random_change(*find_pose_preset("large"), 9).motion();
    for (const DepthPrior prior : {DepthPrior::source_sphere, DepthPrior::infinity}) {
      WarpMaps maps;
      warp.compute(change, prior, &maps, MapKind::geometric);
      for (const auto& [horizontal, vertical] : {std::pair{true, false}, {false, true}, {true, true}}) {
        SCOPED_TRACE(name + (horizontal ? " horizontal" : "") + (vertical ? " vertical" : ""));
        const ViewpointWarp flipped{Camera(mirrored(small, horizontal, vertical))};
        EXPECT_EQ(flipped.float_kernel(), warp.float_kernel());
        WarpMaps flipped_maps;
        flipped.compute(change, prior, &flipped_maps, MapKind::geometric);
        const int w = small.width, h = small.height;
        double worst = 0;
        long valid_differs = 0;
        for (int v = 0; v < h; ++v) {
          for (int u = 0; u < w; ++u) {
            const int fu = horizontal ? w - 1 - u : u, fv = vertical ? h - 1 - v : v;
            valid_differs += maps.valid.at<uchar>(v, u) != flipped_maps.valid.at<uchar>(fv, fu);
            if (!maps.valid.at<uchar>(v, u) || !flipped_maps.valid.at<uchar>(fv, fu)) continue;
            const double x = maps.map_x.at<float>(v, u), y = maps.map_y.at<float>(v, u);
            const Eigen::Vector2d expected(horizontal ? w - 1 - x : x, vertical ? h - 1 - y : y);
            worst = std::max(
                worst,
                (Eigen::Vector2d(flipped_maps.map_x.at<float>(fv, fu), flipped_maps.map_y.at<float>(fv, fu)) - expected)
                    .norm());
          }
        }
        EXPECT_LE(worst, 2e-3);
        EXPECT_LE(valid_differs, 2 * (w + h));  // only where a source lands on the image's edge
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, 3 * 2 * 3);
}

TEST(Augmentation, FastMapsFallBackToTheExactPathWhereFloatFails) {
  CameraParameters small = test::woodscape_front();
  small.width = 160, small.height = 121;
  small.grid.principal_point = {79.5, 60.5};
  small.model = Polynomial<double>({339.749 / 8, -31.988 / 8, 48.275 / 8, -7.201 / 8});
  std::vector<double> k17 = {339.749 / 8, -31.988 / 8, 48.275 / 8, -7.201 / 8};
  k17.resize(17, 0.0);
  k17.back() = 1e-12;  // degree 17: past what the kernel holds
  CameraParameters far_centre = small;
  far_centre.grid.principal_point = {1e6, 1e6};
  far_centre.model = Equidistant<double>(1e6);
  // LATLON whose image reaches next to its pole (76 deg at the sides), where the chart is
  // singular: no table of its offsets (kLensTableMaxCells) holds 1e-4 px.
  CameraParameters latlon = test::with_model(small, Stereographic<double>(60.0));
  latlon.distortion = MrcalLensDistortion{std::make_shared<const MrcalLens>("LENSMODEL_LATLON", std::vector<double>{})};
  const std::pair<const char*, CameraParameters> cases[] = {
      {"LATLON next to its pole", latlon},
      {"degree 17", test::with_model(small, Polynomial<double>(k17))},
      {"principal point at 1e6", far_centre},
      {"f = 1e39", test::with_model(small, Equidistant<double>(1e39))},
      {"kannala-brandt f = 1e39", test::with_model(small, KannalaBrandt<double>(1e39, 0.01, 0, 0, 0))},
      // Every pixel within 1e-7 rad of theta = pi: a rotated ray there has an azimuth
      // float cannot resolve (the identity alone would have kept the fast path).
      {"stereographic f = 1e-6", test::with_model(small, Stereographic<double>(1e-6))},
  };
  for (const auto& [name, p] : cases) {
    const ViewpointWarp warp{Camera(p)};
    EXPECT_FALSE(warp.float_kernel()) << name;
    long differs = 0;
    EXPECT_LE(worst_fast_vs_exact(warp, random_change(*find_pose_preset("large"), 1).motion(), &differs), 1e-3) << name;
    EXPECT_LE(differs, 2) << name;
    WarpMaps identity;
    warp.compute(RigidMotion{}, DepthPrior::source_sphere, &identity);
    const cv::Mat image = test_image(p.width, p.height, CV_8UC1);
    cv::Mat out;
    warp_image(image, identity, &out);
    // Pixels with a source inside the image come back unchanged.
    EXPECT_EQ(cv::norm(image, out, cv::NORM_INF, identity.validity()), 0) << name;
  }
  // The principal point far outside but a normal lens: the identity has every pixel.
  const ViewpointWarp far{Camera(far_centre)};
  WarpMaps identity;
  far.compute(RigidMotion{}, DepthPrior::source_sphere, &identity);
  EXPECT_EQ(identity.invalid_count, 0);
  // Every bundled kind of camera keeps the fast path.
  int kernels = 0;
  for (const auto& [name, p] : test::every_camera()) {
    EXPECT_EQ(ViewpointWarp(Camera(p)).float_kernel(), test::float_kernel_form(p)) << name;
    kernels += test::float_kernel_form(p);
  }
  EXPECT_GE(kernels, 21);  // 16 models, 3 tangential, the spline, the skewed ocam (not CAHVOR, LONLAT, LATLON)
}

// The forward direction inverts the maps under every prior: a visible point's
// output pixel has, in the exact maps, a source within the map's pixel grid of it,
// and its source point (source_point of the output ray) is the point's own ray.
TEST(Augmentation, ForwardPointsInvertTheMapsUnderEveryPrior) {
  const Camera camera(resized(woodscape().parameters(), 320, 242));
  const ViewpointWarp warp(camera);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(3, 316), v(3, 238);  // rounding stays inside the image
  std::vector<Eigen::Vector2d> points(300);
  for (auto& p : points) p = Eigen::Vector2d(u(rng), v(rng));
  int checked = 0;
  for (const DepthPrior prior : kPriors) {
    for (const RigidMotion& change : {RigidMotion::from_euler_deg({12, -25, 8}, {0.2, -0.1, 0.3}),
                                      RigidMotion::from_euler_deg({-5, 3, 30}, {0, 0, -0.4})}) {
      std::vector<Eigen::Vector2d> out(points.size());
      std::vector<std::uint8_t> visible(points.size());
      warp.forward(change, prior, points, out, visible);
      WarpMaps maps;
      warp.compute_exact(change, prior, &maps);
      for (size_t i = 0; i < points.size(); ++i) {
        if (!visible[i]) continue;
        Eigen::Vector3d ray, d;
        ASSERT_TRUE(camera.unproject(points[i], &ray));
        ASSERT_TRUE(camera.unproject(out[i], &d));
        const auto back = source_point(d, change, prior);
        ASSERT_TRUE(back);
        EXPECT_LT((*back - ray).norm(), 1e-9) << to_string(prior);
        const int x = int(std::lround(out[i].x())), y = int(std::lround(out[i].y()));
        ASSERT_TRUE(maps.valid.at<uchar>(y, x));
        EXPECT_LT(std::hypot(maps.map_x.at<float>(y, x) - points[i].x(), maps.map_y.at<float>(y, x) - points[i].y()),
                  1.5);
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 6 * 300 / 2) << "too few visible points to test anything";
}

// Depth maps under a rotation keep each point's range; the output's z is the z of
// the moved point; values that are not depths pass through; sizes are checked.
TEST(Augmentation, DepthMapsAreReExpressedInTheMovedCamera) {
  const Camera camera(resized(woodscape().parameters(), 320, 242));
  const ViewpointWarp warp(camera);
  const RigidMotion rotation = RigidMotion::from_euler_deg({10, -20, 5});
  cv::Mat depth(242, 320, CV_32FC1, cv::Scalar(2.5f)), out;
  depth(cv::Rect(0, 0, 20, 20)).setTo(0.0f);  // a no-depth marker
  warp.warp_depth(rotation, DepthPrior::source_sphere, depth, DepthValues::range, &out, -1.0f);
  int ranges = 0;
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      const float value = out.at<float>(y, x);
      if (value == -1.0f || value == 0.0f) continue;
      EXPECT_NEAR(value, 2.5f, 2e-6f);
      ++ranges;
    }
  }
  EXPECT_GT(ranges, 320 * 242 / 3);
  // z: a translation along the optical axis moves every point's z by -t_z exactly.
  const RigidMotion back = RigidMotion::from_euler_deg({0, 0, 0}, {0, 0, -0.5});
  cv::Mat z(242, 320, CV_32FC1, cv::Scalar(4.0f)), z_out;
  warp.warp_depth(back, DepthPrior::infinity, z, DepthValues::z, &z_out);
  EXPECT_NEAR(z_out.at<float>(121, 160), 3.5f, 1e-5f);
  cv::Mat wrong(10, 10, CV_32FC1);
  EXPECT_THROW(warp.warp_depth(rotation, DepthPrior::source_sphere, wrong, DepthValues::range, &out), Error);
  cv::Mat doubles(242, 320, CV_64FC1);
  EXPECT_THROW(warp.warp_depth(rotation, DepthPrior::source_sphere, doubles, DepthValues::range, &out), Error);
}

TEST(Augmentation, NonFiniteOrNonRotationChangesAreRefused) {
  CameraParameters p = test::woodscape_front();
  p.width = 64, p.height = 48, p.grid.principal_point = {31.5, 23.5};
  const ViewpointWarp warp{Camera(p)};
  WarpMaps maps;
  const double nan = std::nan("");
  for (const RigidMotion& change :
       {RigidMotion::from_euler_deg({nan, 0, 0}), RigidMotion::from_euler_deg({0, 0, 0}, {0, INFINITY, 0}),
        RigidMotion{Eigen::Matrix3d::Identity() * 2, Eigen::Vector3d::Zero()},
        RigidMotion{-Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()}}) {
    EXPECT_THROW(warp.compute(change, DepthPrior::source_sphere, &maps), Error);
    EXPECT_THROW(warp.compute_exact(change, DepthPrior::source_sphere, &maps), Error);
  }
}

TEST(Augmentation, ImagesPastTheResamplingLimitAreRefused) {
  CameraParameters p = test::woodscape_front();
  p.width = 32767, p.height = 10;  // cv::remap needs fewer than 32767
  EXPECT_THROW(ViewpointWarp{Camera(p)}, Error);
  p.width = 10, p.height = 32767;
  EXPECT_THROW(ViewpointWarp{Camera(p)}, Error);
}

TEST(Augmentation, IdentityReproducesTheInputExactly) {
  const Camera camera = woodscape();
  const ViewpointWarp warp(camera);
  for (const auto& [prior, kind] :
       {std::pair{DepthPrior::source_sphere, MapKind::sampling},
        std::pair{DepthPrior::target_sphere, MapKind::geometric}, std::pair{DepthPrior::infinity, MapKind::sampling}}) {
    WarpMaps maps;
    warp.compute(RigidMotion{}, prior, &maps, kind);
    EXPECT_EQ(maps.invalid_count, 0);
    for (int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3}) {
      const cv::Mat image = test_image(camera.width(), camera.height(), type);
      cv::Mat out;
      warp_image(image, maps, &out);
      EXPECT_EQ(cv::norm(image, out, cv::NORM_INF), 0) << to_string(prior) << " type " << type;
    }
    cv::Mat labels(camera.height(), camera.width(), CV_8UC1), out;
    cv::randu(labels, 0, 10);
    warp_labels(labels, maps, 255, &out);
    EXPECT_EQ(cv::norm(labels, out, cv::NORM_INF), 0);
  }
}

TEST(Augmentation, RotationThenInverseRecoversTheGeometry) {
  const Camera camera = woodscape();
  const ViewpointWarp warp(camera);
  const RigidMotion change = RigidMotion::from_euler_deg({15, -20, 25});
  WarpMaps forward, back;
  warp.compute(change, DepthPrior::infinity, &forward, MapKind::geometric);
  warp.compute(change.inverse(), DepthPrior::infinity, &back, MapKind::geometric);
  // back maps output -> intermediate, forward maps intermediate -> original.
  double worst = 0;
  long count = 0;
  for (int v = 0; v < camera.height(); v += 2) {
    for (int u = 0; u < camera.width(); u += 2) {
      if (!back.valid.at<uchar>(v, u)) continue;
      const float x = back.map_x.at<float>(v, u), y = back.map_y.at<float>(v, u);
      // Bilinear interpolation of the forward map at (x, y), where all four neighbours are valid.
      const int u0 = int(std::floor(x)), v0 = int(std::floor(y));
      if (u0 < 0 || v0 < 0 || u0 + 1 >= camera.width() || v0 + 1 >= camera.height()) continue;
      if (!forward.valid.at<uchar>(v0, u0) || !forward.valid.at<uchar>(v0, u0 + 1) ||
          !forward.valid.at<uchar>(v0 + 1, u0) || !forward.valid.at<uchar>(v0 + 1, u0 + 1)) {
        continue;
      }
      const double a = x - u0, b = y - v0;
      auto lerp = [&](const cv::Mat& m) {
        return (1 - b) * ((1 - a) * m.at<float>(v0, u0) + a * m.at<float>(v0, u0 + 1)) +
               b * ((1 - a) * m.at<float>(v0 + 1, u0) + a * m.at<float>(v0 + 1, u0 + 1));
      };
      worst = std::max(worst, std::hypot(lerp(forward.map_x) - u, lerp(forward.map_y) - v));
      ++count;
    }
  }
  EXPECT_GT(count, 100000);
  EXPECT_LT(worst, 0.05);  // the maps are smooth: linear interpolation error only
  // And the image: rotate, rotate back; in the valid region only interpolation blur remains.
  const cv::Mat image = test_image(camera.width(), camera.height(), CV_8UC3);
  cv::Mat once, twice;
  warp_image(image, forward, &once);
  warp_image(once, back, &twice);
  cv::Mat difference;
  cv::absdiff(image, twice, difference);
  const cv::Scalar mean_error = cv::mean(difference, back.valid);
  EXPECT_LT(mean_error[0], 1.0);
}

TEST(Augmentation, LabelValuesArePreservedAndFillIsConfigurable) {
  const Camera camera = woodscape();
  const ViewpointWarp warp(camera);
  cv::Mat labels(camera.height(), camera.width(), CV_8UC1);
  // Blocks of classes 1..9 (no 0 and no 255: so any 0 or 255 in the output was invented).
  for (int v = 0; v < labels.rows; ++v) {
    for (int u = 0; u < labels.cols; ++u) labels.at<uchar>(v, u) = uchar(1 + ((u / 37 + v / 23) % 9));
  }
  WarpMaps maps;
  warp.compute(random_change(*find_pose_preset("large"), 5).motion(), DepthPrior::source_sphere, &maps,
               MapKind::geometric);
  ASSERT_GT(maps.invalid_count, 0);
  for (int fill : {0, 255}) {
    cv::Mat out;
    warp_labels(labels, maps, fill, &out);
    for (int v = 0; v < out.rows; ++v) {
      for (int u = 0; u < out.cols; ++u) {
        const int value = out.at<uchar>(v, u);
        if (maps.valid.at<uchar>(v, u)) {
          ASSERT_TRUE(value >= 1 && value <= 9);
          // Nearest neighbour: exactly the label of the rounded source pixel.
          const int su = int(std::lrint(maps.map_x.at<float>(v, u))), sv = int(std::lrint(maps.map_y.at<float>(v, u)));
          ASSERT_EQ(value, labels.at<uchar>(std::clamp(sv, 0, labels.rows - 1), std::clamp(su, 0, labels.cols - 1)));
        } else {
          ASSERT_EQ(value, fill);
        }
      }
    }
  }
  cv::Mat out;
  EXPECT_THROW(warp_labels(labels, maps, 256, &out), Error);
  EXPECT_THROW(warp_labels(cv::Mat(10, 10, CV_8UC1), maps, 0, &out), Error);
  EXPECT_THROW(warp_image(cv::Mat(camera.height(), camera.width(), CV_64FC1), maps, &out), Error);
  EXPECT_THROW(warp_image(cv::Mat(camera.height(), camera.width(), CV_8UC1), maps, &out, std::nan("")), Error);
}

// Pixels without a source take the image fill value, for every supported depth.
TEST(Augmentation, ImageFillIsConfigurable) {
  const Camera camera = woodscape();
  const ViewpointWarp warp(camera);
  for (MapKind kind : {MapKind::sampling, MapKind::geometric}) {
    WarpMaps maps;
    warp.compute(random_change(*find_pose_preset("large"), 5).motion(), DepthPrior::source_sphere, &maps, kind);
    const cv::Mat invalid = maps.validity() == 0;
    ASSERT_GT(cv::countNonZero(invalid), 0);
    for (int type : {CV_8UC3, CV_16UC1, CV_32FC3}) {
      const cv::Mat image(camera.height(), camera.width(), type, cv::Scalar::all(7));
      cv::Mat out;
      warp_image(image, maps, &out, 42.5);
      const double expected = CV_MAT_DEPTH(type) == CV_32F ? 42.5 : 42;  // saturate_cast rounds half to even
      cv::Mat channels[4];
      cv::split(out, channels);
      for (int c = 0; c < out.channels(); ++c) {
        double lo, hi;
        cv::minMaxLoc(channels[c], &lo, &hi, nullptr, nullptr, invalid);
        EXPECT_EQ(lo, expected) << type;
        EXPECT_EQ(hi, expected) << type;
        cv::minMaxLoc(channels[c], &lo, &hi, nullptr, nullptr, ~invalid);
        EXPECT_EQ(lo, 7) << type;
        EXPECT_EQ(hi, 7) << type;
      }
    }
  }
}

// Sampling maps are the geometric maps made ready for cv::remap: the same pixels
// valid, coordinates moved by at most half a pixel (onto the image), and the same
// resampled images.
TEST(Augmentation, SamplingMapsResampleLikeGeometricMaps) {
  const Camera camera = woodscape();
  const ViewpointWarp warp(camera);
  const RigidMotion change = random_change(*find_pose_preset("large"), 11).motion();
  WarpMaps sampling, geometric;
  warp.compute(change, DepthPrior::source_sphere, &sampling, MapKind::sampling);
  warp.compute(change, DepthPrior::source_sphere, &geometric, MapKind::geometric);
  EXPECT_EQ(sampling.invalid_count, geometric.invalid_count);
  EXPECT_EQ(cv::countNonZero(sampling.validity() != geometric.validity()), 0);
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      if (!geometric.valid.at<uchar>(v, u)) {
        ASSERT_EQ(sampling.map_x.at<float>(v, u), kOutsideSource);
        continue;
      }
      ASSERT_LE(std::abs(sampling.map_x.at<float>(v, u) - geometric.map_x.at<float>(v, u)), 0.5f);
      ASSERT_LE(std::abs(sampling.map_y.at<float>(v, u) - geometric.map_y.at<float>(v, u)), 0.5f);
    }
  }
  const cv::Mat image = test_image(camera.width(), camera.height(), CV_8UC3);
  cv::Mat a, b;
  warp_image(image, sampling, &a);
  warp_image(image, geometric, &b);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  cv::Mat labels(camera.height(), camera.width(), CV_8UC1);
  cv::randu(labels, 1, 10);
  warp_labels(labels, sampling, 255, &a);
  warp_labels(labels, geometric, 255, &b);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
}

// The paper's forward model, literally: every source pixel onto the unit sphere
// (eq. 6), moved (eq. 7), reprojected (eqs. 8-10) and rounded to an output pixel.
// Where exactly one source pixel lands, our inverse map must point back at it.
TEST(Augmentation, AgreesWithABruteForceForwardSplat) {
  CameraParameters p = test::woodscape_front();
  p.width = 160, p.height = 121;  // a small image of the same lens: 1/8 scale
  p.grid.principal_point = {79.5 + 3.942 / 8, 60 - 3.093 / 8};
  p.model = Polynomial<double>({339.749 / 8, -31.988 / 8, 48.275 / 8, -7.201 / 8});
  const Camera camera(p);
  const ViewpointWarp warp(camera);
  for (const auto& change : {RigidMotion::from_euler_deg({10, -5, 8}, {0.1, -0.05, 0.2}),
                             RigidMotion::from_euler_deg({-20, 10, 0}, {0.3, 0.3, -0.3})}) {
    cv::Mat hits = cv::Mat::zeros(p.height, p.width, CV_32SC1);
    cv::Mat hit_x(p.height, p.width, CV_64FC1), hit_y(p.height, p.width, CV_64FC1);
    for (int v = 0; v < p.height; ++v) {
      for (int u = 0; u < p.width; ++u) {
        Eigen::Vector3d sphere;
        Eigen::Vector2d out;
        if (!camera.unproject({double(u), double(v)}, &sphere)) continue;
        if (!camera.project(change.rotation * sphere + change.translation, &out)) continue;
        const int ou = int(std::lround(out.x())), ov = int(std::lround(out.y()));
        if (ou < 0 || ov < 0 || ou >= p.width || ov >= p.height) continue;
        hits.at<int>(ov, ou) += 1;
        hit_x.at<double>(ov, ou) = u, hit_y.at<double>(ov, ou) = v;
      }
    }
    WarpMaps maps;
    warp.compute(change, DepthPrior::source_sphere, &maps, MapKind::geometric);
    long single = 0, close = 0;
    for (int v = 0; v < p.height; ++v) {
      for (int u = 0; u < p.width; ++u) {
        if (hits.at<int>(v, u) != 1) continue;
        ++single;
        // The splat rounded the output position by up to half a pixel; mapped
        // back, that is at most ~half a pixel times the local scale (~1).
        close += std::hypot(maps.map_x.at<float>(v, u) - hit_x.at<double>(v, u),
                            maps.map_y.at<float>(v, u) - hit_y.at<double>(v, u)) <= 1.0;
      }
    }
    EXPECT_GT(single, p.width * p.height / 3);
    EXPECT_GE(double(close) / double(single), 0.999) << close << " of " << single;
  }
}

TEST(Augmentation, RealWoodScapeImageStaysInsideTheImageCircle) {
  const auto image_path = test::shared_path("data/woodscape/front.jpg");
  if (!std::filesystem::exists(image_path)) GTEST_SKIP() << "no ../shared checkout";
  const cv::Mat image = cv::imread(image_path.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  const Camera camera = read_camera(test::shared_path("data/woodscape/front.json"));
  ASSERT_EQ(image.cols, camera.width());
  ASSERT_EQ(image.rows, camera.height());
  const ViewpointWarp warp(camera);
  for (std::uint64_t seed = 0; seed < 8; ++seed) {
    WarpMaps maps;
    warp.compute(random_change(*find_pose_preset("large"), seed).motion(), DepthPrior::source_sphere, &maps,
                 MapKind::geometric);
    cv::Mat out;
    warp_image(image, maps, &out);
    ASSERT_EQ(out.size(), image.size());
    ASSERT_EQ(out.type(), image.type());
    for (int v = 0; v < out.rows; ++v) {
      for (int u = 0; u < out.cols; ++u) {
        const float x = maps.map_x.at<float>(v, u), y = maps.map_y.at<float>(v, u);
        if (maps.valid.at<uchar>(v, u)) {
          // Inside the source image and inside the lens's valid domain.
          ASSERT_TRUE(x >= -0.5f && x < camera.width() - 0.5f && y >= -0.5f && y < camera.height() - 0.5f);
          ASSERT_LE(camera.rho_of_pixel({x, y}), camera.domain().rho_max);
        } else {
          ASSERT_EQ(out.at<cv::Vec3b>(v, u), cv::Vec3b(0, 0, 0));
        }
      }
    }
  }
}

}  // namespace
}  // namespace fishcam

namespace fishcam {
namespace {

// .npy files: a round trip, and headers that lie about their size are refused
// before anything is allocated.
TEST(Npy, RoundTripAndLyingHeaders) {
  const auto dir = test::scratch_dir("npy");
  NpyArray a;
  a.shape = {2, 3};
  a.data = {1, 2, 3, 4, 5, 6};
  write_npy(dir / "a.npy", a);
  const NpyArray b = read_npy(dir / "a.npy");
  EXPECT_EQ(b.shape, a.shape);
  EXPECT_EQ(b.data, a.data);
  // A version-1.0 file with this shape in its header and six floats of data.
  auto with_shape = [&](const std::string& shape) {
    std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': " + shape + ", }";
    header.append(64 - (10 + header.size() + 1) % 64, ' ');
    header += '\n';
    std::string text = std::string("\x93NUMPY\x01\x00", 8);
    text += char(header.size() & 0xff);
    text += char(header.size() >> 8);
    text += header + std::string(6 * sizeof(float), '\0');
    return test::write_file(dir / "bad.npy", text);
  };
  ASSERT_EQ(read_npy(with_shape("(3, 2)")).shape, (std::vector<std::size_t>{3, 2}));
  for (const char* shape :
       {"(4000000000, 4)", "(99999999999999999999, 1)", "(2, 4)", "(1, 3)", "(4294967296, 4294967296, 4294967296)"}) {
    try {
      read_npy(with_shape(shape));
      ADD_FAILURE() << shape << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("shape"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace fishcam

namespace fishcam {
namespace {

struct GridAgreement {
  double worst_px;
  long validity_differs, valid;
};

GridAgreement grid_against_exact(const ViewpointWarp& warp, const RigidMotion& change, DepthPrior prior) {
  WarpMaps grid, exact;
  warp.compute_grid(change, prior, &grid);
  warp.compute_exact(change, prior, &exact);
  GridAgreement a{0, 0, 0};
  for (int v = 0; v < exact.map_x.rows; ++v) {
    for (int u = 0; u < exact.map_x.cols; ++u) {
      const bool e = exact.valid.at<uchar>(v, u), g = grid.valid.at<uchar>(v, u);
      a.valid += e;
      a.validity_differs += e != g;
      if (!(e && g)) continue;
      a.worst_px = std::max<double>(a.worst_px, std::hypot(grid.map_x.at<float>(v, u) - exact.map_x.at<float>(v, u),
                                                           grid.map_y.at<float>(v, u) - exact.map_y.at<float>(v, u)));
    }
  }
  return a;
}

// Every registry model as the source (fold variants included), one test each: the
// grid's float map against the exact reference, within cv::remap's fixed-point step.
TEST_P(EveryModelSource, GridMapsAgreeWithTheExactReference) {
  // Half-size cameras: a quarter of the exact maps' cost.
  const Camera target(resized(woodscape().parameters(), 640, 483));
  const ViewpointWarp warp(Camera(resized(GetParam().second, 640, 483)), target);
  if (!test::float_kernel_form(GetParam().second)) {  // no kernel, no grid: compute_grid is the exact path
    EXPECT_EQ(warp.grid_spacing(), 0);
    return;
  }
  EXPECT_GT(warp.grid_spacing(), 0);
  int checked = 0;
  for (std::uint64_t seed = 0; seed < 2; ++seed) {
    const RigidMotion change = random_change(pose_preset("large"), seed).motion();
    for (DepthPrior prior : kPriors) {
      const auto [worst, differs, valid] = grid_against_exact(warp, change, prior);
      EXPECT_LE(worst, 1.0 / 32) << to_string(prior);
      // As the per-pixel float kernel (FastMaps... above): only pixels on the image border.
      EXPECT_LE(differs, 20) << to_string(prior);
      EXPECT_GT(valid, 10000) << to_string(prior) << ": too few pixels compared";
      ++checked;
    }
  }
  EXPECT_EQ(checked, 6);
}

INSTANTIATE_TEST_SUITE_P(Augmentation, EveryModelSource, ::testing::ValuesIn(test::every_camera()),
                         test::model_case_name);

// mrcal's real splined camera (cam0.splined, read through our reader) as the source:
// the kernel evaluates its spline cells (float_kernel_agrees accepted them against
// libmrcal's projection) at its full 4000 x 2200; resized to 1000 x 550 and warped
// into itself, the per-pixel maps agree with the exact ones to 1e-3 px and the grid's
// to cv::remap's fixed-point step.
TEST(Augmentation, MrcalSplinedSourceTakesTheKernelAndTheGrid) {
  const auto path = test::shared_path("data/external/mrcal_cam0.splined.cameramodel");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared checkout";
  const Camera full = read_camera(path);
  ASSERT_TRUE(full.parameters().mrcal_lens());
  EXPECT_TRUE(ViewpointWarp(full, Camera(resized(full.parameters(), 400, 220))).float_kernel());
  const Camera camera(resized(full.parameters(), 1000, 550));
  const ViewpointWarp warp(camera, camera);
  ASSERT_TRUE(warp.float_kernel());
  EXPECT_GT(warp.grid_spacing(), 0);
  int checked = 0;
  for (std::uint64_t seed = 0; seed < 2; ++seed) {
    const RigidMotion change = random_change(pose_preset("train"), seed).motion();
    for (DepthPrior prior : kPriors) {
      const auto [worst, disagree, both] = fast_against_exact(warp, change, prior);
      EXPECT_LE(worst, 1e-3) << to_string(prior);
      EXPECT_LE(disagree, 20) << to_string(prior);
      EXPECT_GT(both, 100000) << to_string(prior);
      const auto [grid_worst, differs, valid] = grid_against_exact(warp, change, prior);
      EXPECT_LE(grid_worst, 1.0 / 32) << to_string(prior);
      EXPECT_LE(differs, 20) << to_string(prior);
      EXPECT_GT(valid, 100000) << to_string(prior);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 6);
}

// The lens tables (CAHVOR, CAHVORE, LONLAT and LATLON sources, docs/augmentation.md)
// hold over the source image and 16 px around it; past them the kernel's geometric
// coordinates are approximate, and none of those pixels has a source in the image:
// under a large turn, wherever the per-pixel map leaves the exact one by more than the
// float tolerance, both lie outside the source image, the exact one past the margin.
TEST(Augmentation, LensTablesEndOutsideTheImage) {
  int tables = 0;
  for (const auto& [name, p] : test::mrcal_lens_cameras()) {
    if (p.mrcal_lens()->polynomial_cells()) continue;  // the spline: its own cells, extrapolated as mrcal does
    const Camera source(resized(p, 320, 242));
    const ViewpointWarp warp(source, source);
    ASSERT_TRUE(warp.float_kernel()) << name;
    ++tables;
    WarpMaps fast, exact;
    const RigidMotion change = RigidMotion::from_euler_deg({25, -30, 10});
    warp.compute(change, DepthPrior::infinity, &fast, MapKind::geometric);
    warp.compute_exact(change, DepthPrior::infinity, &exact);
    const auto outside_by = [&](double x, double y) {
      return std::max({-0.5 - x, x - (source.width() - 0.5), -0.5 - y, y - (source.height() - 0.5)});
    };
    long approximate = 0;
    double nearest = std::numeric_limits<double>::infinity();
    for (int v = 0; v < exact.map_x.rows; ++v) {
      for (int u = 0; u < exact.map_x.cols; ++u) {
        const double ex = exact.map_x.at<float>(v, u), ey = exact.map_y.at<float>(v, u);
        const double fx = fast.map_x.at<float>(v, u), fy = fast.map_y.at<float>(v, u);
        if (!std::isfinite(ex) || !std::isfinite(fx) || std::hypot(fx - ex, fy - ey) <= 1e-3) continue;
        ++approximate;
        nearest = std::min(nearest, outside_by(ex, ey));
        EXPECT_GT(outside_by(fx, fy), 0) << name << " at " << u << ", " << v;
        EXPECT_EQ(fast.valid.at<uchar>(v, u), 0) << name << " at " << u << ", " << v;
      }
    }
    EXPECT_GT(approximate, 1000) << name << ": the turn should reach past the table";
    EXPECT_GT(nearest, 16) << name;  // the margin (measured: 21-23 px, the 2 % widening beyond it)
  }
  EXPECT_EQ(tables, 4);
}

// Lenses far from the examples: the warp takes the kernel only where it agrees with the
// exact maps, never a table that misses them. Strong CAHVOR terms and a LATLON image
// 2 degrees wide take it; CAHVORE with strong E terms folds inside its image (table
// cells straddle the domain's end, where half their points have no projection) and a
// LONLAT image reaches past its poles: the exact path.
TEST(Augmentation, ExtremeMrcalLensesTakeTheKernelOnlyWhereItAgrees) {
  CameraParameters small = test::woodscape_front();
  small.width = 160, small.height = 121;
  small.grid.principal_point = {79.5, 60.5};
  const auto lens = [&](double f, bool pinhole, const char* lensmodel, std::vector<double> values) {
    CameraParameters p =
        pinhole ? test::with_model(small, Pinhole<double>(f)) : test::with_model(small, Stereographic<double>(f));
    p.distortion = MrcalLensDistortion{std::make_shared<const MrcalLens>(lensmodel, std::move(values))};
    return p;
  };
  struct Case {
    const char* name;
    CameraParameters camera;
    bool kernel;
  };
  const Case cases[] = {
      {"strong CAHVOR", lens(100, true, "LENSMODEL_CAHVOR", {0.3, -0.2, 0.05, -0.5, 0.3}), true},
      {"CAHVORE folding in its image",
       lens(60, false, "LENSMODEL_CAHVORE_linearity=1.00", {0, 0, 0, 0, 0, 2.0, 1.0, -0.5}), false},
      {"LONLAT past its poles", lens(30, false, "LENSMODEL_LONLAT", {}), false},
      {"LATLON 2 degrees wide", lens(4500, false, "LENSMODEL_LATLON", {}), true},
  };
  int ran = 0;
  for (const auto& [name, p, kernel] : cases) {
    const ViewpointWarp warp{Camera(p)};
    EXPECT_EQ(warp.float_kernel(), kernel) << name;
    long differs = 0;
    EXPECT_LE(worst_fast_vs_exact(warp, random_change(pose_preset("large"), 3).motion(), &differs), 1e-3) << name;
    EXPECT_LE(differs, 20) << name;
    ++ran;
  }
  EXPECT_EQ(ran, 4);
}

// Where float arithmetic is weakest: a full-circle fisheye whose image reaches
// theta = 180 deg (the azimuth of a ray next to -z rests on components a rotation
// leaves with a float's absolute error; rho / chi multiplies it), and strongly
// anisotropic pixel scales. The float maps stay within 1e-3 px and the grid within
// 1/32 px, or the warp steps aside to the exact path there (0.12 px and 0.11 px
// before).
// A camera limited per azimuth (what --theta-limit data writes) takes the exact path,
// and its maps are the unlimited camera's exact maps wherever both the output pixel's
// ray and its source's lie within the limit, and without a source elsewhere.
TEST(Augmentation, PerAzimuthLimitedCamerasWarpOnlyWithinTheLimit) {
  const CameraParameters whole = resized(test::woodscape_front(), 320, 242);
  CameraParameters p = whole;
  AzimuthSectors& limits = p.theta_limit_by_azimuth.emplace();
  limits.fill(80 / kDeg);
  for (int k : {5, 6, 7}) limits[size_t(k)] = 30 / kDeg;  // the image's top
  const ViewpointWarp warp{Camera(p)}, unlimited{Camera(whole)};
  EXPECT_FALSE(warp.float_kernel());
  const Camera& camera = unlimited.source();
  const auto within = [&](const Eigen::Vector3d& ray) {
    return std::atan2(ray.head<2>().norm(), ray.z()) <= angle_near_azimuth(limits, std::atan2(ray.y(), ray.x()));
  };
  int checked = 0;
  for (DepthPrior prior : kPriors) {
    const RigidMotion change = random_change(*find_pose_preset("medium"), 4).motion();
    WarpMaps limited_maps, maps;
    warp.compute(change, prior, &limited_maps, MapKind::geometric);
    unlimited.compute_exact(change, prior, &maps);
    long inside = 0, outside = 0;
    for (int v = 0; v < 242; ++v) {
      for (int u = 0; u < 320; ++u) {
        const bool valid = maps.valid.at<std::uint8_t>(v, u);
        Eigen::Vector3d ray, source_ray;
        const Eigen::Vector2d source(maps.map_x.at<float>(v, u), maps.map_y.at<float>(v, u));
        const bool expected = valid && camera.unproject(Eigen::Vector2d(u, v), &ray) && within(ray) &&
                              camera.unproject(source, &source_ray) && within(source_ray);
        // A source within float rounding of the limit may go either way.
        if (valid && !expected && camera.unproject(source, &source_ray) &&
            std::abs(std::acos(source_ray.z()) -
                     angle_near_azimuth(limits, std::atan2(source_ray.y(), source_ray.x()))) < 1e-5) {
          continue;
        }
        ASSERT_EQ(bool(limited_maps.valid.at<std::uint8_t>(v, u)), expected)
            << u << "," << v << " " << to_string(prior);
        if (!expected) {
          ++outside;
          continue;
        }
        ++inside;
        EXPECT_EQ(limited_maps.map_x.at<float>(v, u), maps.map_x.at<float>(v, u));
        EXPECT_EQ(limited_maps.map_y.at<float>(v, u), maps.map_y.at<float>(v, u));
      }
    }
    EXPECT_GT(inside, 20000) << to_string(prior);
    EXPECT_GT(outside, 5000) << to_string(prior);
    ++checked;
  }
  EXPECT_EQ(checked, 3);
}

TEST(Augmentation, FullCircleAndAnisotropicCamerasKeepTheirAccuracy) {
  CameraParameters full_circle = test::woodscape_front();
  full_circle.width = 640, full_circle.height = 483, full_circle.grid.principal_point = {319.5, 241};
  full_circle.model = Equidistant<double>(100);  // theta = pi at rho = 314 px: inside the image
  const std::pair<const char*, CameraParameters> cases[] = {
      {"full circle", full_circle},
      {"full circle, a_y = 0.2", test::with_model(full_circle, Equidistant<double>(100), {1, 0.2})},
      {"woodscape, a_y = 0.2", test::with_model(resized(test::woodscape_front(), 640, 483),
                                                resized(test::woodscape_front(), 640, 483).model, {1, 0.2})},
  };
  int checked = 0;
  for (const auto& [name, p] : cases) {
    const ViewpointWarp warp{Camera(p)};
    for (std::uint64_t seed = 0; seed < 3; ++seed) {
      const RigidMotion change = random_change(*find_pose_preset("large"), seed).motion();
      for (DepthPrior prior : kPriors) {
        const auto fast = fast_against_exact(warp, change, prior);
        EXPECT_LE(fast.worst_px, 1e-3) << name << " seed " << seed << " " << to_string(prior);
        EXPECT_LE(fast.validity_differs, 20) << name << " seed " << seed << " " << to_string(prior);
        const auto grid = grid_against_exact(warp, change, prior);
        EXPECT_LE(grid.worst_px, 1.0 / 32) << name << " seed " << seed << " " << to_string(prior);
        EXPECT_LE(grid.validity_differs, 20) << name << " seed " << seed << " " << to_string(prior);
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 27);
}

}  // namespace
}  // namespace fishcam

namespace fishcam {
namespace {

// augment() through the grid against the exact path, on the rendered scene: the
// labels differ on at most 1e-4 of the valid pixels (nearest-source ties), the
// image by the 1/32 px the maps may differ, and changes beyond the measured range
// take the exact path (bit-identical outputs).
TEST(Augmentation, GridSamplingMatchesTheExactPath) {
  const Camera camera = woodscape();
  const SceneRender scene = render_street_scene(camera, *camera.parameters().pose);
  const ViewpointWarp warp(camera);
  ASSERT_EQ(warp.grid_spacing(), 4);
  EXPECT_LE(warp.grid_error_px(), 1.0 / 32);
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    const RigidMotion change = random_change(*find_pose_preset("train"), seed).motion();
    cv::Mat grid_image, grid_labels, grid_valid, exact_image, exact_labels, exact_valid;
    warp.augment(change, DepthPrior::source_sphere,
                 {&scene.image, &grid_image, 7, &scene.labels, &grid_labels, 255, &grid_valid}, Sampling::grid);
    warp.augment(change, DepthPrior::source_sphere,
                 {&scene.image, &exact_image, 7, &scene.labels, &exact_labels, 255, &exact_valid}, Sampling::exact);
    const long valid = cv::countNonZero(exact_valid);
    EXPECT_LE(cv::countNonZero(grid_valid != exact_valid), std::max(2L, valid / 100000)) << seed;
    EXPECT_LE(cv::countNonZero(grid_labels != exact_labels), std::max(2L, valid / 10000)) << seed;
    cv::Mat difference;
    cv::absdiff(grid_image, exact_image, difference);
    EXPECT_LT(cv::mean(difference)[0], 0.05) << seed;
  }
  // A warp without a grid (a full-size pinhole seen through a half-size target: no
  // spacing keeps 1/32 px with 80 % of the pixels interpolated) samples per pixel.
  const ViewpointWarp no_grid(read_camera(test::data_path("pinhole.cameramodel")),
                              Camera(resized(camera.parameters(), 640, 483)));
  if (no_grid.grid_spacing() == 0) {
    const cv::Mat pinhole_image(no_grid.source().height(), no_grid.source().width(), CV_8UC1, cv::Scalar(9));
    cv::Mat g, e;
    const RigidMotion small = RigidMotion::from_euler_deg({5, 0, 0});
    no_grid.augment(small, DepthPrior::infinity, {&pinhole_image, &g, 0, nullptr, nullptr, 0, nullptr}, Sampling::grid);
    no_grid.augment(small, DepthPrior::infinity, {&pinhole_image, &e, 0, nullptr, nullptr, 0, nullptr},
                    Sampling::exact);
    EXPECT_EQ(cv::norm(g, e, cv::NORM_INF), 0);
  }
  // Past the measured changes: the exact path, exactly.
  const RigidMotion wide = RigidMotion::from_euler_deg({60, 0, 0});
  cv::Mat a, b;
  warp.augment(wide, DepthPrior::source_sphere, {&scene.image, &a, 0, nullptr, nullptr, 0, nullptr}, Sampling::grid);
  warp.augment(wide, DepthPrior::source_sphere, {&scene.image, &b, 0, nullptr, nullptr, 0, nullptr}, Sampling::exact);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  // The identity through the grid copies the image (every map point is a pixel centre to 1/32 px).
  cv::Mat same;
  warp.augment(RigidMotion{}, DepthPrior::source_sphere, {&scene.image, &same, 0, nullptr, nullptr, 0, nullptr});
  EXPECT_LT(cv::norm(same, scene.image, cv::NORM_L1) / double(scene.image.total() * 3), 0.05);
  // Bad inputs as warp_image / warp_labels.
  cv::Mat small(10, 10, CV_8UC3), out;
  EXPECT_THROW(warp.augment(RigidMotion{}, DepthPrior::source_sphere, {&small, &out, 0, nullptr, nullptr, 0, nullptr}),
               Error);
  EXPECT_THROW(
      warp.augment(RigidMotion{}, DepthPrior::source_sphere, {nullptr, nullptr, 0, &scene.labels, &out, 300, nullptr}),
      Error);
}

// `image` given channels-first (AugmentIO::image_planes: its planes one after another
// in one buffer, as torch's CxHxW images are, each row `pad` elements longer than the
// image's), the output planes merged back.
cv::Mat augment_channels_first(const ViewpointWarp& warp, const RigidMotion& change, DepthPrior prior,
                               const cv::Mat& image, double fill, Sampling sampling, int pad = 0) {
  const int c = image.channels(), h = image.rows, w = image.cols;
  const int out_h = warp.target().height(), out_w = warp.target().width();
  const int plane_type = CV_MAKETYPE(image.depth(), 1);
  cv::Mat planes_in(c * h, w + pad, plane_type, cv::Scalar::all(7)), planes_out(c * out_h, out_w + pad, plane_type);
  std::vector<cv::Mat> in, out;
  for (int k = 0; k < c; ++k) {
    in.push_back(planes_in(cv::Rect(0, k * h, w, h)));
    out.push_back(planes_out(cv::Rect(0, k * out_h, out_w, out_h)));
  }
  cv::split(image, in.data());  // into the planes, where they lie
  AugmentIO io{nullptr, nullptr, fill, nullptr, nullptr, 0, nullptr};
  io.image_planes = in, io.out_image_planes = out;
  warp.augment(change, prior, io, sampling);
  EXPECT_EQ(out[0].data, planes_out.data) << "the output planes were reallocated";
  cv::Mat merged;
  cv::merge(out, merged);
  return merged;
}

// The grid path's image is cv::remap (INTER_LINEAR, BORDER_CONSTANT) of its own map
// in fixed point, byte for byte, whichever samples it: the fused 8-bit bilinear
// (AVX2) or cv::remap per tile (other types, and the SSE2 run of this test).
// The map converted here independently of the row loops: clamped onto the outer
// pixel centres inside the image, far outside elsewhere, then cv::convertMaps.
TEST(Augmentation, GridImagesAreCvRemapOfTheGridMapByteForByte) {
  const Camera camera(resized(woodscape().parameters(), 640, 483));
  const ViewpointWarp warp(camera);
  ASSERT_GT(warp.grid_spacing(), 0);
  std::mt19937 random(5);
  auto noise = [&](int type) {  // every byte matters: a wrong weight shows
    cv::Mat m(camera.height(), camera.width(), type);
    cv::randu(m, cv::Scalar::all(0), cv::Scalar::all(CV_MAT_DEPTH(type) == CV_32F ? 1.0 : 256.0));
    return m;
  };
  // A view into a larger image: rows with a stride and the source's last byte not the buffer's.
  cv::Mat wide_buffer = noise(CV_8UC3);
  cv::copyMakeBorder(wide_buffer, wide_buffer, 3, 5, 7, 11, cv::BORDER_REFLECT);
  const cv::Mat view = wide_buffer(cv::Rect(7, 3, camera.width(), camera.height()));
  const std::vector<cv::Mat> images = {noise(CV_8UC1), noise(CV_8UC2),  noise(CV_8UC3), noise(CV_8UC4),
                                       view,           noise(CV_16UC3), noise(CV_32FC1)};
  const float max_x = float(camera.width() - 1), max_y = float(camera.height() - 1);
  // Three large changes, and the identity: it samples the image's last pixels, whose
  // taps bilinear_8u reads without passing the image's end.
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    const RigidMotion change = seed < 3 ? random_change(*find_pose_preset("large"), seed).motion() : RigidMotion{};
    const DepthPrior prior = seed == 0 ? DepthPrior::infinity : DepthPrior::source_sphere;
    WarpMaps maps;
    warp.compute_grid(change, prior, &maps);
    cv::Mat x = maps.map_x.clone(), y = maps.map_y.clone();
    for (int v = 0; v < x.rows; ++v) {
      for (int u = 0; u < x.cols; ++u) {
        float& sx = x.at<float>(v, u);
        float& sy = y.at<float>(v, u);
        if (maps.valid.at<unsigned char>(v, u)) {
          sx = std::clamp(sx, 0.0f, max_x);
          sy = std::clamp(sy, 0.0f, max_y);
        } else {
          sx = sy = -16384;
        }
      }
    }
    cv::Mat fixed, fractions;
    cv::convertMaps(x, y, fixed, fractions, CV_16SC2, false);
    for (const cv::Mat& image : images) {
      const double fill = image.depth() == CV_32F ? 0.25 : 200;
      cv::Mat expected, actual;
      cv::remap(image, expected, fixed, fractions, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(fill));
      warp.augment(change, prior, {&image, &actual, fill, nullptr, nullptr, 0, nullptr}, Sampling::grid);
      EXPECT_EQ(cv::norm(actual, expected, cv::NORM_INF), 0) << seed << " type " << image.type();
      // Channels-first: 8-bit planes interleaved for bilinear_8u, which writes the
      // output planes (AVX2), others through an interleaved copy; contiguous planes and
      // strided ones.
      for (const int pad : {0, 5}) {
        const cv::Mat planar = augment_channels_first(warp, change, prior, image, fill, Sampling::grid, pad);
        EXPECT_EQ(cv::norm(planar, expected, cv::NORM_INF), 0) << seed << " type " << image.type() << " pad " << pad;
      }
    }
  }
}

// Channels-first images on every path: two planes, an odd width (a partial last
// vector), the exact path and a depth map (through an interleaved copy), byte for
// byte the interleaved image's result; and the planes' errors.
TEST(Augmentation, ChannelsFirstImagesEqualInterleavedOnEveryPath) {
  const Camera camera(resized(woodscape().parameters(), 157, 119));
  const ViewpointWarp warp(camera);
  cv::Mat image(camera.height(), camera.width(), CV_8UC2);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(256));
  const RigidMotion change = random_change(*find_pose_preset("large"), 2).motion();
  for (const Sampling sampling : {Sampling::grid, Sampling::exact}) {
    cv::Mat expected;
    warp.augment(change, DepthPrior::source_sphere, {&image, &expected, 9, nullptr, nullptr, 0, nullptr}, sampling);
    const cv::Mat planar = augment_channels_first(warp, change, DepthPrior::source_sphere, image, 9, sampling);
    EXPECT_EQ(cv::norm(planar, expected, cv::NORM_INF), 0) << int(sampling);
  }
  const DepthMap depth{cv::Mat(camera.height(), camera.width(), CV_32FC1, cv::Scalar(4.0f))};
  cv::Mat expected;
  warp.augment(change, depth, {&image, &expected, 9, nullptr, nullptr, 0, nullptr});
  cv::Mat out0(camera.height(), camera.width(), CV_8UC1), out1 = out0.clone();
  std::vector<cv::Mat> in(2), out{out0, out1};
  cv::split(image, in.data());
  AugmentIO io{nullptr, nullptr, 9, nullptr, nullptr, 0, nullptr};
  io.image_planes = in, io.out_image_planes = out;
  warp.augment(change, depth, io);
  cv::Mat merged;
  cv::merge(out, merged);
  EXPECT_EQ(cv::norm(merged, expected, cv::NORM_INF), 0);

  std::vector<cv::Mat> one_out{out0};
  io.out_image_planes = one_out;
  EXPECT_THROW(warp.augment(change, DepthPrior::source_sphere, io), Error);  // 2 planes in, 1 out
  std::vector<cv::Mat> mixed{in[0], cv::Mat(camera.height(), camera.width(), CV_16UC1)};
  io.image_planes = mixed, io.out_image_planes = out;
  EXPECT_THROW(warp.augment(change, DepthPrior::source_sphere, io), Error);  // planes of two types
  std::vector<cv::Mat> small_out{cv::Mat(10, 10, CV_8UC1), cv::Mat(10, 10, CV_8UC1)};
  io.image_planes = in, io.out_image_planes = small_out;
  EXPECT_THROW(warp.augment(change, DepthPrior::source_sphere, io), Error);  // outputs of another size
}

// An output given in its own input's memory gives what a separate output gives.
TEST(Augmentation, AnOutputInItsInputsMemoryGivesTheSameResult) {
  const Camera camera(resized(woodscape().parameters(), 640, 483));
  const SceneRender scene = render_street_scene(camera, *camera.parameters().pose);
  const ViewpointWarp warp(camera);
  const RigidMotion change = random_change(*find_pose_preset("train"), 3).motion();
  for (const Sampling sampling : {Sampling::grid, Sampling::exact}) {
    cv::Mat image, labels;
    warp.augment(change, DepthPrior::source_sphere, {&scene.image, &image, 0, &scene.labels, &labels, 0, nullptr},
                 sampling);
    cv::Mat image_in_place = scene.image.clone(), labels_in_place = scene.labels.clone();
    warp.augment(change, DepthPrior::source_sphere,
                 {&image_in_place, &image_in_place, 0, &labels_in_place, &labels_in_place, 0, nullptr}, sampling);
    EXPECT_EQ(cv::norm(image_in_place, image, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(labels_in_place, labels, cv::NORM_INF), 0);
  }
}

}  // namespace
}  // namespace fishcam
