// fishcam synth-corners CAMERA: chessboard observations from a known camera, in mrcal's corners format.
#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/fit/calibration.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/corners.hpp"
#include "fishcam/testing/testing.hpp"

namespace fishcam::cli {

void register_synth_corners(CLI::App& app) {
  auto* cmd = app.add_subcommand("synth-corners",
                                 "Synthetic chessboard observations from a known camera (poses over "
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
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, inputs] {
    check_outputs({{o->out}, {o->truth}}, {o->camera}, o->force);
    const Camera camera = inputs->read(o->camera);
    const BoardSpec board = parse_board(o->board, o->spacing);
    const testing::SyntheticBoards synthetic = testing::synthesize_boards(camera, board, o->boards, o->noise, o->seed);
    // Corners and truth land together (or neither).
    std::vector<std::pair<std::filesystem::path, std::string>> files{{o->out, format_corners(synthetic.observations)}};
    if (!o->truth.empty()) files.emplace_back(o->truth, format_camera(camera.parameters(), CameraFormat::fishcam));
    write_files_atomically(files, o->force);
    std::printf("wrote %d boards of %dx%d corners (noise %.3g px) to %s\n", o->boards, board.cols, board.rows, o->noise,
                o->out.c_str());
  });
}

}  // namespace fishcam::cli
