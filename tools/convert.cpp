// fishcam convert SOURCE --to MODEL: the best camera of another model, and what it costs.
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <numbers>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/camera_io.hpp"
#include "fishcam/fit.hpp"

namespace fishcam::cli {
namespace {

constexpr double kDeg = 180 / std::numbers::pi;

CameraFormat format_for(const std::string& format, const std::filesystem::path& out) {
  if (!format.empty()) return *parse_camera_format(format);
  const std::string ext = out.extension().string();
  if (ext == ".cameramodel") return CameraFormat::mrcal;
  if (ext == ".yaml" || ext == ".yml" || ext == ".xml") return CameraFormat::opencv;
  if (ext == ".json") return CameraFormat::fishcam;
  throw Error(out.string() + ": cannot tell the format from the extension; pass --format");
}

nlohmann::json report_json(const ErrorReport& r) {
  nlohmann::json bins = nlohmann::json::array();
  for (const auto& b : r.by_angle) {
    bins.push_back({{"theta_from_deg", b.theta_from_deg}, {"theta_to_deg", b.theta_to_deg}, {"samples", b.samples},
                    {"rms_px", b.rms_px}, {"max_px", b.max_px}});
  }
  return {{"samples", r.samples},
          {"unprojectable", r.unprojectable},
          {"rms_px", r.rms_px},
          {"p99_px", r.p99_px},
          {"max_px", r.max_px},
          {"below_90_deg", {{"samples", r.samples_below_90}, {"rms_px", r.rms_below_90_px}, {"max_px", r.max_below_90_px}}},
          {"by_angle", bins}};
}

}  // namespace

void register_convert(CLI::App& app) {
  auto* cmd = app.add_subcommand("convert", "Fit another projection model to a camera and report the pixel error "
                                            "it costs");
  struct Options {
    std::string source, to, method = "lsq", out, format;
    double max_angle = 0;
    bool fit_center = false, fit_aspect = false, json = false, force = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("SOURCE", o->source, "Camera file")->required();
  cmd->add_option("--to", o->to, "Target model: polynomial[:N], equidistant, stereographic, pinhole, kannala-brandt")
      ->required();
  cmd->add_option("--method", o->method, "lsq: least squares over the image's pixels; paper: eqs. 13-14")
      ->check(CLI::IsMember({"lsq", "paper"}))
      ->capture_default_str();
  auto* fit_center = cmd->add_flag("--fit-center", o->fit_center, "Also fit the principal point");
  auto* fit_aspect = cmd->add_flag("--fit-aspect", o->fit_aspect, "Also fit a_y (the aspect)");
  cmd->add_option("--max-angle", o->max_angle, "Fit and report only rays up to this angle of incidence (degrees)")
      ->check(CLI::Range(0.1, 180.0));
  cmd->add_option("--out", o->out, "Output camera file")->required();
  cmd->add_option("--format", o->format, "Output format (default: from the extension; .json = fishcam)")
      ->check(CLI::IsMember({"woodscape", "fishcam", "mrcal", "opencv"}));
  cmd->add_flag("--json", o->json, "Print the report as one JSON object");
  cmd->add_flag("--force", o->force, "Replace an existing output file");
  cmd->callback([o, fit_center, fit_aspect] {
    const auto started = std::chrono::steady_clock::now();
    const Camera source = read_camera(o->source);
    const ModelSpec spec = parse_model_spec(o->to);
    const CameraFormat format = format_for(o->format, o->out);
    const std::optional<double> max_theta = o->max_angle > 0 ? std::optional(o->max_angle / kDeg) : std::nullopt;
    if (o->method == "paper" && (fit_center->count() || fit_aspect->count())) {
      throw Error("--fit-center/--fit-aspect apply to --method lsq only");
    }
    CameraParameters fitted;
    if (o->method == "paper") {
      fitted = paper_camera(source, spec);
    } else {
      // Every 4th pixel, weighted as images are (per pixel).
      fitted = fit_camera(sample_image(source, 4, 1, max_theta), spec, source.parameters(),
                          {o->fit_center, o->fit_aspect});
    }
    const double fit_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    // The report: a denser grid than the fit saw.
    const Camera result(fitted);
    const auto evaluation = sample_image(source, 2, 0, max_theta);
    const ErrorReport report = reprojection_errors(result, evaluation);
    double widest = 0;
    for (const auto& s : evaluation) widest = std::max(widest, std::atan2(s.ray.head<2>().norm(), s.ray.z()));
    std::string warning;
    if (format == CameraFormat::opencv && widest > std::numbers::pi / 2) {
      char buffer[256];
      std::snprintf(buffer, sizeof buffer,
                    "OpenCV's fisheye functions go through the pinhole plane and handle theta < 90 deg only; this "
                    "camera covers %.1f deg (error below 90 deg: rms %.3f px, max %.3f px)",
                    widest * kDeg, report.rms_below_90_px, report.max_below_90_px);
      warning = buffer;
    }
    write_camera(fitted, o->out, format, o->force);
    if (!warning.empty()) std::fprintf(stderr, "fishcam: warning: %s\n", warning.c_str());
    if (o->json) {
      nlohmann::json j = report_json(report);
      j["model"] = model_name(fitted.model);
      j["parameters"] = model_params(fitted.model);
      j["principal_point"] = {fitted.principal_point.x(), fitted.principal_point.y()};
      j["pixel_scale"] = {fitted.pixel_scale.x(), fitted.pixel_scale.y()};
      j["method"] = o->method;
      j["out"] = o->out;
      j["format"] = to_string(format);
      j["fit_ms"] = fit_ms;
      if (!warning.empty()) j["warning"] = warning;
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("%s -> %s (%s), wrote %s (%s)\n", o->source.c_str(), o->to.c_str(), o->method.c_str(), o->out.c_str(),
                std::string(to_string(format)).c_str());
    std::printf("parameters      ");
    for (double p : model_params(fitted.model)) std::printf(" %.10g", p);
    std::printf("\nprincipal point  (%.6f, %.6f), pixel scale (%.10g, %.10g)\n", fitted.principal_point.x(),
                fitted.principal_point.y(), fitted.pixel_scale.x(), fitted.pixel_scale.y());
    std::printf("pixel error over %ld pixels of the source's valid image: rms %.4f, p99 %.4f, max %.4f px", report.samples,
                report.rms_px, report.p99_px, report.max_px);
    if (report.unprojectable) std::printf(" (%ld outside the new model's domain)", report.unprojectable);
    std::printf("\n  theta (deg)   pixels      rms px      max px\n");
    for (const auto& b : report.by_angle) {
      std::printf("  %5.0f-%-5.0f %8ld %11.4f %11.4f\n", b.theta_from_deg, b.theta_to_deg, b.samples, b.rms_px,
                  b.max_px);
    }
  });
}

}  // namespace fishcam::cli
