// fishcam map SOURCE: the augmentation's map as a numpy array.
#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/io/npy.hpp"

namespace fishcam::cli {

void register_map(CLI::App& app) {
  auto* cmd = app.add_subcommand("map",
                                 "Write the viewpoint-augmentation map: float32 HxWx2 .npy of source (x, y) per "
                                 "output pixel, NaN where there is no valid source");
  struct Options {
    std::string source, target, out;
    PoseOptions pose;
    bool exact = false, force = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("SOURCE", o->source, "Source camera file")->required();
  cmd->add_option("--target", o->target, "Output camera file (default: the source camera)");
  add_pose_options(cmd, &o->pose);
  cmd->add_option("--out", o->out, "Output .npy file")->required();
  cmd->add_flag("--exact", o->exact, "Compute in double precision pixel by pixel (slow reference)");
  cmd->add_flag("--force", o->force, "Replace an existing output file");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, inputs] {
    check_outputs({{o->out}}, {o->source, o->target}, o->force);
    if (std::filesystem::path(o->out).extension() != ".npy") {
      throw Error("--out: " + path_for_message(o->out) +
                  ": a map is written as .npy (float32 H x W x 2); name it .npy");
    }
    const ViewpointWarp warp = make_warp(*inputs, o->source, o->target);
    WarpMaps maps;
    if (o->exact) {
      warp.compute_exact(o->pose.motion(), o->pose.prior(), &maps);
    } else {
      warp.compute(o->pose.motion(), o->pose.prior(), &maps, MapKind::geometric);
    }
    const int h = maps.map_x.rows, w = maps.map_x.cols;
    NpyArray array{{size_t(h), size_t(w), 2}, std::vector<float>(2 * size_t(h) * size_t(w))};
    long finite = 0;
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const size_t i = 2 * (size_t(v) * w + u);
        array.data[i] = maps.map_x.at<float>(v, u);
        array.data[i + 1] = maps.map_y.at<float>(v, u);
        finite += !std::isnan(array.data[i]);
      }
    }
    write_npy(o->out, array, o->force);
    std::printf("wrote %s: %dx%dx2 float32, %ld pixels with a source (%ld inside the source image), %s, depth %s\n",
                o->out.c_str(), h, w, finite, long(h) * w - maps.invalid_count,
                describe(o->pose.motion().euler_deg(), o->pose.motion().translation).c_str(), o->pose.depth.c_str());
  });
}

}  // namespace fishcam::cli
