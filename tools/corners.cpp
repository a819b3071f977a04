// Chessboard corners: fishcam detect-corners (OpenCV) and fishcam synth-corners
// (from a known camera), both in mrcal's corners format.
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/calibration.hpp"

namespace fishcam::cli {
namespace {

BoardSpec parse_board(const std::string& text, double spacing) {
  int cols = 0, rows = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &cols, &x, &rows, &extra) != 3 || x != 'x' || cols < 2 || rows < 2) {
    throw Error("--board: expected WxH inner corners (e.g. 10x10), got '" + text + "'");
  }
  return {cols, rows, spacing};
}

}  // namespace

void register_corners(CLI::App& app) {
  {
    auto* cmd = app.add_subcommand("detect-corners", "Find chessboard corners (OpenCV findChessboardCornersSB) and "
                                                     "write them in mrcal's corners format");
    struct Options {
      std::vector<std::string> images;
      std::string board, out;
      bool force = false;
    };
    auto o = std::make_shared<Options>();
    cmd->add_option("IMAGES", o->images, "Images")->required();
    cmd->add_option("--board", o->board, "Inner corners WxH, e.g. 10x10")->required();
    cmd->add_option("--out", o->out, "Output corners.vnl")->required();
    cmd->add_flag("--force", o->force, "Replace an existing output file");
    cmd->callback([o] {
      const BoardSpec board = parse_board(o->board, 1.0);
      std::vector<BoardObservation> observations;
      long found = 0;
      std::vector<std::string> failures;
      for (const std::string& path : o->images) {
        cv::Mat gray;
        try {
          gray = read_image(path, cv::IMREAD_GRAYSCALE);
        } catch (const Error& e) {
          failures.push_back(e.what());
          std::fprintf(stderr, "fishcam: skipped %s\n", e.what());
          continue;
        }
        std::vector<cv::Point2f> corners;
        const bool ok = cv::findChessboardCornersSB(gray, {board.cols, board.rows}, corners,
                                                    cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
        BoardObservation observation{path, {}};
        if (ok) {
          for (const auto& c : corners) observation.corners.emplace_back(c.x, c.y);
          ++found;
        }
        observations.push_back(std::move(observation));
      }
      if (!observations.empty()) write_corners(o->out, observations, o->force);
      std::printf("%ld of %zu images show a %dx%d board; wrote %s\n", found, o->images.size(), board.cols, board.rows,
                  o->out.c_str());
      if (!failures.empty()) throw Error(std::to_string(failures.size()) + " image(s) unreadable, first: " + failures[0]);
    });
  }
  {
    auto* cmd = app.add_subcommand("synth-corners", "Synthetic chessboard observations from a known camera (poses over "
                                                    "the whole field of view), in mrcal's corners format");
    struct Options {
      std::string camera, board = "10x10", out, truth;
      int boards = 0;
      double noise = 0, spacing = 0.1;
      std::uint64_t seed = 0;
      bool force = false;
    };
    auto o = std::make_shared<Options>();
    cmd->add_option("CAMERA", o->camera, "The true camera")->required();
    cmd->add_option("--boards", o->boards, "Number of board observations")->required()->check(CLI::Range(1, 100000));
    cmd->add_option("--noise", o->noise, "Gaussian pixel noise sigma (px)")->required()->check(CLI::NonNegativeNumber);
    cmd->add_option("--seed", o->seed, "Seed")->required();
    cmd->add_option("--board", o->board, "Inner corners WxH")->capture_default_str();
    cmd->add_option("--spacing", o->spacing, "Corner spacing (m)")->check(CLI::PositiveNumber)->capture_default_str();
    cmd->add_option("--out", o->out, "Output corners.vnl")->required();
    cmd->add_option("--truth", o->truth, "Also write the true camera here (fishcam JSON)");
    cmd->add_flag("--force", o->force, "Replace existing output files");
    cmd->callback([o] {
      const Camera camera = read_camera(o->camera);
      const BoardSpec board = parse_board(o->board, o->spacing);
      const SyntheticBoards synthetic = synthesize_boards(camera, board, o->boards, o->noise, o->seed);
      write_corners(o->out, synthetic.observations, o->force);
      if (!o->truth.empty()) write_camera(camera.parameters(), o->truth, CameraFormat::fishcam, o->force);
      std::printf("wrote %d boards of %dx%d corners (noise %.3g px) to %s\n", o->boards, board.cols, board.rows, o->noise,
                  o->out.c_str());
    });
  }
  {
    auto* cmd = app.add_subcommand("calibrate", "Calibrate a camera model from chessboard corners: joint Ceres solve "
                                                "of intrinsics and board poses, robust, with uncertainties");
    struct Options {
      std::string corners, board, model;
      std::vector<int> imagersize;
      double spacing = 0;
      CameraOutputOptions output;
    };
    auto o = std::make_shared<Options>();
    cmd->add_option("--corners", o->corners, "corners.vnl (mrcal's format)")->required();
    cmd->add_option("--board", o->board, "Inner corners WxH")->required();
    cmd->add_option("--spacing", o->spacing, "Corner spacing (m)")->required()->check(CLI::PositiveNumber);
    cmd->add_option("--imagersize", o->imagersize, "Image size WxH")->required()->delimiter('x')->expected(2);
    cmd->add_option("--model", o->model, "polynomial[:N], equidistant, stereographic, pinhole, kannala-brandt")
        ->required();
    add_camera_output_options(cmd, &o->output);
    cmd->callback([o] {
      const BoardSpec board = parse_board(o->board, o->spacing);
      const ModelSpec spec = parse_model_spec(o->model);
      const CameraFormat format = o->output.resolved_format();
      if (o->imagersize[0] < 1 || o->imagersize[1] < 1) throw Error("--imagersize: expected positive WxH");
      const auto observations = read_corners(o->corners, board);
      const CalibrationResult result = calibrate(observations, board, o->imagersize[0], o->imagersize[1], spec);
      write_camera(result.camera, o->output.out, format, o->output.force);
      for (const auto& warning : result.warnings) std::fprintf(stderr, "fishcam: warning: %s\n", warning.c_str());
      nlohmann::json j = {{"model", model_name(result.camera.model)},
                          {"rms_px", result.rms_px},
                          {"corners", result.observations},
                          {"images", result.used_images.size()},
                          {"outliers", result.outliers.size()},
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
      std::printf("calibrated %s from %zu images, %ld corners: rms %.4f px, %zu outliers; wrote %s\n",
                  std::string(model_name(result.camera.model)).c_str(), result.used_images.size(), result.observations,
                  result.rms_px, result.outliers.size(), o->output.out.c_str());
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
}

}  // namespace fishcam::cli
