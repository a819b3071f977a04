// Our maps against mrcal.image_transformation_map (mrcal 2.2's Python, the most
// trusted reference): `infinity` = distance None, `target-sphere` = distance 1.
#include <random>

#include "fishcam/augment/augmentation.hpp"
#include "fishcam/io/npy.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

// Source: the camera frame is mrcal's reference (identity extrinsics). Target:
// rt_cam_ref = (R, t), i.e. p_target = R p_source + t, which is our P' = R P + t.
CameraParameters with_change(CameraParameters p, const RigidMotion& change) {
  const RigidMotion inverse = change.inverse();  // our Pose is camera -> reference
  p.pose = Pose{Eigen::Quaterniond(inverse.rotation), inverse.translation};
  return p;
}

void compare_with_mrcal(const char* source_file, const char* target_file, std::uint64_t seed) {
  const auto dir =
      test::scratch_dir(std::string("mrcal_map_") + source_file + "_" + target_file + std::to_string(seed));
  const Camera source = read_camera(test::data_path(source_file)), target = read_camera(test::data_path(target_file));
  const RigidMotion change = random_change(*find_pose_preset("large"), seed).motion();
  CameraParameters src = source.parameters();
  src.pose = Pose{};
  write_camera(src, dir / "source.cameramodel", CameraFormat::mrcal);
  write_camera(with_change(target.parameters(), change), dir / "target.cameramodel", CameraFormat::mrcal);
  for (const char* distance : {"none", "1"}) {
    const std::string out = (dir / (std::string(distance) + ".npy")).string();
    const std::string command = "/usr/bin/python3 '" + test::test_path("mrcal_map_script").string() + "' '" +
                                (dir / "source.cameramodel").string() + "' '" + (dir / "target.cameramodel").string() +
                                "' " + distance + " '" + out + "' > '" + (dir / "log").string() + "' 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << test::read_file(dir / "log");
  }

  const ViewpointWarp warp(source, target);
  for (DepthPrior prior : {DepthPrior::infinity, DepthPrior::target_sphere}) {
    const NpyArray theirs = read_npy(dir / (prior == DepthPrior::infinity ? "none.npy" : "1.npy"));
    ASSERT_EQ(theirs.shape, (std::vector<size_t>{size_t(target.height()), size_t(target.width()), 2}));
    WarpMaps ours;
    warp.compute(change, prior, &ours, MapKind::geometric);
    double worst = 0, sum2 = 0;
    long count = 0;
    for (int v = 0; v < target.height(); ++v) {
      for (int u = 0; u < target.width(); ++u) {
        const size_t i = 2 * (size_t(v) * target.width() + u);
        const float x = theirs.data[i], y = theirs.data[i + 1];
        // Every pixel whose source lies inside the source image.
        if (!(x >= -0.5f && x < source.width() - 0.5f && y >= -0.5f && y < source.height() - 0.5f)) continue;
        const double e = std::hypot(ours.map_x.at<float>(v, u) - x, ours.map_y.at<float>(v, u) - y);
        ASSERT_TRUE(std::isfinite(e)) << "pixel " << u << "," << v << ": mrcal has a source, we have none";
        worst = std::max(worst, e);
        sum2 += e * e;
        ++count;
      }
    }
    EXPECT_GT(count, 10000);
    EXPECT_LE(worst, 1e-3) << source_file << " -> " << target_file << " " << to_string(prior);
    std::printf("  %s -> %s seed %llu %-13s: %ld pixels, max %.2e px, rms %.2e px\n", source_file, target_file,
                static_cast<unsigned long long>(seed), std::string(to_string(prior)).c_str(), count, worst,
                std::sqrt(sum2 / double(count)));
  }
}

TEST(MrcalAugmentation, StereographicToStereographic) {
  for (std::uint64_t seed : {1, 2}) compare_with_mrcal("stereographic.cameramodel", "stereographic.cameramodel", seed);
}
TEST(MrcalAugmentation, StereographicToPinhole) {
  compare_with_mrcal("stereographic.cameramodel", "pinhole.cameramodel", 3);
}
TEST(MrcalAugmentation, PinholeToStereographic) {
  compare_with_mrcal("pinhole.cameramodel", "stereographic.cameramodel", 4);
}
TEST(MrcalAugmentation, PinholeToPinhole) { compare_with_mrcal("pinhole.cameramodel", "pinhole.cameramodel", 5); }

}  // namespace
}  // namespace fishcam
