// fishcam sample-dataset OUT: WoodScape-layout datasets rendered from street scenes.
// --images N: the bundled street through one camera at seeded perturbations of its
// mount (a few degrees, a few centimetres): what the Python example and tests use.
// --scenes N: a synthetic surround-view dataset, one seeded street per scene seen
// by the SynWoodScape cameras, split into train/val/test by scene, with true
// viewpoint test sets: the test scenes re-rendered from cameras moved by changes of
// the small/medium/large presets (docs/experiment.md).
#include <nlohmann/json.hpp>

#include <charconv>
#include <cstdio>
#include <map>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/atomic_file.hpp"
#include "fishcam/npy.hpp"
#include "fishcam/scene.hpp"

namespace fishcam::cli {
namespace {

namespace fs = std::filesystem;

// The folders of one WoodScape-layout root.
void make_layout(const fs::path& root, bool depth) {
  for (const char* sub : {"rgb_images", "semantic_annotations/gtLabels", "calibration"}) fs::create_directories(root / sub);
  if (depth) fs::create_directories(root / "depth");
}

// One sample's files (image, labels, calibration, optionally the range as .npy),
// landing together or not at all; existing files are never replaced.
void write_sample(const fs::path& root, const std::string& name, const SceneRender& render,
                  const CameraParameters& camera, bool depth) {
  const auto image_path = root / "rgb_images" / (name + ".png");
  const auto label_path = root / "semantic_annotations" / "gtLabels" / (name + ".png");
  std::vector<std::pair<fs::path, std::string>> files = {
      {image_path, encode_image(image_path, render.image)},
      {label_path, encode_image(label_path, render.labels)},
      {root / "calibration" / (name + ".json"), format_camera(camera, CameraFormat::woodscape)}};
  if (depth) {
    NpyArray range{{size_t(render.range.rows), size_t(render.range.cols)}, {}};
    range.data.assign(render.range.begin<float>(), render.range.end<float>());
    const auto depth_path = root / "depth" / (name + ".npy");
    files.emplace_back(depth_path, npy_bytes(range, depth_path.string()));
  }
  write_files_atomically(files, false);
}

Camera sized(Camera camera, const std::string& size) {
  if (size.empty()) return camera;
  const auto [width, height] = parse_image_size(size, "--size");
  if (width < 16 || height < 16 || width > 8192 || height > 8192) throw Error("--size: expected 16 to 8192 pixels per side");
  return Camera(resized(camera.parameters(), width, height));
}

struct Options {
  std::string out, camera, size, cameras = "FV,MVL,MVR,RV", splits = "0.7,0.15,0.15", test_sets = "small,medium,large";
  int images = 0, scenes = 0, supersampling = 2;
  std::uint64_t seed = 0;
  bool depth = false;
};

void bundled_street_dataset(const Options& o) {
  const fs::path camera_path = o.camera.empty() ? bundled_data("woodscape_front.json") : fs::path(o.camera);
  const Camera camera = sized(read_camera(camera_path), o.size);
  if (!camera.parameters().pose) throw Error(camera_path.string() + ": has no pose to place it in the scene");
  const fs::path out = o.out;
  check_output_not_input(out, {camera_path}, true);
  make_layout(out, o.depth);
  // Mount perturbations: up to 3 degrees about each axis, 5 cm along each.
  const PosePreset mount{"mount", 3.0, 0.05};
  for (int i = 0; i < o.images; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%05d_FV", i);
    const RandomPose perturbation = random_pose(mount, derive_seed(o.seed, "sample-dataset", std::uint64_t(i)));
    CameraParameters p = camera.parameters();
    p.pose = moved_camera(*p.pose, perturbation.change());
    write_sample(out, name, StreetScene::bundled().render(camera, *p.pose, o.supersampling), p, o.depth);
  }
  std::printf("wrote %d samples (%dx%d) to %s\n", o.images, camera.width(), camera.height(), out.c_str());
}

void surround_view_dataset(const Options& o) {
  const fs::path out = o.out;
  std::vector<std::pair<std::string, Camera>> cameras;
  std::vector<fs::path> inputs;
  for (const std::string& name : split_commas(o.cameras)) {
    const fs::path path = bundled_data("synwoodscape_" + name + ".json");
    cameras.emplace_back(name, sized(read_camera(path), o.size));
    inputs.push_back(path);
  }
  if (cameras.empty()) throw Error("--cameras: expected camera names such as FV,MVL,MVR,RV");
  check_output_not_input(out, inputs, true);
  const std::vector<std::string> fractions = split_commas(o.splits);
  std::array<double, 3> share{};
  if (fractions.size() != 3) throw Error("--splits: expected TRAIN,VAL,TEST fractions, got '" + o.splits + "'");
  for (size_t k = 0; k < 3; ++k) {
    const char* begin = fractions[k].data();
    const auto [end, error] = std::from_chars(begin, begin + fractions[k].size(), share[k]);
    if (error != std::errc() || end != begin + fractions[k].size()) {
      throw Error("--splits: '" + fractions[k] + "' is not a number");
    }
  }
  if (!(share[0] >= 0 && share[1] >= 0 && share[2] >= 0 && std::abs(share[0] + share[1] + share[2] - 1) < 1e-9)) {
    throw Error("--splits: expected three fractions >= 0 that sum to 1, got '" + o.splits + "'");
  }
  const int train = int(std::lround(share[0] * o.scenes)), val = int(std::lround(share[1] * o.scenes));
  const auto split_of = [&](int k) { return k < train ? "train" : k < train + val ? "val" : "test"; };
  std::vector<PosePreset> test_sets;
  if (o.test_sets != "none") {
    for (const std::string& name : split_commas(o.test_sets)) {
      test_sets.push_back(pose_preset(name, "--test-sets"));
    }
  }
  for (const char* split : {"train", "val", "test"}) make_layout(out / split, o.depth);
  for (const PosePreset& preset : test_sets) {
    make_layout(out / ("test-" + std::string(preset.name)), o.depth);
    make_layout(out / ("test-" + std::string(preset.name) + "-rotation"), o.depth);
  }
  std::string scenes_manifest;
  std::map<std::string, std::string> changes;  // test set -> its changes.jsonl
  int samples = 0;
  for (int k = 0; k < o.scenes; ++k) {
    const std::uint64_t scene_seed = derive_seed(o.seed, "scene", std::uint64_t(k));
    const StreetScene scene = StreetScene::generate(scene_seed);
    const std::string split = split_of(k);
    for (const auto& [camera_name, camera] : cameras) {
      char name[48];
      std::snprintf(name, sizeof name, "%05d_%s", k, camera_name.c_str());
      const CameraParameters& p = camera.parameters();
      write_sample(out / split, name, scene.render(camera, *p.pose, o.supersampling), p, o.depth);
      scenes_manifest += nlohmann::json{{"name", name}, {"split", split}, {"scene_seed", scene_seed},
                                        {"camera", camera_name}}.dump() + "\n";
      ++samples;
      if (split != std::string("test")) continue;
      // The true viewpoint test sets: the camera really moved (t read as metres), and
      // the same change without its translation.
      for (const PosePreset& preset : test_sets) {
        const std::string set = "test-" + std::string(preset.name);
        const std::uint64_t seed = derive_seed(o.seed, set, std::uint64_t(samples));
        const RandomPose full = random_pose(preset, seed);
        RandomPose rotation = full;
        rotation.translation.setZero();
        for (const auto& [folder, change] : {std::pair{set, full}, std::pair{set + "-rotation", rotation}}) {
          CameraParameters moved = p;
          moved.pose = moved_camera(*p.pose, change.change());
          write_sample(out / folder, name, scene.render(camera, *moved.pose, o.supersampling), moved, o.depth);
          const auto& r = change.rotation_deg;
          const auto& t = change.translation;
          changes[folder] += nlohmann::json{{"name", name}, {"preset", preset.name}, {"seed", seed},
                                            {"rotation_deg", {r.x(), r.y(), r.z()}},
                                            {"translation", {t.x(), t.y(), t.z()}}}.dump() + "\n";
        }
      }
    }
  }
  std::vector<std::pair<fs::path, std::string>> manifests = {{out / "scenes.jsonl", scenes_manifest}};
  for (const auto& [folder, text] : changes) manifests.emplace_back(out / folder / "changes.jsonl", text);
  write_outputs(manifests, false);
  std::printf("wrote %d scenes x %zu cameras (%d train, %d val, %d test scenes; %zu true viewpoint test sets) to %s\n",
              o.scenes, cameras.size(), train, val, o.scenes - train - val, test_sets.size(), out.c_str());
}

}  // namespace

void register_sample_dataset(CLI::App& app) {
  auto* cmd = app.add_subcommand("sample-dataset", "Write a WoodScape-layout dataset rendered from street scenes "
                                                   "(images, labels, calibrations)");
  auto o = std::make_shared<Options>();
  cmd->add_option("OUT", o->out, "Output folder (created; existing samples are never replaced)")->required();
  auto* images = cmd->add_option("--images", o->images, "Samples of the bundled street (one camera, mount perturbed)")
                     ->check(CLI::Range(1, 100000));
  auto* scenes = cmd->add_option("--scenes", o->scenes, "Seeded streets seen by --cameras: a surround-view dataset "
                                                        "with train/val/test splits and true viewpoint test sets")
                     ->check(CLI::Range(1, 100000));
  images->excludes(scenes);
  cmd->add_option("--seed", o->seed, "Seed of everything drawn (mount perturbations, scenes, changes)")->required();
  cmd->add_option("--camera", o->camera, "--images: camera file with a pose (default: the bundled WoodScape front camera)")
      ->excludes(scenes);
  cmd->add_option("--cameras", o->cameras, "--scenes: the SynWoodScape cameras (data/synwoodscape_NAME.json)")
      ->capture_default_str()
      ->excludes(images);
  cmd->add_option("--splits", o->splits, "--scenes: train,val,test fractions of the scenes (in scene order)")
      ->capture_default_str()
      ->excludes(images);
  cmd->add_option("--test-sets", o->test_sets, "--scenes: presets of the true viewpoint test sets, or none")
      ->capture_default_str()
      ->excludes(images);
  cmd->add_option("--size", o->size, "Render at WxH or W,H (the same lens, resized; default: the camera's size)");
  cmd->add_option("--supersampling", o->supersampling, "RGB rays per pixel side")->check(CLI::Range(1, 4))->capture_default_str();
  cmd->add_flag("--depth", o->depth, "Also write each sample's range (depth/NAME.npy, float32, metres along the ray)");
  cmd->callback([o] {
    if (o->scenes > 0) return surround_view_dataset(*o);
    if (o->images == 0) o->images = 8;
    bundled_street_dataset(*o);
  });
}

}  // namespace fishcam::cli
