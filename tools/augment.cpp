// fishcam augment SOURCE --image IN ...: one augmented image (and labels).
#include <opencv2/imgcodecs.hpp>

#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"

namespace fishcam::cli {

void register_augment(CLI::App& app) {
  auto* cmd = app.add_subcommand("augment", "Augment one image (and its labels) with a viewpoint change (or the "
                                            "affine baseline)");
  struct Options {
    std::string source, target, image, label, out_image, out_label, out_mask, preset, method = "viewpoint",
                                                                                 sampling = "grid";
    std::vector<double> affine;
    PoseOptions pose;
    std::uint64_t seed = 0;
    int label_fill = 0;
    bool force = false, json = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("SOURCE", o->source, "Source camera file")->required();
  cmd->add_option("--image", o->image, "Input image (8/16-bit, 1-4 channels)")->required();
  cmd->add_option("--label", o->label, "Input label image (single channel 8/16-bit)");
  cmd->add_option("--out-image", o->out_image, "Output image")->required();
  auto* out_label = cmd->add_option("--out-label", o->out_label, "Output label image (needs --label)");
  cmd->add_option("--out-mask", o->out_mask, "Output validity mask (255 = has a source inside the source image)");
  add_pose_options(cmd, &o->pose);
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
  auto* preset = cmd->add_option("--preset", o->preset, "Random change preset (the viewpoint or affine ranges of that name)")
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
  cmd->callback([o, out_label, cmd, inputs] {
    if (out_label->count() && o->label.empty()) throw Error("--out-label needs --label");
    const bool affine = o->method == "affine";
    if (affine) {
      for (const char* option : {"--rotate", "--translate", "--depth", "--target", "--sampling"}) {
        if (cmd->count(option)) throw Error(std::string(option) + ": not used by --method affine (see --affine)");
      }
    } else if (!o->affine.empty()) {
      throw Error("--affine needs --method affine");
    }
    check_outputs({{o->out_image}, {o->out_label, true}, {o->out_mask}}, {o->source, o->target, o->image, o->label},
                  o->force);
    const ViewpointWarp warp = make_warp(*inputs, o->source, o->target);
    const RandomPose pose = o->preset.empty() ? RandomPose{{o->pose.rotate[0], o->pose.rotate[1], o->pose.rotate[2]},
                                                           {o->pose.translate[0], o->pose.translate[1], o->pose.translate[2]}}
                                              : random_pose(pose_preset(o->preset, "--preset"), o->seed);
    AffineChange affine_change;
    if (affine && !o->preset.empty()) {
      affine_change = random_affine(affine_preset(o->preset, "--preset"), o->seed);
    } else if (!o->affine.empty()) {
      affine_change = AffineChange{o->affine[0], {o->affine[1], o->affine[2]}, o->affine[3]};
      check_affine(affine_change);
    }
    const cv::Mat image = read_image(o->image, cv::IMREAD_UNCHANGED);
    cv::Mat labels;
    if (!o->label.empty()) {
      labels = read_image(o->label, cv::IMREAD_UNCHANGED);
      if (labels.channels() != 1) throw Error(o->label + ": expected a single-channel label image");
    }
    cv::Mat out, out_labels, valid;
    AugmentIO io{&image, &out, 0, nullptr, nullptr, o->label_fill, o->out_mask.empty() ? nullptr : &valid};
    if (!o->out_label.empty()) io.labels = &labels, io.out_labels = &out_labels;
    try {
      if (affine) {
        affine_augment(affine_change, cv::Size(warp.source().width(), warp.source().height()), io);
      } else {
        warp.augment(pose.change(), o->pose.prior(), io, *parse_sampling(o->sampling));
      }
    } catch (const Error& e) {
      // Which input was wrong: the library names the argument ("image: ...", "labels: ...").
      const std::string what = e.what();
      throw Error((what.rfind("labels", 0) == 0 || what.rfind("warp_labels", 0) == 0 ? o->label : o->image) + ": " +
                  what);
    }
    std::vector<std::pair<std::filesystem::path, cv::Mat>> outputs{{o->out_image, out}};
    if (!o->out_label.empty()) outputs.emplace_back(o->out_label, out_labels);
    if (!o->out_mask.empty()) outputs.emplace_back(o->out_mask, valid * 255);
    write_images(outputs, o->force);
    const nlohmann::json seed_json = o->preset.empty() ? nlohmann::json(nullptr) : nlohmann::json(o->seed);
    const nlohmann::json preset_json = o->preset.empty() ? nlohmann::json(nullptr) : nlohmann::json(o->preset);
    if (affine) {
      const nlohmann::json j = affine_to_json(affine_change);
      if (o->json) {
        nlohmann::json out = j;
        out["seed"] = seed_json, out["preset"] = preset_json;
        std::printf("%s\n", out.dump().c_str());
      } else {
        std::printf("affine: %s\n", j.dump().c_str());
      }
      return;
    }
    if (o->json) {
      const auto& r = pose.rotation_deg;
      const auto& t = pose.translation;
      nlohmann::json j{{"rotation_deg", {r.x(), r.y(), r.z()}},
                       {"translation", {t.x(), t.y(), t.z()}},
                       {"depth", o->pose.depth},
                       {"seed", seed_json},
                       {"preset", preset_json}};
      std::printf("%s\n", j.dump().c_str());  // nlohmann writes doubles round-trip exact
      return;
    }
    std::printf("pose: %s, depth %s\n", describe(pose.rotation_deg, pose.translation).c_str(), o->pose.depth.c_str());
  });
}

}  // namespace fishcam::cli
