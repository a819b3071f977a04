// fishcam check-mrcal SOURCE ...: the same map computed by mrcal, and the difference.
#include <unistd.h>

#include <cmath>
#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/io/camera_io.hpp"
#include "fishcam/io/npy.hpp"

namespace fishcam::cli {

namespace {

// Our geometric map against mrcal's (x, y per pixel) where mrcal's source lies inside
// the source image: the largest and the summed squared distance, over `count` pixels;
// `missing`: pixels where mrcal has a source and we have none.
struct MapAgreement {
  double worst = 0, sum2 = 0;
  long count = 0, missing = 0;
};

MapAgreement map_agreement(const WarpMaps& ours, const NpyArray& theirs, int source_width, int source_height) {
  MapAgreement out;
  const int w = ours.map_x.cols, h = ours.map_x.rows;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float x = theirs.data[2 * (size_t(v) * w + u)], y = theirs.data[2 * (size_t(v) * w + u) + 1];
      if (!(x >= -0.5f && x < source_width - 0.5f && y >= -0.5f && y < source_height - 0.5f)) continue;
      const double e = std::hypot(ours.map_x.at<float>(v, u) - x, ours.map_y.at<float>(v, u) - y);
      if (!std::isfinite(e)) {
        ++out.missing;
        continue;
      }
      out.worst = std::max(out.worst, e);
      out.sum2 += e * e;
      ++out.count;
    }
  }
  return out;
}

}  // namespace

void register_check_mrcal(CLI::App& app) {
  auto* cmd = app.add_subcommand("check-mrcal",
                                 "Compare our map with mrcal.image_transformation_map (needs "
                                 "/usr/bin/python3 with mrcal, and mrcal-representable cameras)");
  struct Options {
    std::string source, target;
    PoseOptions pose;
  };
  auto o = std::make_shared<Options>();
  o->pose.depth = "target-sphere";
  cmd->add_option("SOURCE", o->source, "Source camera file (pinhole or stereographic)")->required();
  cmd->add_option("--target", o->target, "Output camera file (default: the source camera)");
  cmd->add_option("--rotate", o->pose.rotate, "Rotation rx,ry,rz in degrees (R = Rz Ry Rx)")
      ->delimiter(',')
      ->expected(3)
      ->required();
  cmd->add_option("--translate", o->pose.translate, "Translation tx,ty,tz")->delimiter(',')->expected(3);
  cmd->add_option("--depth", o->pose.depth, "Depth prior mrcal has (distance=1 or None)")
      ->check(CLI::IsMember({"target-sphere", "infinity"}))
      ->capture_default_str();
  const auto inputs = std::make_shared<const CameraInputs>();  // as the files say
  cmd->callback([o, inputs] {
    const ViewpointWarp warp = make_warp(*inputs, o->source, o->target);
    const RigidMotion change = o->pose.motion();
    // mrcal: the source frame is the reference; the target has rt_cam_ref = (R, t).
    CameraParameters source = warp.source().parameters(), target = warp.target().parameters();
    source.pose = Pose{};
    const RigidMotion inverse = change.inverse();
    target.pose = Pose{Eigen::Quaterniond(inverse.rotation), inverse.translation};
    char pattern[] = "/tmp/fishcam-check-mrcal-XXXXXX";
    if (!mkdtemp(pattern)) throw Error("cannot create a temporary folder");
    const std::filesystem::path dir = pattern;
    struct Cleanup {
      std::filesystem::path dir;
      ~Cleanup() {
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
      }
    } cleanup{dir};
    try {
      write_camera(source, dir / "source.cameramodel", CameraFormat::mrcal);
      write_camera(target, dir / "target.cameramodel", CameraFormat::mrcal);
    } catch (const Error& e) {
      throw Error(std::string("cameras must be mrcal-representable (pinhole or stereographic): ") + e.what());
    }
    const std::string script = bundled_data("mrcal_map.py").string();
    const std::string command = "/usr/bin/python3 '" + script + "' '" + (dir / "source.cameramodel").string() + "' '" +
                                (dir / "target.cameramodel").string() + "' " +
                                (o->pose.prior() == DepthPrior::infinity ? "none" : "1") + " '" +
                                (dir / "map.npy").string() + "' > '" + (dir / "log").string() + "' 2>&1";
    if (std::system(command.c_str()) != 0) {
      throw Error("mrcal (/usr/bin/python3 " + script + ") failed; is python3-mrcal installed?");
    }
    const NpyArray theirs = read_npy(dir / "map.npy");
    WarpMaps ours;
    warp.compute(change, o->pose.prior(), &ours, MapKind::geometric);
    const MapAgreement agreement = map_agreement(ours, theirs, source.width, source.height);
    const double worst = agreement.worst, sum2 = agreement.sum2;
    const long count = agreement.count, missing = agreement.missing;
    std::printf("compared %ld pixels whose mrcal source lies inside the source image (%s, depth %s)\n", count,
                describe(change.euler_deg(), change.translation).c_str(), o->pose.depth.c_str());
    std::printf("max difference %.3g px, rms %.3g px", worst, count ? std::sqrt(sum2 / double(count)) : 0.0);
    if (missing) std::printf(", %ld pixels where mrcal has a source and we have none", missing);
    std::printf("\n");
    if (missing) throw Error("fishcam and mrcal disagree on which pixels have a source");
  });
}

}  // namespace fishcam::cli
