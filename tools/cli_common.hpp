// What several subcommands share: pose options, image files, bundled data.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "fishcam/augment/affine.hpp"
#include "fishcam/augment/augmentation.hpp"
#include "fishcam/augment/viewpoint.hpp"
#include "fishcam/core/camera.hpp"
#include "fishcam/fit/calibration.hpp"
#include "fishcam/fit/fit.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/camera_io.hpp"

namespace fishcam::cli {

// --rotate rx,ry,rz (degrees, R = Rz Ry Rx), --translate tx,ty,tz, --depth PRIOR.
struct PoseOptions {
  std::vector<double> rotate{0, 0, 0};
  std::vector<double> translate{0, 0, 0};
  std::string depth = "source-sphere";
  RigidMotion motion() const;
  DepthPrior prior() const;
};
// with_depth_map: --depth also takes "map" (the caller then reads a depth map).
void add_pose_options(CLI::App* cmd, PoseOptions* options, bool with_depth = true, bool with_depth_map = false);

// How a subcommand reads its camera files: --camera NAME|INDEX, --imagersize W,H
// (or WxH), --format (--input-format where --format names the output) and
// --distortion-model, held per subcommand (no process-wide option state); notes
// (which camera, what was not read) go to stderr.
struct CameraInputs {
  std::string camera, imagersize, format, distortion_model;
  Camera read(const std::filesystem::path& path, CameraFileInfo* info = nullptr) const;
};
// Adds those options to cmd (after any --format of its own) and returns where they land.
std::shared_ptr<const CameraInputs> add_camera_input_options(CLI::App* cmd);
// "a,b,c" -> {"a", "b", "c"} (empty parts kept).
std::vector<std::string> split_commas(const std::string& text);
// The names of a comma-separated list option (--preset, --cameras, --test-sets):
// refuses an empty list, an empty name and a name given twice, naming the option.
std::vector<std::string> distinct_names(const std::string& text, const std::string& option);
// "W,H" or "WxH" as positive integers; throws Error naming the option.
std::pair<int, int> parse_image_size(const std::string& text, const std::string& option);

// The warp from SOURCE to TARGET (TARGET empty: the source camera again).
ViewpointWarp make_warp(const CameraInputs& inputs, const std::string& source, const std::string& target);

// Whether labels survive the format of path's extension (PNG, TIFF, PGM; not JPEG).
bool lossless_label_format(const std::filesystem::path& path);
// A file a command will write (empty path: not requested); labels need a lossless format.
struct OutputFile {
  std::filesystem::path path;
  bool labels = false;
};
// Checks every output before anything is computed or written: none is an input
// or given twice, label files are lossless, folders exist, and nothing is
// replaced unless overwrite.
void check_outputs(const std::vector<OutputFile>& outputs, const std::vector<std::string>& inputs, bool overwrite);
// The file content of an image in the format of path's extension; throws Error naming the file.
std::string encode_image(const std::filesystem::path& path, const cv::Mat& image);
// Encodes all images first, then commits them together (fishcam/io/atomic_file.hpp).
void write_images(const std::vector<std::pair<std::filesystem::path, cv::Mat>>& images, bool overwrite);
void write_image(const std::filesystem::path& path, const cv::Mat& image, bool overwrite);
// Commits files (path, bytes) together; a refusal to overwrite suggests --force.
void write_outputs(const std::vector<std::pair<std::filesystem::path, std::string>>& files, bool overwrite);

// A bundled file (data/NAME, or a helper script of tools/): next to an installed
// binary (../share/fishcam) or in the source tree this binary was built from.
std::filesystem::path bundled_data(const std::string& name);

// An affine change as augment --json and the manifest record it: method "affine",
// rotation_deg, translation [tx, ty] (fractions of the image size), scale.
nlohmann::json affine_to_json(const AffineChange& change);

// "rotation [rx, ry, rz] deg, translation [tx, ty, tz]".
std::string describe(const Eigen::Vector3d& rotation_deg, const Eigen::Vector3d& translation);

// The output format: --format if given, else from the extension (.cameramodel,
// .yaml/.yml/.xml, .json = fishcam).
CameraFormat output_format(const std::string& format, const std::filesystem::path& out);

// --out FILE (required), --format, --json, --force: what subcommands that write a
// camera and print a report (convert, fit, calibrate) share.
struct CameraOutputOptions {
  std::string out, format;
  bool json = false, force = false;
  CameraFormat resolved_format() const { return output_format(format, out); }
};
void add_camera_output_options(CLI::App* cmd, CameraOutputOptions* options);

// Writes a camera (atomically; refuses to replace a file unless force) and says on
// stderr when the format leaves out the camera's calibration record.
void write_camera_file(const CameraParameters& camera, const std::string& out, CameraFormat format, bool force);
// The note alone, for commands that write the camera with other files.
void note_dropped_record(const CameraParameters& camera, CameraFormat format, const std::string& out);

// --theta-limit data[+DEG] (calibrate, convert): the camera capped at its observed
// angles plus DEG (fishcam::limited_to_observed); text empty: the camera as it is.
void add_theta_limit_option(CLI::App* cmd, std::string* text);
CameraParameters apply_theta_limit(const CameraParameters& camera, const std::string& text);

// A fitted camera and its error report as text (as JSON: fishcam::fit_report_json).
void print_fit_report(const CameraParameters& fitted, const ErrorReport& report, const char* over_what);

// --board WxH (inner corners) with the corner spacing.
BoardSpec parse_board(const std::string& text, double spacing);
// The board of --board WxH and --spacing S (a chessboard) or of --target (charuco:...
// or aprilgrid:...: fishcam/augment/target.hpp), refused in one line unless one of
// them is given.
BoardSpec board_or_target(const std::string& board, double spacing, const std::string& target);

// Labels as colours (WoodScape classes), for looking at.
cv::Mat colourise_labels(const cv::Mat& labels);

}  // namespace fishcam::cli
