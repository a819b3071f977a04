#include "fishcam/augment/target.hpp"

#include "fishcam/core/error.hpp"

namespace fishcam {

TargetSpec parse_target(std::string_view text) {
  if (text.starts_with("charuco:")) return parse_charuco(text);
  if (text.starts_with("aprilgrid:")) return parse_aprilgrid(text);
  throw Error("--target '" + text_for_message(text) +
              "': expected charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY] (OpenCV's ChArUco) or "
              "aprilgrid:COLSxROWS:SIZE:SPACING (Kalibr's AprilGrid)");
}

BoardSpec target_board(const TargetSpec& target) {
  return std::visit([](const auto& spec) { return spec.board(); }, target);
}

std::string target_name(const TargetSpec& target) {
  return std::holds_alternative<CharucoSpec>(target) ? "ChArUco" : "AprilGrid";
}

std::optional<BoardObservation> detect_target(const cv::Mat& gray, const TargetSpec& target) {
  if (const auto* charuco = std::get_if<CharucoSpec>(&target)) return detect_charuco(gray, *charuco);
  return detect_aprilgrid(gray, std::get<AprilGridSpec>(target));
}

std::function<double(double, double)> target_texture(const TargetSpec& target) {
  if (const auto* charuco = std::get_if<CharucoSpec>(&target)) return CharucoTexture(*charuco);
  return AprilGridTexture(std::get<AprilGridSpec>(target));
}

}  // namespace fishcam
