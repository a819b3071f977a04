// Kalibr's AprilGrid: a grid of AprilTags (family 36h11, each with a black border two
// bits wide) with black squares in the gaps at the tags' corners, so each tag corner
// is a chessboard-like X junction known by its tag's id: a board partly outside the
// image still calibrates. Detection (libapriltag) and the board's printed look, for
// calibration and synthetic renders.
#pragma once

#include <opencv2/core.hpp>

#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "fishcam/core/board.hpp"

namespace fishcam {

// cols x rows tags of side `size` (the black border's outer edge, Kalibr's tagSize),
// `spacing` the gap between tags as a fraction of `size` (Kalibr's tagSpacing), as
// Kalibr's kalibr_create_target_pdf prints it: tag id 0 at the bottom left as the
// board is seen from its front, ids increasing to the right, then upwards. Its
// corners are a (2 cols) x (2 rows) board (board(): each tag's four corners) in
// fishcam's board frame: corner 0 the top left corner of the top left tag, x to the
// right, y down the board, numbered row by row (Kalibr numbers them from the bottom
// left): the corner ids of the corners file.
struct AprilGridSpec {
  int cols = 0, rows = 0;
  double size = 0, spacing = 0;
  BoardSpec board() const { return {2 * cols, 2 * rows, size, size * spacing}; }
};

// "aprilgrid:COLSxROWS:SIZE:SPACING" (what --target takes), e.g.
// "aprilgrid:6x6:0.088:0.3"; throws Error naming the problem.
AprilGridSpec parse_aprilgrid(std::string_view text);
// Throws Error unless the grid has 1..100 tags per side, 2 to 587 tags (the family's
// codes), a finite size > 0 and a spacing within (0, 1].
void check_aprilgrid(const AprilGridSpec& spec);

// The corners found in an 8-bit grayscale image: tags found by libapriltag (on the
// image doubled and brightened by half a pixel, which parts the gap squares from the
// tags they touch at a corner), each tag's four corners refined with cornerSubPix on
// the image itself (the X junction of tag and square), as a partial observation (ids
// in board order), or nullopt when fewer than 6 corners spanning 2 rows and 2
// columns are found.
// Throws Error for an image that is not 8-bit grayscale.
std::optional<BoardObservation> detect_aprilgrid(const cv::Mat& gray, const AprilGridSpec& spec);

// The board as Kalibr prints it, looked up in the board frame of spec.board(): the
// grey level (0..255) at (x, y), a white margin of a tag's side around the gap
// squares, NaN beyond.
class AprilGridTexture {
 public:
  explicit AprilGridTexture(const AprilGridSpec& spec);
  double operator()(double x, double y) const;

 private:
  AprilGridSpec spec_;
  std::vector<std::vector<bool>> black_bits_;  // per tag id: its 6x6 data bits, row by row, true = black
};

}  // namespace fishcam
