// fishcam uncertainty CAMERA: projection uncertainty of a calibrated camera (mrcal's
// definition), over the image and where the calibration observed corners.
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/eval/calibration_report.hpp"

namespace fishcam::cli {
namespace {

struct Summary {
  long pixels = 0;
  double median = std::nan(""), p95 = std::nan(""), max = std::nan("");
};

Summary summarise(std::vector<double> values) {
  Summary s;
  s.pixels = long(values.size());
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  const auto at = [&](double q) { return values[size_t(q * double(values.size() - 1))]; };
  s.median = at(0.5), s.p95 = at(0.95), s.max = values.back();
  return s;
}

nlohmann::json summary_json(const Summary& s) {
  const auto number = [](double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); };
  return {{"pixels", s.pixels}, {"median_px", number(s.median)}, {"p95_px", number(s.p95)}, {"max_px", number(s.max)}};
}

}  // namespace

void register_uncertainty(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "uncertainty",
      "Projection uncertainty of a calibration (as mrcal defines it): the 1-sigma spread, in the worst "
      "direction, of where a point seen at a pixel projects, given the calibration's corner noise");
  struct Options {
    std::string camera, out;
    double distance = 0, max_px = 0;
    bool infinity = false, json = false, force = false;
    int step = 4;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("CAMERA", o->camera, "A camera written by fishcam calibrate (fishcam JSON)")->required();
  auto* distance = cmd->add_option("--distance", o->distance, "The point's distance along the ray (board units, m)")
                       ->check(CLI::PositiveNumber);
  auto* infinity = cmd->add_flag("--infinity", o->infinity, "A point at infinity (the default): rotations only");
  distance->excludes(infinity);
  cmd->add_option("--step", o->step, "Evaluate every STEP-th pixel")->check(CLI::Range(1, 256))->capture_default_str();
  cmd->add_option("--out", o->out, "Heatmap image (PNG): black = no ray, dimmed = outside the observed angles");
  cmd->add_option("--max-px", o->max_px,
                  "The heatmap's top colour (px; default: the largest value over the "
                  "observed angles)")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--json", o->json, "Print one JSON object");
  cmd->add_flag("--force", o->force, "Replace an existing output file");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, distance, inputs] {
    if (!o->out.empty()) check_outputs({{o->out}}, {o->camera}, o->force);
    const Camera camera = inputs->read(o->camera);
    const std::optional<double> d = distance->count() ? std::optional(o->distance) : std::nullopt;
    const double at_centre =
        projection_uncertainty(camera, camera.principal_point(), d);  // throws without a covariance
    const UncertaintyMap map = uncertainty_map(camera, o->step, d);
    const Summary all = summarise(map.everywhere), data = summarise(map.in_data);
    if (!o->out.empty()) {
      const double top = o->max_px > 0 ? o->max_px : (std::isnan(data.max) ? all.max : data.max);
      write_image(o->out, uncertainty_heatmap(map, top, camera.width(), camera.height()), o->force);
    }
    if (o->json) {
      const nlohmann::json j = {{"point", d ? nlohmann::json({{"distance", *d}}) : nlohmann::json("infinity")},
                                {"step", o->step},
                                {"at_principal_point_px", at_centre},
                                {"observed", summary_json(data)},
                                {"valid_image", summary_json(all)},
                                {"out", o->out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o->out)}};
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("projection uncertainty (worst-direction 1-sigma) of a point %s:\n",
                d ? ("at " + std::to_string(*d) + " along the ray").c_str() : "at infinity");
    std::printf("  at the principal point   %.4f px\n", at_centre);
    std::printf("  observed angles          median %.4f, p95 %.4f, max %.4f px (%ld pixels)\n", data.median, data.p95,
                data.max, data.pixels);
    std::printf("  whole valid image        median %.4f, p95 %.4f, max %.4f px (%ld pixels)\n", all.median, all.p95,
                all.max, all.pixels);
    if (!o->out.empty()) std::printf("wrote %s\n", o->out.c_str());
  });
}

}  // namespace fishcam::cli
