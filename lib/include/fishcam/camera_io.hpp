// Camera files: WoodScape calibration JSON, mrcal .cameramodel (pinhole and
// stereographic), OpenCV fisheye YAML/XML (read with yaml-cpp / pugixml) and fishcam JSON.
// Field by field in docs/formats.md. Every error is one line naming the file and
// the field: "front.json: intrinsic.k1: expected a number, got string".
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "fishcam/camera.hpp"

namespace fishcam {

enum class CameraFormat { woodscape, mrcal, opencv, fishcam };

std::string_view to_string(CameraFormat format);
// "woodscape", "mrcal", "opencv", "fishcam"; nullopt for anything else.
std::optional<CameraFormat> parse_camera_format(std::string_view name);

// The format of a file's content (not its name). Throws Error if none fits.
CameraFormat detect_camera_format(std::string_view content, std::string_view source_name);

// Parses and validates a camera (in `format`, or the detected one); source_name
// prefixes every error message.
CameraParameters parse_camera(std::string_view content, std::string_view source_name,
                              std::optional<CameraFormat> format = std::nullopt);

struct CameraReadOptions {
  std::optional<CameraFormat> format;             // read as this format instead of detecting it
  std::optional<std::string> camera;              // which camera of a file (name or index; default the first)
  std::optional<std::pair<int, int>> image_size;  // width, height for files without one; must agree otherwise
};
// Reads, detects the format (reported in *format when given) and validates.
Camera read_camera(const std::filesystem::path& path, CameraFormat* format = nullptr);
Camera read_camera(const std::filesystem::path& path, const CameraReadOptions& options,
                   CameraFormat* format = nullptr);

// What `fishcam info --json` prints: one JSON object (model, parameters, width,
// height, cx, cy, pixel_scale, theta_max_deg, rho_max_px, fov_deg, pose, ...).
std::string camera_info_json(const Camera& camera, std::optional<CameraFormat> format = std::nullopt);

// The file content of a camera in a format; throws Error when the format cannot
// hold the camera (e.g. a polynomial in mrcal's format) rather than dropping anything.
std::string format_camera(const CameraParameters& camera, CameraFormat format);
// Writes atomically (temporary file + rename). Refuses to replace an existing file
// unless overwrite is true.
void write_camera(const CameraParameters& camera, const std::filesystem::path& path, CameraFormat format,
                  bool overwrite = false);

}  // namespace fishcam
