// The calibration targets --target names: boards whose corners are known by their
// ids, so a board partly outside the image still calibrates (fishcam/augment/
// charuco.hpp, aprilgrid.hpp). One place that tells them apart, for the program.
#pragma once

#include <opencv2/core.hpp>

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "fishcam/augment/aprilgrid.hpp"
#include "fishcam/augment/charuco.hpp"
#include "fishcam/core/board.hpp"

namespace fishcam {

using TargetSpec = std::variant<CharucoSpec, AprilGridSpec>;

// "charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY]" or "aprilgrid:COLSxROWS:SIZE:SPACING";
// throws Error naming the problem (or both forms, for neither).
TargetSpec parse_target(std::string_view text);
// The target's corners as a board (CharucoSpec::board, AprilGridSpec::board).
BoardSpec target_board(const TargetSpec& target);
// "ChArUco" or "AprilGrid".
std::string target_name(const TargetSpec& target);
// detect_charuco or detect_aprilgrid.
std::optional<BoardObservation> detect_target(const cv::Mat& gray, const TargetSpec& target);
// The printed look (CharucoTexture, AprilGridTexture): the grey level at (x, y) of the
// board frame, NaN off the board.
std::function<double(double, double)> target_texture(const TargetSpec& target);

}  // namespace fishcam
