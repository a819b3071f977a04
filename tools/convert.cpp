// fishcam convert SOURCE --to MODEL: the best camera of another model, and what it costs.
#include <chrono>
#include <cstdio>
#include <numbers>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/fit/fit.hpp"
#include "fishcam/io/camera_io.hpp"
#include "fishcam/io/npy.hpp"

namespace fishcam::cli {
namespace {

constexpr double kDeg = 180 / std::numbers::pi;

// The warning a camera written for OpenCV's fisheye functions needs: they go through
// the pinhole plane, so a camera past 90 degrees is only partly theirs ("" if not).
std::string opencv_range_warning(CameraFormat format, const Conversion& conversion) {
  if (format != CameraFormat::opencv || conversion.widest_theta <= std::numbers::pi / 2) return "";
  char buffer[256];
  std::snprintf(buffer, sizeof buffer,
                "OpenCV's fisheye functions go through the pinhole plane and handle theta < 90 deg only; this "
                "camera covers %.1f deg (error below 90 deg: rms %.3f px, max %.3f px)",
                conversion.widest_theta * kDeg, conversion.report.rms_below_90_px, conversion.report.max_below_90_px);
  return buffer;
}

// --json's object: the fit report and what this run did.
nlohmann::json convert_json(const Camera& source, const Conversion& conversion, const CameraParameters& fitted,
                            const std::string& method, const CameraOutputOptions& output, double fit_ms,
                            const std::string& warning, const std::string& error_map) {
  const Conversion::NonRadial& non_radial = conversion.non_radial;
  nlohmann::json j = nlohmann::json::parse(fit_report_json(fitted, conversion.report));
  j["method"] = method;
  j["out"] = output.out;
  j["format"] = to_string(output.resolved_format());
  j["fit_ms"] = fit_ms;
  if (!warning.empty()) j["warning"] = warning;
  j["center_and_aspect_fitted"] = conversion.center_and_aspect_fitted;
  j["non_radial"] = source.radial() ? nlohmann::json(nullptr)
                                    : nlohmann::json{{"samples", non_radial.samples},
                                                     {"rms_px", non_radial.rms_px},
                                                     {"max_px", non_radial.max_px}};
  if (!error_map.empty()) j["error_map"] = error_map;
  return j;
}

}  // namespace

void register_convert(CLI::App& app) {
  auto* cmd = app.add_subcommand("convert",
                                 "Fit another projection model to a camera and report the pixel error "
                                 "it costs");
  struct Options {
    std::string source, to, method = "lsq", theta_limit, error_map;
    double max_angle = 0;
    bool fit_center = false, fit_aspect = false;
    CameraOutputOptions output;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("SOURCE", o->source, "Camera file")->required();
  cmd->add_option("--to", o->to, "Target model: " + fishcam::model_names_text())->required();
  cmd->add_option("--method", o->method, "lsq: least squares over the image's pixels; paper: eqs. 13-14")
      ->check(CLI::IsMember(conversion_method_names()))
      ->capture_default_str();
  auto* fit_center = cmd->add_flag("--fit-center", o->fit_center, "Also fit the principal point");
  auto* fit_aspect = cmd->add_flag("--fit-aspect", o->fit_aspect, "Also fit a_y (the aspect)");
  cmd->add_option("--max-angle", o->max_angle, "Fit and report only rays up to this angle of incidence (degrees)")
      ->check(CLI::Range(0.1, 180.0));
  add_theta_limit_option(cmd, &o->theta_limit);
  cmd->add_option("--error-map", o->error_map,
                  "Also write the pixel error at every pixel of the source image (H x W float32 .npy, NaN where the "
                  "source has no ray or the new model none)");
  add_camera_output_options(cmd, &o->output);
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, fit_center, fit_aspect, inputs] {
    check_outputs({{o->output.out}, {o->error_map}}, {o->source}, o->output.force);
    const auto started = std::chrono::steady_clock::now();
    const Camera source = inputs->read(o->source);
    const ModelSpec spec = parse_model_spec(o->to);
    const CameraFormat format = o->output.resolved_format();
    std::optional<double> max_theta = o->max_angle > 0 ? std::optional(o->max_angle / kDeg) : std::nullopt;
    // --theta-limit data: the fit, its report and the new camera stop at the observed angles.
    const std::optional<double> data_limit = apply_theta_limit(source.parameters(), o->theta_limit).theta_limit;
    if (!o->theta_limit.empty() && data_limit) max_theta = std::min(max_theta.value_or(*data_limit), *data_limit);
    if (o->method == "paper" && (fit_center->count() || fit_aspect->count())) {
      throw Error("--fit-center/--fit-aspect apply to --method lsq only");
    }
    const Conversion conversion = convert_camera(source, spec, o->method, max_theta, {o->fit_center, o->fit_aspect});
    const double fit_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const CameraParameters fitted = apply_theta_limit(conversion.camera, o->theta_limit);
    const ErrorReport& report = conversion.report;
    const std::string warning = opencv_range_warning(format, conversion);
    write_camera_file(fitted, o->output.out, format, o->output.force);
    if (!o->error_map.empty()) {
      const std::vector<float> map = reprojection_error_map(source, Camera(fitted));
      write_npy(o->error_map, {{size_t(source.height()), size_t(source.width())}, map}, o->output.force);
    }
    const Conversion::NonRadial& non_radial = conversion.non_radial;
    if (!warning.empty()) std::fprintf(stderr, "fishcam: warning: %s\n", warning.c_str());
    if (o->output.json) {
      const nlohmann::json j =
          convert_json(source, conversion, fitted, o->method, o->output, fit_ms, warning, o->error_map);
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("%s -> %s (%s), wrote %s (%s)\n", o->source.c_str(), o->to.c_str(), o->method.c_str(),
                o->output.out.c_str(), std::string(to_string(format)).c_str());
    print_fit_report(fitted, report, "pixels of the source's valid image");
    if (!source.radial()) {
      std::printf(
          "the source is not radially symmetric (principal point and a_y were fitted): about them no radial "
          "model gets below rms %.4f px (max %.4f px), the error of the best free-form rho(theta)\n",
          non_radial.rms_px, non_radial.max_px);
    }
    if (!o->error_map.empty()) std::printf("wrote %s (pixel error per pixel)\n", o->error_map.c_str());
  });
}

}  // namespace fishcam::cli
