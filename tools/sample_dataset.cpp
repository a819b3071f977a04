// fishcam sample-dataset OUT --images N --seed S: a small WoodScape-layout dataset
// made from the bundled street scene, so the Python example and tests run from a
// fresh clone: each sample is the scene rendered through the camera at a seeded
// perturbation of its mount (a few degrees, a few centimetres), with its labels
// and its calibration (the perturbed pose), as WoodScape names them.
#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/atomic_file.hpp"
#include "fishcam/scene.hpp"

namespace fishcam::cli {

void register_sample_dataset(CLI::App& app) {
  auto* cmd = app.add_subcommand("sample-dataset", "Write a small WoodScape-layout dataset rendered from the bundled "
                                                   "street scene (images, labels, calibrations)");
  struct Options {
    std::string out, camera;
    int images = 8;
    std::uint64_t seed = 0;
    std::string size;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("OUT", o->out, "Output folder (created; existing samples are never replaced)")->required();
  cmd->add_option("--images", o->images, "Number of samples")->check(CLI::Range(1, 100000))->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the mount perturbations")->required();
  cmd->add_option("--camera", o->camera, "Camera file with a pose (default: the bundled WoodScape front camera)");
  cmd->add_option("--size", o->size, "Render at WxH or W,H (the same lens, resized; default: the camera's size)");
  cmd->callback([o] {
    const std::filesystem::path camera_path = o->camera.empty() ? bundled_data("woodscape_front.json") : std::filesystem::path(o->camera);
    Camera camera = read_camera(camera_path);
    if (!camera.parameters().pose) throw Error(camera_path.string() + ": has no pose to place it in the scene");
    if (!o->size.empty()) {
      const auto [width, height] = parse_image_size(o->size, "--size");
      if (width < 16 || height < 16 || width > 8192 || height > 8192) {
        throw Error("--size: expected 16 to 8192 pixels per side");
      }
      camera = Camera(resized(camera.parameters(), width, height));
    }
    const std::filesystem::path out = o->out;
    check_output_not_input(out, {camera_path}, true);
    for (const char* sub : {"rgb_images", "semantic_annotations/gtLabels", "calibration"}) {
      std::filesystem::create_directories(out / sub);
    }
    // Mount perturbations: up to 3 degrees about each axis, 5 cm along each.
    const PosePreset mount{"mount", 3.0, 0.05};
    int written = 0;
    for (int i = 0; i < o->images; ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "%05d_FV", i);
      const auto image_path = out / "rgb_images" / (std::string(name) + ".png");
      const auto label_path = out / "semantic_annotations" / "gtLabels" / (std::string(name) + ".png");
      const auto calibration_path = out / "calibration" / (std::string(name) + ".json");
      const RandomPose perturbation = random_pose(mount, derive_seed(o->seed, "sample-dataset", std::uint64_t(i)));
      CameraParameters p = camera.parameters();
      p.pose = moved_camera(*p.pose, perturbation.change());
      const SceneRender render = render_street_scene(camera, *p.pose);
      // The three files of a sample land together or not at all.
      write_files_atomically({{image_path, encode_image(image_path, render.image)},
                              {label_path, encode_image(label_path, render.labels)},
                              {calibration_path, format_camera(p, CameraFormat::woodscape)}},
                             false);
      ++written;
    }
    std::printf("wrote %d samples (%dx%d) to %s\n", written, camera.width(), camera.height(), out.c_str());
  });
}

}  // namespace fishcam::cli
