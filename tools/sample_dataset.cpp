// fishcam sample-dataset OUT: WoodScape-layout datasets rendered from street scenes.
// --images N: the bundled street through one camera at seeded perturbations of its
// mount (a few degrees, a few centimetres): what the Python example and tests use.
// --scenes N: a synthetic surround-view dataset, one seeded street per scene seen
// by the SynWoodScape cameras, split into train/val/test by scene, with true
// viewpoint test sets: the test scenes re-rendered from cameras moved by changes of
// the small/medium/large presets (docs/experiment.md).
#include <nlohmann/json.hpp>

#include <array>
#include <charconv>
#include <cstdio>
#include <functional>
#include <map>
#include <optional>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/augment/scene.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/npy.hpp"
#include "fishcam/io/output_settings.hpp"

namespace fishcam::cli {
namespace {

namespace fs = std::filesystem;

// The folders of one WoodScape-layout root.
void make_layout(const fs::path& root, bool depth) {
  for (const char* sub : {"rgb_images", "semantic_annotations/gtLabels", "calibration"})
    fs::create_directories(root / sub);
  if (depth) fs::create_directories(root / "depth");
}

// The files of one sample: image, labels, calibration, optionally the range (.npy).
std::vector<fs::path> sample_files(const fs::path& root, const std::string& name, bool depth) {
  std::vector<fs::path> files{root / "rgb_images" / (name + ".png"),
                              root / "semantic_annotations" / "gtLabels" / (name + ".png"),
                              root / "calibration" / (name + ".json")};
  if (depth) files.push_back(root / "depth" / (name + ".npy"));
  return files;
}

// Where a run writes, in two passes over the same loop: the first (check) looks at
// every sample's files before anything is written, the second (write) renders and
// writes the samples not already there. A sample's files land together, so a sample
// whose files all exist in a folder this command's settings record claims is done
// (a resume); any other existing file is not this run's and is refused in the first
// pass, before anything is written.
class SampleWriter {
 public:
  SampleWriter(bool depth, bool resuming) : depth_(depth), resuming_(resuming) {}
  void start_writing() { writing_ = true; }
  bool writing() const { return writing_; }

  template <class Render>
  void sample(const fs::path& root, const std::string& name, const CameraParameters& camera, const Render& render) {
    const std::vector<fs::path> files = sample_files(root, name, depth_);
    std::size_t existing = 0;
    std::error_code ec;
    for (const fs::path& file : files) existing += fs::exists(fs::symlink_status(file, ec));
    // In a folder this run's settings claim, a sample's files are this run's: complete
    // (skipped), or cut by a kill between the renames of its files (written again).
    if (!writing_) {
      if (existing > 0 && !resuming_ && foreign_++ == 0) first_foreign_ = files[0];
      return;
    }
    if (existing == files.size()) {
      ++skipped_;
      return;
    }
    const SceneRender r = render();
    std::vector<std::pair<fs::path, std::string>> contents = {
        {files[0], encode_image(files[0], r.image)},
        {files[1], encode_image(files[1], r.labels)},
        {files[2], format_camera(camera, CameraFormat::woodscape)}};
    if (depth_) {
      NpyArray range{{size_t(r.range.rows), size_t(r.range.cols)}, {}};
      range.data.assign(r.range.begin<float>(), r.range.end<float>());
      contents.emplace_back(files[3], npy_bytes(range, files[3].string()));
    }
    write_files_atomically(contents, resuming_ && existing > 0);
    ++written_;
  }

  // After the check pass: refuses files this run did not write.
  void check() const {
    if (foreign_ == 0) return;
    throw Error(path_for_message(first_foreign_) + ": exists and is not a sample of a run with these settings (" +
                std::to_string(foreign_) + " such sample(s)); nothing written (use another OUT)");
  }
  long written() const { return written_; }
  long skipped() const { return skipped_; }

 private:
  bool depth_, resuming_, writing_ = false;
  std::size_t foreign_ = 0;
  fs::path first_foreign_;
  long written_ = 0, skipped_ = 0;
};

// One line of a test set's changes.jsonl.
std::string change_line(const std::string& name, const PosePreset& preset, std::uint64_t seed,
                        const ViewpointChange& change) {
  const auto& r = change.rotation_deg;
  const auto& t = change.translation;
  return nlohmann::json{{"name", name},
                        {"preset", preset.name},
                        {"seed", seed},
                        {"rotation_deg", {r.x(), r.y(), r.z()}},
                        {"translation", {t.x(), t.y(), t.z()}}}
             .dump() +
         "\n";
}

Camera sized(Camera camera, const std::string& size) {
  if (size.empty()) return camera;
  const auto [width, height] = parse_image_size(size, "--size");
  if (width < 16 || height < 16 || width > 8192 || height > 8192)
    throw Error("--size: expected 16 to 8192 pixels per side");
  return Camera(resized(camera.parameters(), width, height));
}

struct Options {
  std::string out, camera, size, cameras = "FV,MVL,MVR,RV", splits = "0.7,0.15,0.15", test_sets = "small,medium,large";
  // The paper protocol's label where the augmentation has no source: the paper's
  // "empty values" (0, WoodScape's void class) or "ignore" (255, left out of training
  // and scoring).
  std::string paper_label_fill = "0";
  int images = 0, scenes = 0, supersampling = 2;
  std::uint64_t seed = 0;
  bool depth = false;
};

int paper_label_fill(const std::string& text) {
  if (text == "ignore") return 255;
  int value = -1;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < 0 || value > 255) {
    throw Error("--paper-label-fill: expected a label 0 to 255 or 'ignore', got " + quoted_for_message(text));
  }
  return value;
}

// Everything the samples depend on, recorded in OUT/sample-dataset.json.
OutputSettings settings_of(const Options& o, const fs::path& camera_path) {
  OutputSettings settings{"sample-dataset",
                          {{"--seed", std::to_string(o.seed)},
                           {"--size", o.size},
                           {"--supersampling", std::to_string(o.supersampling)},
                           {"--depth", o.depth ? "yes" : "no"}}};
  if (o.scenes > 0) {
    settings.values.insert(settings.values.end(), {{"--scenes", std::to_string(o.scenes)},
                                                   {"--cameras", o.cameras},
                                                   {"--splits", o.splits},
                                                   {"--test-sets", o.test_sets},
                                                   {"--paper-label-fill", o.paper_label_fill}});
  } else {
    settings.values.insert(settings.values.end(),
                           {{"--images", std::to_string(o.images)},
                            {"--camera", fs::weakly_canonical(fs::absolute(camera_path)).string()}});
  }
  return settings;
}

// Checks OUT's settings record (or that OUT holds none of this run's files, the
// manifests of --scenes included), records the settings, then writes the samples not
// already there. Returns how many were there.
template <class Loop>
long write_samples(const fs::path& out, const OutputSettings& settings, bool depth,
                   const std::vector<fs::path>& manifests, const Loop& loop) {
  const fs::path record = out / "sample-dataset.json";
  const bool resuming = claim_output_settings(record, settings, false);
  SampleWriter writer(depth, resuming);
  loop(writer);
  writer.check();
  std::error_code ec;
  for (const fs::path& manifest : manifests) {
    if (!resuming && fs::exists(fs::symlink_status(manifest, ec))) {
      throw Error(path_for_message(manifest) +
                  ": exists and is not a run's with these settings; nothing written (use "
                  "another OUT)");
    }
  }
  fs::create_directories(out);
  claim_output_settings(record, settings, true);
  writer.start_writing();
  loop(writer);
  return writer.skipped();
}

void bundled_street_dataset(const Options& o) {
  const fs::path camera_path = o.camera.empty() ? bundled_data("woodscape_front.json") : fs::path(o.camera);
  const Camera camera = sized(read_camera(camera_path), o.size);
  if (!camera.parameters().pose) throw Error(camera_path.string() + ": has no pose to place it in the scene");
  const fs::path out = o.out;
  check_output_not_input(out, {camera_path}, true);
  // Mount perturbations: up to 3 degrees about each axis, 5 cm along each.
  const PosePreset mount{"mount", 3.0, 0.05};
  const long skipped = write_samples(out, settings_of(o, camera_path), o.depth, {}, [&](SampleWriter& writer) {
    if (writer.writing()) make_layout(out, o.depth);
    for (int i = 0; i < o.images; ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "%05d_FV", i);
      const ViewpointChange perturbation =
          random_change(mount, derive_seed(o.seed, "sample-dataset", std::uint64_t(i)));
      CameraParameters p = camera.parameters();
      p.pose = moved_camera(*p.pose, perturbation.motion());
      writer.sample(out, name, p, [&] { return StreetScene::bundled().render(camera, *p.pose, o.supersampling); });
    }
  });
  std::printf("wrote %ld samples (%dx%d) to %s%s\n", o.images - skipped, camera.width(), camera.height(), out.c_str(),
              skipped > 0 ? (" (" + std::to_string(skipped) + " already there)").c_str() : "");
}

// --splits TRAIN,VAL,TEST: three fractions >= 0 that sum to 1.
std::array<double, 3> split_shares(const std::string& splits) {
  const std::vector<std::string> fractions = split_commas(splits);
  std::array<double, 3> share{};
  if (fractions.size() != 3) throw Error("--splits: expected TRAIN,VAL,TEST fractions, got '" + splits + "'");
  for (size_t k = 0; k < 3; ++k) {
    const char* begin = fractions[k].data();
    const auto [end, error] = std::from_chars(begin, begin + fractions[k].size(), share[k]);
    if (error != std::errc() || end != begin + fractions[k].size()) {
      throw Error("--splits: '" + fractions[k] + "' is not a number");
    }
  }
  if (!(share[0] >= 0 && share[1] >= 0 && share[2] >= 0 && std::abs(share[0] + share[1] + share[2] - 1) < 1e-9)) {
    throw Error("--splits: expected three fractions >= 0 that sum to 1, got '" + splits + "'");
  }
  return share;
}

// What one --scenes run writes, and what its sample loop shares (write_samples runs the
// loop twice: once to see what is there, once to write).
struct SurroundViewRun {
  const Options& o;
  fs::path out;
  std::vector<std::pair<std::string, Camera>> cameras = {};
  std::vector<PosePreset> test_sets = {};
  int train = 0, val = 0;
  int label_fill = 0;
  std::string scenes_manifest = {};
  std::map<std::string, std::string> changes = {};  // test set -> its changes.jsonl
  // The paper protocol's camera per camera name, as its calibration file holds it (what
  // augment-dataset reads), and its warp.
  std::map<std::string, std::pair<CameraParameters, ViewpointWarp>> paper_cameras = {};

  const char* split_of(int k) const { return k < train ? "train" : k < train + val ? "val" : "test"; }

  std::vector<fs::path> manifest_paths() const {
    std::vector<fs::path> paths{out / "scenes.jsonl"};
    for (const PosePreset& preset : test_sets) {
      for (const char* suffix : {"", "-rotation", "-paper"}) {
        paths.push_back(out / ("test-" + std::string(preset.name) + suffix) / "changes.jsonl");
      }
    }
    return paths;
  }

  void make_folders() const {
    for (const char* split : {"train", "val", "test"}) make_layout(out / split, o.depth);
    for (const PosePreset& preset : test_sets) {
      for (const char* suffix : {"", "-rotation", "-paper"}) {
        make_layout(out / ("test-" + std::string(preset.name) + suffix), o.depth);
      }
    }
  }

  void write(SampleWriter& writer) {
    if (writer.writing()) make_folders();
    scenes_manifest.clear();
    changes.clear();
    int samples = 0;
    for (int k = 0; k < o.scenes; ++k) {
      const std::uint64_t scene_seed = derive_seed(o.seed, "scene", std::uint64_t(k));
      std::optional<StreetScene> scene;  // generated when a sample of it is rendered
      const std::function<const StreetScene&()> scene_of = [&]() -> const StreetScene& {
        if (!scene) scene = StreetScene::generate(scene_seed);
        return *scene;
      };
      const std::string split = split_of(k);
      for (const auto& entry : cameras) {
        // Named, not structured bindings: lambdas below capture them (clang 14 refuses bindings).
        const std::string& camera_name = entry.first;
        const Camera& camera = entry.second;
        char name[48];
        std::snprintf(name, sizeof name, "%05d_%s", k, camera_name.c_str());
        const CameraParameters& p = camera.parameters();
        std::optional<SceneRender> original;  // rendered once for the split and the paper protocol
        const std::function<const SceneRender&()> original_of = [&]() -> const SceneRender& {
          if (!original) original = scene_of().render(camera, *p.pose, o.supersampling);
          return *original;
        };
        writer.sample(out / split, name, p, original_of);
        scenes_manifest +=
            nlohmann::json{{"name", name}, {"split", split}, {"scene_seed", scene_seed}, {"camera", camera_name}}
                .dump() +
            "\n";
        ++samples;
        if (split == std::string("test")) write_test_sets(writer, name, entry, samples, scene_of, original_of);
      }
    }
  }

  // The true viewpoint test sets of one test sample: the camera really moved (t read as
  // metres), and the same change without its translation; and the paper's protocol.
  void write_test_sets(SampleWriter& writer, const std::string& name, const std::pair<std::string, Camera>& entry,
                       int samples, const std::function<const StreetScene&()>& scene_of,
                       const std::function<const SceneRender&()>& original_of) {
    const Camera& camera = entry.second;
    const CameraParameters& p = camera.parameters();
    for (const PosePreset& preset : test_sets) {
      const std::string set = "test-" + std::string(preset.name);
      const std::uint64_t seed = derive_seed(o.seed, set, std::uint64_t(samples));
      const ViewpointChange full = random_change(preset, seed);
      ViewpointChange rotation = full;
      rotation.translation.setZero();
      for (const auto& [folder, change] : {std::pair{set, full}, std::pair{set + "-rotation", rotation}}) {
        CameraParameters moved = p;
        moved.pose = moved_camera(*p.pose, change.motion());
        writer.sample(out / folder, name, moved,
                      [&] { return scene_of().render(camera, *moved.pose, o.supersampling); });
        changes[folder] += change_line(name, preset, seed, change);
      }
      write_paper_sample(writer, set + "-paper", name, entry, full, original_of);
      changes[set + "-paper"] += change_line(name, preset, seed, full);
    }
  }

  // The paper's protocol: the original test image augmented by the same change
  // (source-sphere prior, the translation in the sphere's units), as
  // augment-dataset --depth source-sphere --sampling grid --label-fill FILL writes it.
  void write_paper_sample(SampleWriter& writer, const std::string& folder, const std::string& name,
                          const std::pair<std::string, Camera>& entry, const ViewpointChange& full,
                          const std::function<const SceneRender&()>& original_of) {
    auto as_written = paper_cameras.find(entry.first);
    if (as_written == paper_cameras.end()) {
      const CameraParameters read_back =
          parse_camera(format_camera(entry.second.parameters(), CameraFormat::woodscape), name);
      as_written = paper_cameras.emplace(entry.first, std::pair{read_back, ViewpointWarp(Camera(read_back))}).first;
    }
    const ViewpointWarp& warp = as_written->second.second;
    writer.sample(out / folder, name, augmented_camera(as_written->second.first, full.motion()), [&] {
      const SceneRender& source = original_of();
      SceneRender augmented;
      const AugmentIO io{&source.image, &augmented.image, 0, &source.labels, &augmented.labels, label_fill, nullptr};
      warp.augment(full.motion(), DepthPrior::source_sphere, io, Sampling::grid);
      if (o.depth) {
        warp.warp_depth(full.motion(), DepthPrior::source_sphere, source.range, DepthValues::range, &augmented.range);
      }
      return augmented;
    });
  }
};

void surround_view_dataset(const Options& o) {
  SurroundViewRun run{.o = o, .out = o.out};
  std::vector<fs::path> inputs;
  for (const std::string& name : distinct_names(o.cameras, "--cameras")) {
    const fs::path path = bundled_data("synwoodscape_" + name + ".json");
    run.cameras.emplace_back(name, sized(read_camera(path), o.size));
    inputs.push_back(path);
  }
  if (run.cameras.empty()) throw Error("--cameras: expected camera names such as FV,MVL,MVR,RV");
  check_output_not_input(run.out, inputs, true);
  const std::array<double, 3> share = split_shares(o.splits);
  run.train = int(std::lround(share[0] * o.scenes)), run.val = int(std::lround(share[1] * o.scenes));
  if (o.test_sets != "none") {
    for (const std::string& name : distinct_names(o.test_sets, "--test-sets")) {
      run.test_sets.push_back(pose_preset(name, "--test-sets"));
    }
  }
  run.label_fill = paper_label_fill(o.paper_label_fill);
  const fs::path& out = run.out;
  const bool resuming = claim_output_settings(out / "sample-dataset.json", settings_of(o, {}), false);
  const long skipped = write_samples(out, settings_of(o, {}), o.depth, run.manifest_paths(),
                                     [&](SampleWriter& writer) { run.write(writer); });
  // The manifests describe every sample (those of an earlier, interrupted run of the
  // same settings too): written last, replacing only a resumed run's own.
  std::vector<std::pair<fs::path, std::string>> manifests = {{out / "scenes.jsonl", run.scenes_manifest}};
  for (const auto& [folder, text] : run.changes) manifests.emplace_back(out / folder / "changes.jsonl", text);
  write_outputs(manifests, resuming);
  std::printf(
      "wrote %d scenes x %zu cameras (%d train, %d val, %d test scenes; %zu true viewpoint test sets) to %s%s\n",
      o.scenes, run.cameras.size(), run.train, run.val, o.scenes - run.train - run.val, run.test_sets.size(),
      out.c_str(), skipped > 0 ? (" (" + std::to_string(skipped) + " samples already there)").c_str() : "");
}

}  // namespace

void register_sample_dataset(CLI::App& app) {
  auto* cmd = app.add_subcommand("sample-dataset",
                                 "Write a WoodScape-layout dataset rendered from street scenes "
                                 "(images, labels, calibrations)");
  auto o = std::make_shared<Options>();
  cmd->add_option("OUT", o->out, "Output folder (created; existing samples are never replaced)")->required();
  auto* images = cmd->add_option("--images", o->images, "Samples of the bundled street (one camera, mount perturbed)")
                     ->check(CLI::Range(1, 100000));
  auto* scenes = cmd->add_option("--scenes", o->scenes,
                                 "Seeded streets seen by --cameras: a surround-view dataset "
                                 "with train/val/test splits and true viewpoint test sets")
                     ->check(CLI::Range(1, 100000));
  images->excludes(scenes);
  cmd->add_option("--seed", o->seed, "Seed of everything drawn (mount perturbations, scenes, changes)")->required();
  cmd->add_option("--camera", o->camera,
                  "--images: camera file with a pose (default: the bundled WoodScape front camera)")
      ->excludes(scenes);
  cmd->add_option("--cameras", o->cameras, "--scenes: the SynWoodScape cameras (data/synwoodscape_NAME.json)")
      ->capture_default_str()
      ->excludes(images);
  cmd->add_option("--splits", o->splits, "--scenes: train,val,test fractions of the scenes (in scene order)")
      ->capture_default_str()
      ->excludes(images);
  cmd->add_option("--test-sets", o->test_sets,
                  "--scenes: presets of the true viewpoint test sets (test-PRESET/, test-PRESET-rotation/ and the "
                  "paper's protocol test-PRESET-paper/), or none")
      ->capture_default_str()
      ->excludes(images);
  cmd->add_option("--size", o->size, "Render at WxH or W,H (the same lens, resized; default: the camera's size)");
  cmd->add_option("--supersampling", o->supersampling, "RGB rays per pixel side")
      ->check(CLI::Range(1, 4))
      ->capture_default_str();
  cmd->add_flag("--depth", o->depth, "Also write each sample's range (depth/NAME.npy, float32, metres along the ray)");
  cmd->add_option("--paper-label-fill", o->paper_label_fill,
                  "--scenes: the label of pixels without a source in the paper-protocol test sets "
                  "(test-PRESET-paper/): 0, the paper's empty value (WoodScape's void class), another label, "
                  "or ignore (255)")
      ->capture_default_str()
      ->excludes(images);
  cmd->callback([o] {
    if (o->out.empty()) throw Error("OUT: expected a folder, got ''");
    if (o->scenes > 0) return surround_view_dataset(*o);
    if (o->images == 0) o->images = 8;
    bundled_street_dataset(*o);
  });
}

}  // namespace fishcam::cli
