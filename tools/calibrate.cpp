// fishcam calibrate: intrinsics and board poses from chessboard corners.
#include <fnmatch.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <set>
#include <sstream>
#include <thread>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/fit/calibration.hpp"
#include "fishcam/io/corners.hpp"
#include "report_folder.hpp"

namespace fishcam::cli {
namespace {

// --images PATTERN[,PATTERN...]: the observations whose file name (as the corners
// file gives it, or its last component) matches one of the shell patterns
// (fnmatch); a pattern that matches nothing is an error (a typo must not calibrate
// from fewer images than meant).
std::vector<BoardObservation> select_images(std::vector<BoardObservation> all, const std::string& list) {
  const std::vector<std::string> patterns = split_commas(list);
  if (patterns.empty()) throw Error("--images: no pattern given");
  for (const auto& p : patterns) {
    if (p.empty()) throw Error("--images: empty pattern in '" + list + "'");
  }
  std::set<std::string> unmatched(patterns.begin(), patterns.end());
  std::vector<BoardObservation> kept;
  for (auto& o : all) {
    bool match = false;
    for (const auto& p : patterns) {
      const std::string name = std::filesystem::path(o.filename).filename().string();
      if (fnmatch(p.c_str(), o.filename.c_str(), 0) == 0 || fnmatch(p.c_str(), name.c_str(), 0) == 0) {
        match = true, unmatched.erase(p);
      }
    }
    if (match) kept.push_back(std::move(o));
  }
  if (!unmatched.empty()) throw Error("--images: '" + *unmatched.begin() + "' matches no image of the corners file");
  return kept;
}

struct CalibrateOptions {
  std::vector<std::string> corners, imagersize, fix_intrinsics;
  std::string board, target, model, images, poses, theta_limit, report, board_warp = "on";
  double spacing = 0;
  int threads = int(std::max(1u, std::thread::hardware_concurrency()));
  CameraOutputOptions output;
};

// One value for every camera, or one per camera.
std::vector<std::string> per_camera(const std::vector<std::string>& given, size_t cameras, const char* option) {
  if (given.size() == 1) return std::vector<std::string>(cameras, given[0]);
  if (given.size() != cameras) {
    throw Error(std::string(option) + ": give one value, or one per camera (" + std::to_string(cameras) + "), not " +
                std::to_string(given.size()));
  }
  return given;
}

// calibrate with several --corners: a rig (fishcam::calibrate_rig), written as one
// file in a format that holds rigs.
void calibrate_rig_command(const CalibrateOptions& o, const BoardSpec& board) {
  const size_t n = o.corners.size();
  const CameraFormat format = o.output.resolved_format();
  if (!camera_format_holds_rig(format)) format_rig({}, format);  // the one-line refusal, before any work
  const auto models = per_camera(split_commas(o.model), n, "--model");
  const auto sizes = per_camera(o.imagersize, n, "--imagersize");
  std::vector<RigCamera> cameras(n);
  for (size_t k = 0; k < n; ++k) {
    cameras[k].model = parse_model_spec(models[k]);
    std::tie(cameras[k].width, cameras[k].height) = parse_image_size(sizes[k], "--imagersize");
    cameras[k].observations = read_corners(o.corners[k], board);
    if (!o.images.empty()) cameras[k].observations = select_images(std::move(cameras[k].observations), o.images);
  }
  if (!o.fix_intrinsics.empty() && o.fix_intrinsics.size() != n) {
    throw Error("--fix-intrinsics: give one camera file (or 'free') per --corners (" + std::to_string(n) + "), not " +
                std::to_string(o.fix_intrinsics.size()));
  }
  for (size_t k = 0; k < o.fix_intrinsics.size(); ++k) {
    if (o.fix_intrinsics[k] != "free") cameras[k].fixed_intrinsics = read_camera(o.fix_intrinsics[k]).parameters();
  }
  const RigCalibrationResult rig = calibrate_rig(cameras, board, {o.threads, o.board_warp == "on"});
  std::vector<CameraParameters> written;
  for (const auto& r : rig.cameras) written.push_back(apply_theta_limit(r.camera, o.theta_limit));
  std::vector<std::pair<std::filesystem::path, std::string>> files = {{o.output.out, format_rig(written, format)}};
  if (!o.poses.empty()) files.emplace_back(o.poses, rig_calibration_poses_json(rig) + "\n");
  std::string report_error;  // a report that cannot be drawn costs the report, not the calibration
  if (!o.report.empty()) {
    std::vector<std::vector<BoardObservation>> observations;
    std::vector<std::string> titles;
    for (size_t k = 0; k < n; ++k) {
      observations.push_back(cameras[k].observations);
      titles.push_back(std::filesystem::path(o.corners[k]).filename().string());
    }
    try {
      for (auto& file : report_files(o.report, rig_calibration_report(rig, written, observations, board, titles))) {
        files.push_back(std::move(file));
      }
    } catch (const Error& e) {
      report_error = e.what();
    }
  }
  write_outputs_with_report(files, report_error.empty() ? o.report : "", o.output.force);
  if (!report_error.empty()) throw Error("--report: not written (the rig was): " + report_error);
  for (const auto& warning : rig.warnings) std::fprintf(stderr, "fishcam: warning: %s\n", warning.c_str());
  for (size_t k = 0; k < n; ++k) {
    for (const auto& text : rig.cameras[k].undetermined) {
      std::fprintf(stderr, "fishcam: warning: camera %zu: not determined by the data: %s\n", k, text.c_str());
    }
  }
  if (!written.empty() && written[0].calibration && !camera_format_holds_calibration_record(format)) {
    note_dropped_record(written[0], format, o.output.out);
  }
  if (o.output.json) {
    std::printf("%s\n", rig_calibration_report_json(rig, o.corners, o.output.out).c_str());
    return;
  }
  std::printf("calibrated a rig of %zu cameras from %ld instants: rms %.4f px (2-D; %.4f per coordinate); wrote %s\n",
              n, rig.instants, rig.rms_px, rig.rms_px / std::sqrt(2.0), o.output.out.c_str());
  if (const auto& warp = rig.cameras[0].board_warp) {
    std::printf("  board warp (x2, y2) %.4g +- %.2g, %.4g +- %.2g (board units; --board-warp off: flat)\n", warp->x2,
                rig.cameras[0].board_warp_sigma.x2, warp->y2, rig.cameras[0].board_warp_sigma.y2);
  }
  for (size_t k = 0; k < n; ++k) {
    const CalibrationResult& r = rig.cameras[k];
    const Pose& pose = *r.camera.pose;
    std::printf("  camera %zu (%s%s, %zu images, rms %.4f px): ", k, std::string(model_name(r.camera.model)).c_str(),
                rig.fixed_intrinsics[k] ? ", intrinsics fixed" : "", r.used_images.size(), r.rms_px);
    if (k == 0) {
      std::printf("the rig's frame\n");
    } else {
      std::printf("rotation %.4f deg +- %.2g, translation (%.6g, %.6g, %.6g) +- %.2g\n",
                  Eigen::AngleAxisd(pose.rotation).angle() * 180 / std::numbers::pi,
                  rig.rotation_sigma_rad[k] * 180 / std::numbers::pi, pose.translation.x(), pose.translation.y(),
                  pose.translation.z(), rig.translation_sigma[k]);
    }
  }
}

}  // namespace

namespace {

// What calibrate prints for one camera without --json.
void print_calibration(const CalibrationResult& result, const CameraParameters& camera, const std::string& out) {
  constexpr double kDeg = 180 / std::numbers::pi;
  const CalibrationRecord& record = *result.camera.calibration;
  std::printf(
      "calibrated %s%s from %zu images, %ld corners: rms %.4f px (2-D; %.4f per coordinate), %zu outliers; "
      "wrote %s\n",
      std::string(model_name(result.camera.model)).c_str(),
      result.camera.mrcal_lens()            ? (" with " + result.camera.mrcal_lens()->lensmodel()).c_str()
      : displaces(result.camera.distortion) ? " with tangential terms"
                                            : "",
      result.used_images.size(), result.observations, result.rms_px, result.rms_px / std::sqrt(2.0),
      result.outliers.size(), out.c_str());
  const MrcalLens* lens = result.camera.mrcal_lens();
  for (size_t i = 0; i < result.parameters.size(); ++i) {
    // A spline's values (hundreds) summarised: they are in the camera file and --json.
    if (lens && result.parameter_names[i].starts_with("values[")) {
      if (result.parameter_names[i] != "values[0]") continue;
      const auto [low, high] = std::minmax_element(lens->values().begin(), lens->values().end());
      std::printf("  %zu spline values in [%.4g, %.4g] (in the camera file; --json lists them with sigmas)\n",
                  lens->values().size(), *low, *high);
      continue;
    }
    if (std::isnan(result.sigmas[i])) {
      std::printf("  %-4s %16.10g    not determined by the data\n", result.parameter_names[i].c_str(),
                  result.parameters[i]);
    } else {
      std::printf("  %-4s %16.10g +- %.3g\n", result.parameter_names[i].c_str(), result.parameters[i],
                  result.sigmas[i]);
    }
  }
  if (const auto& warp = result.board_warp) {
    std::printf("  board warp (x2, y2) %.4g +- %.2g, %.4g +- %.2g (board units; --board-warp off: flat)\n", warp->x2,
                result.board_warp_sigma.x2, warp->y2, result.board_warp_sigma.y2);
  }
  std::printf("  observed angles of incidence up to %.1f deg", record.theta_max * kDeg);
  if (const auto& by_azimuth = camera.theta_limit_by_azimuth) {
    const auto [low, high] = std::minmax_element(by_azimuth->begin(), by_azimuth->end());
    std::printf(" (valid domain capped per azimuth at %.1f to %.1f deg)", *low * kDeg, *high * kDeg);
  } else if (camera.theta_limit) {
    std::printf(" (valid domain capped at %.1f deg)", *camera.theta_limit * kDeg);
  }
  std::printf("\n  per-image rms (px):");
  for (size_t i = 0; i < result.used_images.size(); ++i) {
    std::printf("%s %s %.3f", i % 4 ? "," : "\n   ", result.used_images[i].c_str(), result.per_image_rms_px[i]);
  }
  std::printf("\n");
  for (const auto& outlier : result.outliers) {
    std::printf("  outlier: %s corner %d, %.2f px\n", outlier.filename.c_str(), outlier.corner, outlier.error_px);
  }
}

void add_calibrate_options(CLI::App* cmd, CalibrateOptions* o) {
  cmd->add_option("--corners", o->corners,
                  "corners.vnl (mrcal's format); once per camera for a rig (images of one instant share their file "
                  "name)")
      ->required();
  auto* board = cmd->add_option("--board", o->board, "Inner corners WxH (with --spacing)");
  auto* spacing = cmd->add_option("--spacing", o->spacing, "Corner spacing (m)")->check(CLI::PositiveNumber);
  cmd->add_option("--target", o->target,
                  "A target instead of --board and --spacing, charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY] (its "
                  "corners are a (COLS-1)x(ROWS-1) board of spacing SQUARE) or aprilgrid:COLSxROWS:SIZE:SPACING (each "
                  "tag's four corners), as detect-corners --target")
      ->excludes(board)
      ->excludes(spacing);
  cmd->add_option("--imagersize", o->imagersize, "Image size WxH (or W,H); for a rig once, or once per camera")
      ->required();
  cmd->add_option("--model", o->model,
                  "Model: " + fishcam::model_names_text() +
                      "; MODEL+tangential adds OpenCV's p1, p2 and MODEL+thin-prism also s1..s4 (pinhole, opencv, "
                      "mei: opencv+tangential is mrcal's OPENCV8); mrcal's splined model by its mrcal name "
                      "(LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=200); for a rig one, or one per "
                      "camera (comma-separated)")
      ->required();
  cmd->add_option("--images", o->images,
                  "Use only the images whose file name matches one of these shell patterns (comma-separated)");
  cmd->add_option("--poses", o->poses, "Also write the board poses (JSON) to this file");
  cmd->add_option("--report", o->report,
                  "Also write a report to look at into this folder: an HTML page with PNG figures (residuals, "
                  "coverage, observed domain, projection uncertainty; a rig's per-instant poses)");
  cmd->add_option("--fix-intrinsics", o->fix_intrinsics,
                  "For a rig: one camera file per --corners whose intrinsics are held fixed (only where the camera "
                  "sits is solved), or 'free' for a camera whose intrinsics are solved");
  cmd->add_option("--board-warp", o->board_warp,
                  "Solve the boards' warp (mrcal's calobject_warp: two parabolic bows, one for every board) with the "
                  "intrinsics, as mrcal does (on; for a rig, in its joint solve, as mrcal's); off: flat boards, as "
                  "OpenCV")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads for the independent solves (the result is the same for any count)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  add_theta_limit_option(cmd, &o->theta_limit);
  add_camera_output_options(cmd, &o->output);
}

}  // namespace

void register_calibrate(CLI::App& app) {
  auto* cmd = app.add_subcommand("calibrate",
                                 "Calibrate a camera model from chessboard corners: joint Ceres solve "
                                 "of intrinsics and board poses, robust, with uncertainties");
  auto o = std::make_shared<CalibrateOptions>();
  add_calibrate_options(cmd, o.get());
  cmd->callback([o, cmd] {
    std::vector<OutputFile> outputs = {{o->output.out}};
    if (!o->poses.empty()) outputs.push_back({o->poses});
    std::vector<std::string> inputs = o->corners;
    inputs.insert(inputs.end(), o->fix_intrinsics.begin(), o->fix_intrinsics.end());
    check_outputs(outputs, inputs, o->output.force);
    if (!o->report.empty()) check_report_folder(o->report, inputs, o->output.force, {o->output.out, o->poses});
    const BoardSpec board = board_or_target(o->board, o->spacing, o->target);
    if (o->corners.size() > 1) return calibrate_rig_command(*o, board);
    if (o->imagersize.size() > 1) throw Error("--imagersize: one camera takes one image size");
    if (!o->fix_intrinsics.empty()) throw Error("--fix-intrinsics: for a rig (several --corners)");
    const ModelSpec spec = parse_model_spec(o->model);
    const CameraFormat format = o->output.resolved_format();
    const auto [width, height] = parse_image_size(o->imagersize[0], "--imagersize");
    auto observations = read_corners(o->corners[0], board);
    if (!o->images.empty()) observations = select_images(std::move(observations), o->images);
    const CalibrationResult result =
        calibrate(observations, board, width, height, spec, {o->threads, o->board_warp == "on"});
    const CameraParameters camera = apply_theta_limit(result.camera, o->theta_limit);
    // Everything is computed (and every output checked) before the first file is written.
    std::vector<std::pair<std::filesystem::path, std::string>> files = {{o->output.out, format_camera(camera, format)}};
    if (!o->poses.empty()) files.emplace_back(o->poses, calibration_poses_json(result) + "\n");
    std::string report_error;  // a report that cannot be drawn costs the report, not the calibration
    if (!o->report.empty()) {
      try {
        for (auto& file :
             report_files(o->report, calibration_report(result, camera, observations, board,
                                                        std::filesystem::path(o->corners[0]).filename().string()))) {
          files.push_back(std::move(file));
        }
      } catch (const Error& e) {
        report_error = e.what();
      }
    }
    write_outputs_with_report(files, report_error.empty() ? o->report : "", o->output.force);
    if (!report_error.empty()) throw Error("--report: not written (the camera was): " + report_error);
    note_dropped_record(camera, format, o->output.out);
    for (const auto& warning : result.warnings) std::fprintf(stderr, "fishcam: warning: %s\n", warning.c_str());
    for (const auto& text : result.undetermined) {
      std::fprintf(stderr, "fishcam: warning: not determined by the data: %s\n", text.c_str());
    }
    if (o->output.json) {
      std::printf("%s\n", calibration_report_json(result, camera, o->output.out).c_str());
      return;
    }
    print_calibration(result, camera, o->output.out);
  });
}

}  // namespace fishcam::cli
