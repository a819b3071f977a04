// fishcam detect-corners IMAGES...: chessboard, ChArUco or AprilGrid corners (OpenCV, libapriltag)
// (fishcam/augment/chessboard.hpp, target.hpp), in mrcal's corners format.
#include <unistd.h>
#include <opencv2/imgcodecs.hpp>

#include <atomic>
#include <cstdio>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/augment/chessboard.hpp"
#include "fishcam/augment/target.hpp"
#include "fishcam/core/parallel.hpp"
#include "fishcam/io/corners.hpp"
#include "image_files.hpp"

namespace fishcam::cli {

namespace {

// One photo under two spellings (x.png, ./x.png, a symlink) would count twice: the
// corners file would hold the same board twice, which calibrate refuses.
void check_distinct_images(const std::vector<std::string>& images) {
  std::map<std::filesystem::path, size_t> seen;
  for (size_t k = 0; k < images.size(); ++k) {
    std::error_code ec;
    const auto resolved = std::filesystem::weakly_canonical(std::filesystem::absolute(images[k]), ec);
    const auto [at, fresh] = seen.emplace(ec ? std::filesystem::path(images[k]) : resolved, k);
    if (!fresh) {
      throw Error(path_for_message(images[k]) + ": the same image as " + path_for_message(images[at->second]) +
                  " (given twice)");
    }
  }
}

// One image's corners (a partial board with ids), or nullopt where none were found.
using Detector = std::function<std::optional<BoardObservation>(const cv::Mat& gray)>;

// Every image's board corners (none where no board was found), on `threads` threads;
// failures[k] says why image k could not be read ("" if it could).
std::vector<BoardObservation> detect_boards(const std::vector<std::string>& images, const Detector& detect, int threads,
                                            std::vector<std::string>* failures) {
  const size_t count = images.size();
  std::vector<BoardObservation> observations(count);
  failures->assign(count, "");
  std::atomic<int> done{0};
  const bool progress = isatty(fileno(stderr));
  std::mutex print;
  for_each_index(int(count), threads, [&](int k) {
    const std::string& path = images[size_t(k)];
    observations[size_t(k)].filename = path;
    try {
      const cv::Mat gray = read_image(path, cv::IMREAD_GRAYSCALE);
      if (auto found = detect(gray)) {
        observations[size_t(k)].corners = std::move(found->corners);
        observations[size_t(k)].ids = std::move(found->ids);
      }
    } catch (const Error& e) {
      (*failures)[size_t(k)] = e.what();
    }
    const int finished = ++done;
    if (progress) {
      const std::lock_guard lock(print);
      std::fprintf(stderr, "\rdetect-corners: %d/%zu images", finished, count);
      if (size_t(finished) == count) std::fprintf(stderr, "\n");
    }
  });
  return observations;
}

}  // namespace

void register_detect_corners(CLI::App& app) {
  auto* cmd = app.add_subcommand("detect-corners",
                                 "Find chessboard or ChArUco corners (OpenCV) and write them in mrcal's "
                                 "corners format");
  struct Options {
    std::vector<std::string> images;
    std::string board, target, out;
    int threads = int(std::max(1u, std::thread::hardware_concurrency()));
    bool force = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("IMAGES", o->images, "Images")->required();
  auto* board_option = cmd->add_option("--board", o->board, "A chessboard's inner corners WxH, e.g. 10x10");
  cmd->add_option("--target", o->target,
                  "A target whose boards may leave the image instead (each corner kept with its id; calibrate with "
                  "the same --target): OpenCV's ChArUco, charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY] (squares, "
                  "their side, the markers' side; dictionary 4X4_50 unless given), or Kalibr's AprilGrid, "
                  "aprilgrid:COLSxROWS:SIZE:SPACING (tags, their side, the gap between them over the side)")
      ->excludes(board_option);
  cmd->add_option("--out", o->out, "Output corners.vnl")->required();
  cmd->add_option("--threads", o->threads, "Images detected in parallel")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->add_flag("--force", o->force, "Replace an existing output file");
  cmd->callback([o] {
    {
      std::vector<OutputFile> outputs{{o->out}};
      check_outputs(outputs, o->images, o->force);
    }
    check_distinct_images(o->images);
    if (o->board.empty() == o->target.empty()) {
      throw Error("give --board WxH (a chessboard) or --target charuco:... or aprilgrid:...");
    }
    const std::optional<TargetSpec> target = o->target.empty() ? std::nullopt : std::optional(parse_target(o->target));
    const BoardSpec board = target ? target_board(*target) : parse_board(o->board, 1.0);
    // OpenCV's chessboard detector needs more than 2 corners per side.
    if (!target && (board.cols < 3 || board.rows < 3)) {
      throw Error("--board: detection needs at least 3x3 inner corners");
    }
    const Detector detect = [&](const cv::Mat& gray) -> std::optional<BoardObservation> {
      if (target) return detect_target(gray, *target);
      auto corners = detect_chessboard(gray, board);
      if (!corners) return std::nullopt;
      return BoardObservation{"", std::move(*corners), {}};
    };
    const size_t count = o->images.size();
    std::vector<std::string> failures;
    std::vector<BoardObservation> observations = detect_boards(o->images, detect, o->threads, &failures);
    // Images that could not be read are left out of the file (and reported); the
    // others keep the order they were given in.
    std::vector<BoardObservation> readable;
    std::vector<std::string> unreadable;
    long found = 0, partial = 0;
    for (size_t k = 0; k < count; ++k) {
      if (!failures[k].empty()) {
        unreadable.push_back(failures[k]);
        std::fprintf(stderr, "fishcam: skipped %s\n", failures[k].c_str());
        continue;
      }
      found += observations[k].corners.empty() ? 0 : 1;
      partial += observations[k].ids.empty() ? 0 : 1;
      readable.push_back(std::move(observations[k]));
    }
    if (readable.empty()) throw Error("no image could be read; nothing written (first: " + unreadable[0] + ")");
    write_corners(o->out, readable, board, o->force);
    std::printf("%ld of %zu images show a %dx%d board%s; wrote %s\n", found, count, board.cols, board.rows,
                target ? (" (" + std::to_string(partial) + " of them partly)").c_str() : "", o->out.c_str());
    if (!unreadable.empty()) {
      throw Error(std::to_string(unreadable.size()) + " image(s) unreadable, first: " + unreadable[0]);
    }
  });
}

}  // namespace fishcam::cli
