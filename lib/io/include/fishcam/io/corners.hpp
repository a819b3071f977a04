// mrcal's corners file format (vnlog), read and written (fishcam_io).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fishcam/core/board.hpp"

namespace fishcam {

// "# filename x y level", one row per corner in board order, "filename - - -" for an
// image without a board. A row whose level is '-' (mrcal's mark: x and y may be '-'
// too) is a corner not observed or not to be used: the image's observation is then
// partial (BoardObservation::ids). Throws Error naming the file, line and problem
// (e.g. a wrong number of rows for an image).
std::vector<BoardObservation> read_corners(const std::filesystem::path& path, const BoardSpec& board);
// The content of a corners file: every image's rows in board order, a partial
// board's missing corners as "- - -" (throws Error for non-finite corners or ids
// that do not fit the board).
std::string format_corners(const std::vector<BoardObservation>& observations, const BoardSpec& board);
void write_corners(const std::filesystem::path& path, const std::vector<BoardObservation>& observations,
                   const BoardSpec& board, bool overwrite = false);

}  // namespace fishcam
