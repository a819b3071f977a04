// fishcam render CAMERA: a street scene (the bundled one, or one drawn from
// --scene-seed) as CAMERA sees it, optionally after a viewpoint change (the ground
// truth for augmentations): RGB, labels and, on request, the range of every pixel.
#include <cstdio>

#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/npy.hpp"

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/augment/scene.hpp"
#include "fishcam/io/camera_io.hpp"

namespace fishcam::cli {

void register_render(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Ray-cast a street scene through a camera: RGB, WoodScape labels, range");
  struct Options {
    std::string camera, mount, out_image, out_label, out_depth;
    std::optional<std::uint64_t> scene_seed;
    int supersampling = 2;
    PoseOptions pose;
    bool force = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("CAMERA", o->camera, "Camera file")->required();
  add_pose_options(cmd, &o->pose, /*with_depth=*/false);
  cmd->add_option("--mount", o->mount, "Take the camera's pose (camera -> vehicle) from this camera file instead");
  cmd->add_option("--out-image", o->out_image, "Output RGB image (e.g. render.png)")->required();
  cmd->add_option("--out-label", o->out_label, "Output label image (PNG, WoodScape class ids)")->required();
  cmd->add_option("--out-depth", o->out_depth,
                  "Output range of every pixel (.npy float32 H x W, metres along the ray; inf: sky, NaN: outside "
                  "the camera's domain)");
  cmd->add_option("--scene-seed", o->scene_seed, "Draw a random street from this seed (default: the bundled street)");
  cmd->add_option("--supersampling", o->supersampling,
                  "RGB rays per pixel side (labels and range: one ray at the "
                  "pixel centre)")
      ->check(CLI::Range(1, 4))
      ->capture_default_str();
  cmd->add_flag("--force", o->force, "Replace existing output files");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, inputs] {
    if (!o->out_depth.empty() && std::filesystem::path(o->out_depth).extension() != ".npy") {
      throw Error("--out-depth: " + o->out_depth + ": the range is written as .npy");
    }
    check_outputs({{o->out_image}, {o->out_label, true}, {o->out_depth}}, {o->camera, o->mount}, o->force);
    const Camera camera = inputs->read(o->camera);
    const std::optional<Pose> mount_pose =
        o->mount.empty() ? camera.parameters().pose : inputs->read(o->mount).parameters().pose;
    if (!mount_pose) {
      throw Error(o->camera +
                  ": has no pose to place it in the scene (give one with --mount, e.g. "
                  "data/woodscape_front.json)");
    }
    const Pose pose = moved_camera(*mount_pose, o->pose.motion());
    const StreetScene scene = o->scene_seed ? StreetScene::generate(*o->scene_seed) : StreetScene::bundled();
    const SceneRender render = scene.render(camera, pose, o->supersampling);
    std::vector<std::pair<std::filesystem::path, std::string>> files = {
        {o->out_image, encode_image(o->out_image, render.image)},
        {o->out_label, encode_image(o->out_label, render.labels)}};
    if (!o->out_depth.empty()) {
      NpyArray depth{{size_t(camera.height()), size_t(camera.width())}, {}};
      depth.data.assign(render.range.begin<float>(), render.range.end<float>());
      files.emplace_back(o->out_depth, npy_bytes(depth, o->out_depth));
    }
    write_outputs(files, o->force);
    std::printf("wrote %s, %s%s%s (%dx%d)\n", o->out_image.c_str(), o->out_label.c_str(),
                o->out_depth.empty() ? "" : " and ", o->out_depth.c_str(), camera.width(), camera.height());
  });
}

}  // namespace fishcam::cli
