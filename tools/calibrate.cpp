// fishcam calibrate: intrinsics and board poses from chessboard corners.
#include <cmath>
#include <cstdio>

#include "fishcam/corners.hpp"
#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/calibration.hpp"

namespace fishcam::cli {

void register_calibrate(CLI::App& app) {
  auto* cmd = app.add_subcommand("calibrate", "Calibrate a camera model from chessboard corners: joint Ceres solve "
                                              "of intrinsics and board poses, robust, with uncertainties");
  struct Options {
    std::string corners, board, model;
    std::string imagersize;
    double spacing = 0;
    CameraOutputOptions output;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("--corners", o->corners, "corners.vnl (mrcal's format)")->required();
  cmd->add_option("--board", o->board, "Inner corners WxH")->required();
  cmd->add_option("--spacing", o->spacing, "Corner spacing (m)")->required()->check(CLI::PositiveNumber);
  cmd->add_option("--imagersize", o->imagersize, "Image size W,H (or WxH)")->required();
  cmd->add_option("--model", o->model, "Model: " + fishcam::model_names_text())
      ->required();
  add_camera_output_options(cmd, &o->output);
  cmd->callback([o] {
    check_outputs({{o->output.out}}, {o->corners}, o->output.force);
    const BoardSpec board = parse_board(o->board, o->spacing);
    const ModelSpec spec = parse_model_spec(o->model);
    const CameraFormat format = o->output.resolved_format();
    const auto [width, height] = parse_image_size(o->imagersize, "--imagersize");
    const auto observations = read_corners(o->corners, board);
    const CalibrationResult result = calibrate(observations, board, width, height, spec);
    write_camera(result.camera, o->output.out, format, o->output.force);
    for (const auto& warning : result.warnings) std::fprintf(stderr, "fishcam: warning: %s\n", warning.c_str());
    // rms_px: the root mean square of the corners' 2-D reprojection error (the
    // norm); mrcal and OpenCV print it per coordinate, which is rms_px / sqrt(2).
    nlohmann::json outliers = nlohmann::json::array();
    for (const auto& outlier : result.outliers) {
      outliers.push_back({{"image", outlier.filename}, {"corner", outlier.corner}, {"error_px", outlier.error_px}});
    }
    nlohmann::json j = {{"model", model_name(result.camera.model)},
                        {"rms_px", result.rms_px},
                        {"rms_per_coordinate_px", result.rms_px / std::sqrt(2.0)},
                        {"corners", result.observations},
                        {"images", result.used_images.size()},
                        {"outliers", outliers},
                        {"warnings", result.warnings},
                        {"out", o->output.out}};
    for (size_t i = 0; i < result.parameters.size(); ++i) {
      j["parameters"][result.parameter_names[i]] = {{"value", result.parameters[i]}, {"sigma", result.sigmas[i]}};
    }
    for (size_t i = 0; i < result.used_images.size(); ++i) j["per_image_rms_px"][result.used_images[i]] = result.per_image_rms_px[i];
    if (o->output.json) {
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("calibrated %s from %zu images, %ld corners: rms %.4f px (2-D; %.4f per coordinate), %zu outliers; "
                "wrote %s\n",
                std::string(model_name(result.camera.model)).c_str(), result.used_images.size(), result.observations,
                result.rms_px, result.rms_px / std::sqrt(2.0), result.outliers.size(), o->output.out.c_str());
    for (size_t i = 0; i < result.parameters.size(); ++i) {
      std::printf("  %-4s %16.10g +- %.3g\n", result.parameter_names[i].c_str(), result.parameters[i], result.sigmas[i]);
    }
    std::printf("  per-image rms (px):");
    for (size_t i = 0; i < result.used_images.size(); ++i) {
      std::printf("%s %s %.3f", i % 4 ? "," : "\n   ", result.used_images[i].c_str(), result.per_image_rms_px[i]);
    }
    std::printf("\n");
    for (const auto& outlier : result.outliers) {
      std::printf("  outlier: %s corner %d, %.2f px\n", outlier.filename.c_str(), outlier.corner, outlier.error_px);
    }
  });
}

}  // namespace fishcam::cli
