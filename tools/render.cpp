// fishcam render CAMERA: the bundled street scene as CAMERA sees it, optionally
// after a viewpoint change (the ground truth for augmentations).
#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/camera_io.hpp"
#include "fishcam/scene.hpp"

namespace fishcam::cli {

void register_render(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Ray-cast the bundled street scene through a camera: RGB and WoodScape "
                                           "labels");
  struct Options {
    std::string camera, mount, out_image, out_label;
    PoseOptions pose;
    bool force = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("CAMERA", o->camera, "Camera file")->required();
  add_pose_options(cmd, &o->pose, /*with_depth=*/false);
  cmd->add_option("--mount", o->mount, "Take the camera's pose (camera -> vehicle) from this camera file instead");
  cmd->add_option("--out-image", o->out_image, "Output RGB image (e.g. render.png)")->required();
  cmd->add_option("--out-label", o->out_label, "Output label image (PNG, WoodScape class ids)")->required();
  cmd->add_flag("--force", o->force, "Replace existing output files");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, inputs] {
    check_outputs({{o->out_image}, {o->out_label, true}}, {o->camera, o->mount}, o->force);
    const Camera camera = inputs->read(o->camera);
    const std::optional<Pose> mount_pose = o->mount.empty() ? camera.parameters().pose : inputs->read(o->mount).parameters().pose;
    if (!mount_pose) {
      throw Error(o->camera + ": has no pose to place it in the scene (give one with --mount, e.g. "
                              "data/woodscape_front.json)");
    }
    const Pose pose = moved_camera(*mount_pose, o->pose.change());
    const SceneRender render = render_street_scene(camera, pose);
    write_images({{o->out_image, render.image}, {o->out_label, render.labels}}, o->force);
    std::printf("wrote %s and %s (%dx%d)\n", o->out_image.c_str(), o->out_label.c_str(), camera.width(),
                camera.height());
  });
}

}  // namespace fishcam::cli
