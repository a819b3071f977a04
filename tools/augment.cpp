// fishcam augment SOURCE --image IN ...: one augmented image (and labels).
#include <opencv2/imgcodecs.hpp>

#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/io/npy.hpp"
#include "image_files.hpp"

namespace fishcam::cli {

namespace {

struct AugmentOptions {
  std::string source, target, image, label, out_image, out_label, out_mask, preset,
      method = "viewpoint", sampling = "grid", depth_file, depth_values = "range";
  std::vector<double> affine;
  PoseOptions pose;
  std::uint64_t seed = 0;
  int label_fill = 0;
  bool force = false, json = false;
};

// The change to apply: --preset with --seed (the viewpoint or affine ranges of that
// name), else --rotate/--translate or --affine.
struct AugmentChange {
  ViewpointChange pose;
  AffineChange affine;
};

AugmentChange change_of(const AugmentOptions& o, bool affine) {
  AugmentChange c;
  c.pose = o.preset.empty() ? ViewpointChange{{o.pose.rotate[0], o.pose.rotate[1], o.pose.rotate[2]},
                                              {o.pose.translate[0], o.pose.translate[1], o.pose.translate[2]}}
                            : random_change(pose_preset(o.preset, "--preset"), o.seed);
  if (const auto prior = parse_depth_prior(o.pose.depth); prior && !affine) c.pose = applied_under(c.pose, *prior);
  if (affine && !o.preset.empty()) {
    c.affine = random_affine(affine_preset(o.preset, "--preset"), o.seed);
  } else if (!o.affine.empty()) {
    c.affine = AffineChange{o.affine[0], {o.affine[1], o.affine[2]}, o.affine[3]};
    check_affine(c.affine);
  }
  return c;
}

// What was applied, as text or (--json) one object at full precision.
void print_change(const AugmentOptions& o, const AugmentChange& c, bool affine) {
  const nlohmann::json seed = o.preset.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.seed);
  const nlohmann::json preset = o.preset.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.preset);
  if (affine) {
    nlohmann::json j = affine_to_json(c.affine);
    if (!o.json) {
      std::printf("affine: %s\n", j.dump().c_str());
      return;
    }
    j["seed"] = seed, j["preset"] = preset;
    std::printf("%s\n", j.dump().c_str());
    return;
  }
  if (!o.json) {
    std::printf("pose: %s, depth %s\n", describe(c.pose.rotation_deg, c.pose.translation).c_str(),
                o.pose.depth.c_str());
    return;
  }
  const auto& r = c.pose.rotation_deg;
  const auto& t = c.pose.translation;
  const nlohmann::json j{{"rotation_deg", {r.x(), r.y(), r.z()}},
                         {"translation", {t.x(), t.y(), t.z()}},
                         {"depth", o.pose.depth},
                         {"seed", seed},
                         {"preset", preset}};
  std::printf("%s\n", j.dump().c_str());  // nlohmann writes doubles round-trip exact
}

// --depth map: the maps from the source image's depth map (.npy, H x W float32).
void augment_with_depth_file(const ViewpointWarp& warp, const RigidMotion& change, const AugmentOptions& o,
                             const AugmentIO& io) {
  const NpyArray array = read_npy(o.depth_file);
  const size_t h = size_t(warp.source().height()), w = size_t(warp.source().width());
  if (array.shape != std::vector<size_t>{h, w}) {
    throw Error(path_for_message(o.depth_file) + ": expected a " + std::to_string(h) + " x " + std::to_string(w) +
                " depth map (the source camera's size)");
  }
  const cv::Mat depth(int(h), int(w), CV_32FC1, const_cast<float*>(array.data.data()));
  warp.augment(change, DepthMap{depth, *parse_depth_values(o.depth_values)}, io);
}

void run_augment_command(const AugmentOptions& o, const CameraInputs& inputs, const CLI::App& cmd,
                         bool out_label_given) {
  if (out_label_given && o.label.empty()) throw Error("--out-label needs --label");
  const bool affine = o.method == "affine";
  if (affine) {
    for (const char* option : {"--rotate", "--translate", "--depth", "--target", "--sampling"}) {
      if (cmd.count(option)) throw Error(std::string(option) + ": not used by --method affine (see --affine)");
    }
  } else if (!o.affine.empty()) {
    throw Error("--affine needs --method affine");
  }
  const bool depth_map = o.pose.depth == kDepthMapName;
  if (depth_map && o.depth_file.empty()) throw Error("--depth map needs --depth-file D.npy (the source image's depth)");
  if (!depth_map && (!o.depth_file.empty() || cmd.count("--depth-values"))) {
    throw Error(std::string(o.depth_file.empty() ? "--depth-values" : "--depth-file") + " needs --depth map");
  }
  if (depth_map && cmd.count("--sampling")) throw Error("--sampling: not used by --depth map (its maps are exact)");
  check_outputs({{o.out_image}, {o.out_label, true}, {o.out_mask, true}},
                {o.source, o.target, o.image, o.label, o.depth_file}, o.force);
  const ViewpointWarp warp = make_warp(inputs, o.source, o.target);
  const AugmentChange change = change_of(o, affine);
  const cv::Mat image = read_image(o.image, cv::IMREAD_UNCHANGED);
  cv::Mat labels;
  if (!o.label.empty()) {
    labels = read_image(o.label, cv::IMREAD_UNCHANGED);
    if (labels.channels() != 1) throw Error(path_for_message(o.label) + ": expected a single-channel label image");
  }
  cv::Mat out, out_labels, valid;
  AugmentIO io{&image, &out, 0, nullptr, nullptr, o.label_fill, o.out_mask.empty() ? nullptr : &valid};
  if (!o.out_label.empty()) io.labels = &labels, io.out_labels = &out_labels;
  try {
    if (affine) {
      affine_augment(change.affine, cv::Size(warp.source().width(), warp.source().height()), io);
    } else if (depth_map) {
      augment_with_depth_file(warp, change.pose.motion(), o, io);
    } else {
      warp.augment(change.pose.motion(), o.pose.prior(), io, *parse_sampling(o.sampling));
    }
  } catch (const Error& e) {
    // Which input was wrong: the library names the argument ("image: ...", "labels: ...").
    const std::string what = e.what();
    const bool labels_wrong = what.rfind("labels", 0) == 0 || what.rfind("warp_labels", 0) == 0;
    throw Error(path_for_message(labels_wrong ? o.label : o.image) + ": " + what);
  }
  std::vector<std::pair<std::filesystem::path, cv::Mat>> outputs{{o.out_image, out}};
  if (!o.out_label.empty()) outputs.emplace_back(o.out_label, out_labels);
  if (!o.out_mask.empty()) outputs.emplace_back(o.out_mask, valid * 255);
  write_images(outputs, o.force);
  print_change(o, change, affine);
}

}  // namespace

void register_augment(CLI::App& app) {
  auto* cmd = app.add_subcommand("augment",
                                 "Augment one image (and its labels) with a viewpoint change (or the "
                                 "affine baseline)");
  auto o = std::make_shared<AugmentOptions>();
  cmd->add_option("SOURCE", o->source, "Source camera file")->required();
  cmd->add_option("--image", o->image, "Input image (8/16-bit, 1-4 channels)")->required();
  cmd->add_option("--label", o->label, "Input label image (single channel 8/16-bit)");
  cmd->add_option("--out-image", o->out_image, "Output image")->required();
  auto* out_label = cmd->add_option("--out-label", o->out_label, "Output label image (needs --label)");
  cmd->add_option("--out-mask", o->out_mask, "Output validity mask (255 = has a source inside the source image)");
  add_pose_options(cmd, &o->pose, /*with_depth=*/true, /*with_depth_map=*/true);
  cmd->add_option("--depth-file", o->depth_file,
                  "--depth map: the source image's depth (.npy, H x W float32; units of --translate; inf: sky)");
  cmd->add_option("--depth-values", o->depth_values, "--depth map: what the depth file holds")
      ->check(CLI::IsMember(depth_values_names()))
      ->capture_default_str();
  cmd->add_option("--method", o->method,
                  "viewpoint: the camera-aware augmentation; affine: the paper's baseline (rotation about the image "
                  "centre, translation, scale; no camera model)")
      ->check(CLI::IsMember({"viewpoint", "affine"}))
      ->capture_default_str();
  cmd->add_option("--sampling", o->sampling,
                  "grid: the map at grid nodes, interpolated to within 1/32 px (fast); exact: the per-pixel map")
      ->check(CLI::IsMember(sampling_names()))
      ->capture_default_str();
  auto* affine = cmd->add_option("--affine", o->affine,
                                 "Affine change ROT,TX,TY,SCALE (degrees counter-clockwise, fractions of the image "
                                 "width and height, scale > 0) for --method affine")
                     ->delimiter(',')
                     ->expected(4);
  auto* preset =
      cmd->add_option("--preset", o->preset, "Random change preset (the viewpoint or affine ranges of that name)")
          ->check(CLI::IsMember(pose_preset_names()));
  auto* seed = cmd->add_option("--seed", o->seed, "Seed of the random pose");
  preset->needs(seed);
  seed->needs(preset);
  preset->excludes("--rotate")->excludes("--translate")->excludes(affine);
  cmd->add_option("--target", o->target, "Output camera file (default: the source camera)");
  cmd->add_option("--label-fill", o->label_fill, "Label for pixels without a source (0 = WoodScape background)")
      ->capture_default_str();
  cmd->add_flag("--force", o->force, "Replace existing output files");
  cmd->add_flag("--json", o->json, "Print the applied change as one JSON object (full precision)");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, out_label, cmd, inputs] { run_augment_command(*o, *inputs, *cmd, out_label->count() > 0); });
}

}  // namespace fishcam::cli
