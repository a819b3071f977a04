// fishcam detect-corners IMAGES...: chessboard corners found by OpenCV, in mrcal's corners format.
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdio>

#include "fishcam/corners.hpp"
#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/calibration.hpp"

namespace fishcam::cli {

void register_detect_corners(CLI::App& app) {
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
    {
      std::vector<OutputFile> outputs{{o->out}};
      check_outputs(outputs, o->images, o->force);
    }
    const BoardSpec board = parse_board(o->board, 1.0);
    // OpenCV's detector needs more than 2 corners per side.
    if (board.cols < 3 || board.rows < 3) throw Error("--board: detection needs at least 3x3 inner corners");
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
    if (observations.empty()) throw Error("no image could be read; nothing written (first: " + failures[0] + ")");
    write_corners(o->out, observations, o->force);
    std::printf("%ld of %zu images show a %dx%d board; wrote %s\n", found, o->images.size(), board.cols, board.rows,
                o->out.c_str());
    if (!failures.empty()) throw Error(std::to_string(failures.size()) + " image(s) unreadable, first: " + failures[0]);
  });
}

}  // namespace fishcam::cli
