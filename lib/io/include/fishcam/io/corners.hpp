// mrcal's corners file format (vnlog), read and written (fishcam_io).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fishcam/core/board.hpp"

namespace fishcam {

// "# filename x y level", one row per corner in board order, "filename - - -" for an
// image without a board. Throws Error naming the file, line and problem (e.g. a
// wrong number of corners for an image).
std::vector<BoardObservation> read_corners(const std::filesystem::path& path, const BoardSpec& board);
// The content of a corners file (throws Error for non-finite corners).
std::string format_corners(const std::vector<BoardObservation>& observations);
void write_corners(const std::filesystem::path& path, const std::vector<BoardObservation>& observations,
                   bool overwrite = false);

}  // namespace fishcam
