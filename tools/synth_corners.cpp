// fishcam synth-corners CAMERA: board observations from a known camera, in mrcal's
// corners format, and on request the photos they come from.
#include <cstdio>
#include <opencv2/core.hpp>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/augment/target.hpp"
#include "fishcam/fit/calibration.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/corners.hpp"
#include "fishcam/testing/testing.hpp"

namespace fishcam::cli {

void register_synth_corners(CLI::App& app) {
  auto* cmd = app.add_subcommand("synth-corners",
                                 "Synthetic chessboard or ChArUco observations from a known camera (poses over "
                                 "the whole field of view), in mrcal's corners format, and their photos");
  struct Options {
    std::string camera, board = "10x10", target, out, truth, images;
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
  auto* board = cmd->add_option("--board", o->board, "A chessboard's inner corners WxH")->capture_default_str();
  cmd->add_option("--spacing", o->spacing, "The chessboard's corner spacing (m)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--target", o->target,
                  "A target whose boards may leave the image instead (the corners inside it are written with their "
                  "ids): charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY] or aprilgrid:COLSxROWS:SIZE:SPACING (as "
                  "detect-corners --target)")
      ->excludes(board);
  cmd->add_option("--out", o->out, "Output corners.vnl")->required();
  cmd->add_option("--truth", o->truth, "Also write the true camera here (fishcam JSON)");
  cmd->add_option("--images", o->images,
                  "Also render each board's photo into this existing folder (grayscale PNG named as in the corners "
                  "file; 3x3 rays per pixel, 0.8 px blur, noise of 2 grey levels; --noise moves the written corners "
                  "only)");
  cmd->add_flag("--force", o->force, "Replace existing output files");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, inputs] {
    const std::optional<TargetSpec> target = o->target.empty() ? std::nullopt : std::optional(parse_target(o->target));
    const BoardSpec board = target ? target_board(*target) : parse_board(o->board, o->spacing);
    const Camera camera = inputs->read(o->camera);
    const testing::SyntheticBoards synthetic =
        testing::synthesize_boards(camera, board, o->boards, o->noise, o->seed, /*partial=*/target.has_value());
    std::vector<OutputFile> outputs{{o->out}, {o->truth}};
    if (!o->images.empty()) {
      for (const auto& view : synthetic.observations)
        outputs.push_back({std::filesystem::path(o->images) / view.filename});
    }
    check_outputs(outputs, {o->camera}, o->force);
    // Corners, truth and photos land together (or none).
    std::vector<std::pair<std::filesystem::path, std::string>> files{
        {o->out, format_corners(synthetic.observations, board)}};
    if (!o->truth.empty()) files.emplace_back(o->truth, format_camera(camera.parameters(), CameraFormat::fishcam));
    if (!o->images.empty()) {
      const std::function<double(double, double)> texture = target ? target_texture(*target) : nullptr;
      for (size_t b = 0; b < synthetic.observations.size(); ++b) {
        const BoardPose& pose = synthetic.poses[b];
        std::vector<std::uint8_t> pixels =
            texture ? testing::render_target_image(camera, texture, pose, 3, 0.8, 2.0, o->seed + b)
                    : testing::render_board_image(camera, board, pose, 3, 0.8, 2.0, o->seed + b);
        const cv::Mat image(camera.height(), camera.width(), CV_8UC1, pixels.data());
        const auto path = std::filesystem::path(o->images) / synthetic.observations[b].filename;
        files.emplace_back(path, encode_image(path, image));
      }
    }
    write_outputs(files, o->force);
    std::printf("wrote %d %s boards of %dx%d corners (noise %.3g px) to %s%s%s\n", o->boards,
                target ? target_name(*target).c_str() : "chess", board.cols, board.rows, o->noise, o->out.c_str(),
                o->images.empty() ? "" : ", their photos to ", o->images.c_str());
  });
}

}  // namespace fishcam::cli
