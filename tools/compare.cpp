// fishcam compare CAMERA --models ...: what the projection model used for
// augmentation changes (the paper's Table 5 and Fig. 8), in numbers and pictures.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <numbers>
#include <sstream>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/augment/scene.hpp"
#include "fishcam/eval/comparison.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "image_files.hpp"

namespace fishcam::cli {
namespace {

namespace fs = std::filesystem;

// A name usable in a file name.
std::string file_stem(const std::string& name) {
  std::string out = fs::path(name).stem().string();
  for (char& c : out) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  }
  return out.empty() ? "model" : out;
}

void title(cv::Mat& image, const std::string& text) {
  const double scale = std::clamp(image.cols / 1400.0, 0.5, 2.0);
  cv::putText(image, text, {12, int(30 * scale)}, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), int(4 * scale));
  cv::putText(image, text, {12, int(30 * scale)}, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255),
              int(1.5 * scale));
}

// The paper's Fig. 8: the image on the unit sphere as the camera's model maps it,
// seen from outside (orthographic, from the front-right and above), with circles of
// constant angle of incidence every 30 degrees.
cv::Mat sphere_picture(const Camera& camera, const cv::Mat& image, int size) {
  const Eigen::Vector3d towards_viewer = Eigen::Vector3d(0.9, -0.5, 1.0).normalized();
  const Eigen::Vector3d up_hint(0, -1, 0);  // the camera's y points down
  const Eigen::Vector3d right = up_hint.cross(towards_viewer).normalized();
  const Eigen::Vector3d up = towards_viewer.cross(right);
  cv::Mat map_x(size, size, CV_32FC1, cv::Scalar(-1e5)), map_y(size, size, CV_32FC1, cv::Scalar(-1e5));
  cv::Mat shade(size, size, CV_8UC1, cv::Scalar(0));  // 0: off the sphere, 1: on it, 2: a circle of constant angle
  const double radius = 0.47 * size, centre = (size - 1) / 2.0;
  for (int i = 0; i < size; ++i) {
    for (int j = 0; j < size; ++j) {
      const double sx = (j - centre) / radius, sy = (centre - i) / radius, r2 = sx * sx + sy * sy;
      if (r2 > 1) continue;
      const Eigen::Vector3d p = sx * right + sy * up + std::sqrt(1 - r2) * towards_viewer;
      const double theta = std::acos(std::clamp(p.z(), -1.0, 1.0)) * 180 / std::numbers::pi;
      const double to_circle = std::abs(theta - 30 * std::round(theta / 30));
      shade.at<uchar>(i, j) = to_circle < 0.4 && theta > 1 ? 2 : 1;
      Eigen::Vector2d pixel;
      if (camera.project(p, &pixel)) map_x.at<float>(i, j) = float(pixel.x()), map_y.at<float>(i, j) = float(pixel.y());
    }
  }
  cv::Mat out;
  cv::remap(image, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(200, 200, 200));
  out.setTo(cv::Scalar(255, 255, 255), shade == 0);
  out.setTo(cv::Scalar(40, 40, 40), shade == 2);
  return out;
}

// Mean displacement per output pixel as colours (turbo, 0 .. max; black: never a
// source in both), with the colour scale below.
cv::Mat heatmap(const cv::Mat& displacement, const std::string& name) {
  double max = 0;
  cv::minMaxLoc(displacement, nullptr, &max, nullptr, nullptr, displacement == displacement);  // NaN-free
  max = std::max(max, 1e-6);
  cv::Mat scaled;
  displacement.convertTo(scaled, CV_8UC1, 255.0 / max);
  cv::Mat colours;
  cv::applyColorMap(scaled, colours, cv::COLORMAP_TURBO);
  colours.setTo(cv::Scalar(0, 0, 0), displacement != displacement);
  const int bar = std::max(16, colours.rows / 30);
  cv::Mat legend(bar, colours.cols, CV_8UC1);
  for (int u = 0; u < colours.cols; ++u) legend.col(u).setTo(255 * u / std::max(1, colours.cols - 1));
  cv::Mat legend_colours;
  cv::applyColorMap(legend, legend_colours, cv::COLORMAP_TURBO);
  cv::Mat out;
  cv::vconcat(colours, legend_colours, out);
  char text[160];
  std::snprintf(text, sizeof text, "%s: mean displacement, scale 0 .. %.3g px", name.c_str(), max);
  title(out, text);
  return out;
}

cv::Mat side_by_side(std::vector<cv::Mat> pictures, int width) {
  for (cv::Mat& p : pictures) {
    if (p.channels() == 1) cv::cvtColor(p, p, cv::COLOR_GRAY2BGR);
    if (p.cols != width) cv::resize(p, p, cv::Size(width, p.rows * width / p.cols), 0, 0, cv::INTER_AREA);
  }
  cv::Mat out;
  cv::hconcat(pictures, out);
  return out;
}

struct CompareOptions {
  std::string camera, models = "equidistant,stereographic,kannala-brandt", method = "lsq", preset = "train", image,
                      label, out;
  std::string depth = "source-sphere";
  int samples = 8;
  std::uint64_t seed = 0;
  bool json = false, force = false;
};

// --models as tokens, each with its output name (a file's stem), none twice.
std::vector<std::string> model_tokens(const std::string& models, std::vector<std::string>* names) {
  std::vector<std::string> tokens;
  std::stringstream list(models);
  for (std::string token; std::getline(list, token, ',');) {
    if (token.empty()) throw Error("--models: empty entry in " + quoted_for_message(models));
    tokens.push_back(token);
  }
  if (tokens.empty()) throw Error("--models: no model given");
  for (const std::string& token : tokens) {
    names->push_back(file_stem(token));
    if (std::count(names->begin(), names->end(), names->back()) > 1) {
      throw Error("--models: " + quoted_for_message(token) + " given twice");
    }
  }
  return tokens;
}

// Every output is known before anything is computed: --out (created) must hold no
// input (the camera, the pictures, --models files), files are not replaced unless --force.
void check_compare_outputs(const CompareOptions& o, const std::vector<std::string>& tokens,
                           const std::vector<std::string>& names) {
  std::vector<std::string> input_files{o.camera, o.image, o.label};
  std::error_code ec;
  for (const std::string& token : tokens) {
    if (fs::exists(token, ec)) input_files.push_back(token);
  }
  std::vector<OutputFile> outputs;
  if (!o.out.empty()) {
    check_output_not_input(o.out, {input_files.begin(), input_files.end()}, true);
    fs::create_directories(o.out, ec);
    if (ec) throw Error(path_for_message(o.out) + ": cannot create the folder (" + ec.message() + ")");
    outputs.push_back({fs::path(o.out) / "sphere.png"});
    outputs.push_back({fs::path(o.out) / "augmented.png"});
    for (const std::string& name : names) {
      outputs.push_back({fs::path(o.out) / ("displacement-" + name + ".png")});
      outputs.push_back({fs::path(o.out) / (name + ".json")});
    }
  }
  check_outputs(outputs, input_files, o.force);
}

// The picture the figures show and the label images compared: the scene rendered
// from the camera's mount (or the bundled WoodScape front camera's), or --image and
// --label.
cv::Mat pictures_and_labels(const CompareOptions& o, const Camera& camera, NamedLabels* labels) {
  std::optional<Pose> mount = camera.parameters().pose;
  if (!mount) mount = read_camera(bundled_data("woodscape_front.json")).parameters().pose;
  const SceneRender scene = render_street_scene(camera, *mount);
  labels->emplace_back("scene", scene.labels);
  cv::Mat picture = scene.image;
  const std::string size = std::to_string(camera.width()) + "x" + std::to_string(camera.height());
  if (!o.image.empty()) {
    picture = read_image(o.image, cv::IMREAD_COLOR);
    if (picture.cols != camera.width() || picture.rows != camera.height()) {
      throw Error(path_for_message(o.image) + ": is " + std::to_string(picture.cols) + "x" +
                  std::to_string(picture.rows) + " but the camera is " + size);
    }
  }
  if (!o.label.empty()) {
    const cv::Mat user = read_image(o.label, cv::IMREAD_UNCHANGED);
    if (user.channels() != 1 || user.cols != camera.width() || user.rows != camera.height()) {
      throw Error(path_for_message(o.label) + ": expected single-channel labels of the camera's size " + size);
    }
    labels->emplace_back("user", user);
  }
  return picture;
}

// The figures (Fig. 8's spheres, the first change augmented through every model, a
// displacement heatmap per model) and the alternatives as fishcam JSON, written together.
void write_figures(const CompareOptions& o, const Camera& camera, const std::vector<AlternativeModel>& alternatives,
                   const std::vector<std::string>& names, const Comparison& comparison, const cv::Mat& picture,
                   DepthPrior prior) {
  std::vector<std::pair<fs::path, std::string>> files;
  const int sphere_size = 480;
  std::vector<cv::Mat> spheres, augmented;
  const auto add_model = [&](const Camera& model, const std::string& label) {
    spheres.push_back(sphere_picture(model, picture, sphere_size));
    title(spheres.back(), label);
    WarpMaps maps;
    ViewpointWarp(model).compute(comparison.changes[0].motion(), prior, &maps);
    augmented.emplace_back();
    warp_image(picture, maps, &augmented.back());
    title(augmented.back(), label);
  };
  add_model(camera, std::string(model_name(camera.model())) + " (camera)");
  for (std::size_t m = 0; m < alternatives.size(); ++m) {
    add_model(alternatives[m].camera, alternatives[m].name);
    const fs::path heat = fs::path(o.out) / ("displacement-" + names[m] + ".png");
    files.emplace_back(heat, encode_image(heat, heatmap(comparison.models[m].mean_displacement, alternatives[m].name)));
    files.emplace_back(fs::path(o.out) / (names[m] + ".json"),
                       format_camera(alternatives[m].camera.parameters(), CameraFormat::fishcam));
  }
  const fs::path sphere = fs::path(o.out) / "sphere.png", side = fs::path(o.out) / "augmented.png";
  files.emplace_back(sphere, encode_image(sphere, side_by_side(spheres, sphere_size)));
  files.emplace_back(side, encode_image(side, side_by_side(augmented, std::min(camera.width(), 640))));
  write_files_atomically(files, o.force);
}

void print_comparison(const CompareOptions& o, const Camera& camera, const Comparison& comparison, size_t label_sets) {
  std::printf("%s (%s, %dx%d): %d changes of preset %s (seed %llu), depth %s\n", o.camera.c_str(),
              std::string(model_name(camera.model())).c_str(), camera.width(), camera.height(), o.samples,
              o.preset.c_str(), static_cast<unsigned long long>(o.seed), o.depth.c_str());
  std::printf("displacement (px) between where the two augmentations sample, over pixels with a source in both\n");
  std::printf("%-18s %-24s %8s %9s %8s %8s %8s %7s %7s %7s %7s %9s %8s%s\n", "model", "how", "fit rms", "identity",
              "mean", "p95", "max", "0-30", "30-60", "60-90", ">90", "validity", "labels",
              label_sets > 1 ? "   user labels" : "");
  for (const ModelComparison& r : comparison.models) {
    const AlternativeModel& a = r.alternative;
    char fit[32] = "-";
    if (a.fit_rms_px) std::snprintf(fit, sizeof fit, "%.3f", *a.fit_rms_px);
    std::printf("%-18s %-24s %8s %9.1e %8.3f %8.3f %8.3f", a.name.c_str(), a.how.substr(0, 24).c_str(), fit,
                r.identity_max_px, r.all.mean_px, r.all.p95_px, r.all.max_px);
    for (const DisplacementStats& band : r.by_angle) {
      if (band.pixels > 0) {
        std::printf(" %7.3f", band.mean_px);
      } else {
        std::printf(" %7s", "-");
      }
    }
    std::printf(" %8.3f%% %7.3f%%", r.validity_differs_pct, r.labels_differ_pct[0]);
    if (label_sets > 1) std::printf(" %13.3f%%", r.labels_differ_pct[1]);
    std::printf("\n");
  }
  std::printf(
      "angle bands: mean displacement by the angle of incidence (deg) under the camera; identity: the "
      "unchanged view through both (a check: 0 up to the float maps' 1e-3 px)\n");
  if (!o.out.empty()) std::printf("pictures and the alternatives' cameras in %s\n", o.out.c_str());
}

void run_compare(const CompareOptions& o, const CameraInputs& inputs) {
  const Camera camera = inputs.read(o.camera);
  check_comparison_size(camera.width(), camera.height(), o.samples);  // before rendering anything
  std::vector<std::string> names;
  const std::vector<std::string> tokens = model_tokens(o.models, &names);
  check_compare_outputs(o, tokens, names);
  std::vector<AlternativeModel> alternatives;
  std::error_code ec;
  for (const std::string& token : tokens) {
    alternatives.push_back(fs::is_regular_file(token, ec) ? alternative_from_file(token, inputs.read(token))
                                                          : alternative_model(camera, token, o.method));
  }
  NamedLabels labels;
  const cv::Mat picture = pictures_and_labels(o, camera, &labels);
  ComparisonOptions options;
  options.preset = pose_preset(o.preset, "--preset");
  options.samples = o.samples;
  options.seed = o.seed;
  options.prior = depth_prior(o.depth, "--depth");
  const Comparison comparison = compare_models(camera, alternatives, options, labels);
  if (!o.out.empty()) write_figures(o, camera, alternatives, names, comparison, picture, options.prior);
  if (o.json) {
    std::printf("%s\n", comparison_json(comparison).c_str());
  } else {
    print_comparison(o, camera, comparison, labels.size());
  }
}

}  // namespace

void register_compare(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "compare",
      "Compare augmenting with other projection models of a camera against augmenting with the camera itself "
      "(displacement, validity and labels; the paper's Table 5 and Fig. 8)");
  auto o = std::make_shared<CompareOptions>();
  cmd->add_option("CAMERA", o->camera, "Camera file (the reference: its own model)")->required();
  cmd->add_option("--models", o->models,
                  "Alternatives, comma-separated: model names (fitted to CAMERA as fishcam convert does) or camera "
                  "files")
      ->capture_default_str();
  cmd->add_option("--method", o->method,
                  "lsq: least-squares fits; paper: eqs. 13-14 for equidistant and stereographic (other models are "
                  "still fitted by least squares)")
      ->check(CLI::IsMember(conversion_method_names()))
      ->capture_default_str();
  cmd->add_option("--preset", o->preset, "Viewpoint-change preset")
      ->check(CLI::IsMember(pose_preset_names()))
      ->capture_default_str();
  cmd->add_option("--samples", o->samples, "Seeded viewpoint changes")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the changes")->capture_default_str();
  cmd->add_option("--depth", o->depth, "Depth prior")->check(CLI::IsMember(depth_prior_names()))->capture_default_str();
  auto* image =
      cmd->add_option("--image", o->image, "An image of CAMERA for the pictures (default: the rendered scene)");
  auto* label = cmd->add_option("--label", o->label, "Its label image: label differences are reported for it too");
  label->needs(image);
  cmd->add_option(
      "--out", o->out,
      "Folder (created) for the pictures (sphere.png: Fig. 8; displacement-MODEL.png; augmented.png) and the "
      "alternatives as fishcam JSON (MODEL.json)");
  cmd->add_flag("--json", o->json, "Print the results as JSON");
  cmd->add_flag("--force", o->force, "Replace existing files in --out");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, inputs] { run_compare(*o, *inputs); });
}

}  // namespace fishcam::cli
