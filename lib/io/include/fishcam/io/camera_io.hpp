// Camera files in the formats people have (lib/io/src/formats/, one file each; the
// table is lib/io/src/formats/table.cpp): WoodScape, mrcal, OpenCV, fishcam, Kalibr,
// basalt, COLMAP, ROS, camodocal, ORB-SLAM3. Field by field in docs/formats.md.
// Every error is one line naming the file and the field:
// "front.json: intrinsic.k1: expected a number, got string".
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "fishcam/core/camera.hpp"
#include "fishcam/io/camera_format_list.hpp"

namespace fishcam {

#define FISHCAM_FORMAT_ENUMERATOR(name) name,
enum class CameraFormat { FISHCAM_CAMERA_FORMATS(FISHCAM_FORMAT_ENUMERATOR) };
#undef FISHCAM_FORMAT_ENUMERATOR

std::string_view to_string(CameraFormat format);
// The format's name ("kalibr", ...); nullopt for anything else.
std::optional<CameraFormat> parse_camera_format(std::string_view name);
// Every format, in the table's order.
std::vector<CameraFormat> camera_formats();
// "woodscape, mrcal, ..." for help texts and messages.
std::string camera_format_names();
// The registry models a format holds (its writer takes), in the format's order.
std::vector<std::string> camera_format_models(CameraFormat format);
// The format a file name's extension suggests for writing (.cameramodel: mrcal,
// .yaml/.yml/.xml: opencv, .json: fishcam, .txt: colmap); nullopt if none.
std::optional<CameraFormat> camera_format_for_extension(const std::filesystem::path& path);

// The format of a file's content (not its name). Throws Error if none fits.
CameraFormat detect_camera_format(std::string_view content, std::string_view source_name);

struct CameraReadOptions {
  std::optional<CameraFormat> format;             // read as this format instead of detecting it
  std::optional<std::string> camera;              // which camera of a file (name or index; default the first)
  std::optional<std::pair<int, int>> image_size;  // width, height for files without one; must agree otherwise
  // For OpenCV files whose coefficients do not say which model they are: "fisheye"
  // or "plumb_bob" (never guessed); must agree with the file's distortion_model.
  std::optional<std::string> distortion_model;
};

// What reading told besides the camera.
struct CameraFileInfo {
  CameraFormat format = CameraFormat::fishcam;
  std::string camera_name;  // as the file names it ("cam0"), or its index
  int camera_index = 0;
  int camera_count = 1;
  std::vector<std::string> notes;  // what was not read, which camera was chosen (the CLI prints them)
};

// Parses and validates a camera (in `format`, or the detected one); source_name
// prefixes every error message.
CameraParameters parse_camera(std::string_view content, std::string_view source_name,
                              std::optional<CameraFormat> format = std::nullopt);
CameraParameters parse_camera(std::string_view content, std::string_view source_name, const CameraReadOptions& options,
                              CameraFileInfo* info = nullptr);

// Reads, detects the format (reported in *format when given) and validates.
Camera read_camera(const std::filesystem::path& path, CameraFormat* format = nullptr);
Camera read_camera(const std::filesystem::path& path, const CameraReadOptions& options, CameraFormat* format = nullptr);
Camera read_camera(const std::filesystem::path& path, const CameraReadOptions& options, CameraFileInfo* info);

// What `fishcam info --json` prints: one JSON object (model, parameters, width,
// height, cx, cy, pixel_scale, theta_max_deg, rho_max_px, fov_deg, pose, ...).
std::string camera_info_json(const Camera& camera, std::optional<CameraFormat> format = std::nullopt);

// A camera rig in one file: every camera with its pose relative to the first
// (CameraParameters::pose = camera -> camera 0). fishcam JSON ("fishcam_rig"),
// Kalibr (camN with T_cn_cnm1, no T_cam_imu) and basalt (T_imu_cam, camera 0
// standing in for the IMU) hold rigs; the others refuse in one line. Read back
// with read_camera(path, {.camera = "N"}).
bool camera_format_holds_rig(CameraFormat format);
std::string format_rig(const std::vector<CameraParameters>& cameras, CameraFormat format);
void write_rig(const std::vector<CameraParameters>& cameras, const std::filesystem::path& path, CameraFormat format,
               bool overwrite = false);

// Whether the format keeps a camera's calibration record (fishcam JSON only).
bool camera_format_holds_calibration_record(CameraFormat format);
// Whether the format can store this plane distortion (fishcam/core/plane_distortion.hpp;
// tangential p1, p2: most formats with a pinhole plane; s1..s4 and mrcal lenses: fewer).
bool camera_format_holds(CameraFormat format, const PlaneDistortion& distortion);

// The file content of a camera in a format; throws Error when the format cannot
// hold the camera (e.g. a polynomial in mrcal's format) rather than dropping
// anything -- except the calibration record, which only fishcam JSON holds and the
// others leave out (check camera_format_holds_calibration_record and tell the user).
std::string format_camera(const CameraParameters& camera, CameraFormat format);
// Writes atomically (temporary file + rename). Refuses to replace an existing file
// unless overwrite is true.
void write_camera(const CameraParameters& camera, const std::filesystem::path& path, CameraFormat format,
                  bool overwrite = false);

}  // namespace fishcam
