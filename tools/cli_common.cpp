#include "cli_common.hpp"
#include <charconv>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <sstream>

#include "fishcam/augment/scene.hpp"
#include "fishcam/augment/target.hpp"
#include "fishcam/core/error.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/camera_io.hpp"

namespace fishcam::cli {

RigidMotion PoseOptions::motion() const {
  return RigidMotion::from_euler_deg({rotate[0], rotate[1], rotate[2]}, {translate[0], translate[1], translate[2]});
}

DepthPrior PoseOptions::prior() const { return depth_prior(depth, "--depth"); }

void add_pose_options(CLI::App* cmd, PoseOptions* options, bool with_depth, bool with_depth_map) {
  cmd->add_option("--rotate", options->rotate,
                  "Rotation rx,ry,rz in degrees about the camera x, y, z axes "
                  "(R = Rz Ry Rx, acting on the points)")
      ->delimiter(',')
      ->expected(3);
  cmd->add_option("--translate", options->translate, "Translation tx,ty,tz in unit-sphere units (metres for render)")
      ->delimiter(',')
      ->expected(3);
  if (with_depth) {
    cmd->add_option("--depth", options->depth,
                    with_depth_map ? "Depth prior, or map: the source image's depth map (--depth-file)" : "Depth prior")
        ->check(CLI::IsMember(with_depth_map ? depth_prior_and_map_names() : depth_prior_names()))
        ->capture_default_str();
  }
}

ViewpointWarp make_warp(const CameraInputs& inputs, const std::string& source, const std::string& target) {
  const Camera source_camera = inputs.read(source);
  return target.empty() ? ViewpointWarp(source_camera) : ViewpointWarp(source_camera, inputs.read(target));
}

nlohmann::json affine_to_json(const AffineChange& change) {
  return {{"method", "affine"},
          {"rotation_deg", change.rotation_deg},
          {"translation", {change.translation.x(), change.translation.y()}},
          {"scale", change.scale}};
}

bool lossless_label_format(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".pgm";
}

std::string encode_image(const std::filesystem::path& path, const cv::Mat& image) {
  std::vector<uchar> bytes;
  bool ok = false;
  try {
    ok = cv::imencode(path.extension().string(), image, bytes);
  } catch (const cv::Exception& e) {
    throw Error(path_for_message(path) + ": cannot encode the image in this format (" + e.err + ")");
  }
  if (!ok) throw Error(path_for_message(path) + ": cannot encode the image in this format");
  return std::string(bytes.begin(), bytes.end());
}

void check_outputs(const std::vector<OutputFile>& outputs, const std::vector<std::string>& inputs, bool overwrite) {
  std::vector<std::filesystem::path> input_paths(inputs.begin(), inputs.end());
  std::vector<std::filesystem::path> taken;
  for (const OutputFile& out : outputs) {
    if (out.path.empty()) continue;
    check_output_not_input(out.path, input_paths, false);
    for (const std::filesystem::path& earlier : taken) {
      if (is_same_file(out.path, earlier)) throw Error(path_for_message(out.path) + ": given as more than one output");
    }
    taken.push_back(out.path);
    if (out.labels && !lossless_label_format(out.path)) {
      throw Error(path_for_message(out.path) + ": labels need a lossless format (.png, .tif, .pgm)");
    }
    std::error_code ec;
    if (!std::filesystem::is_directory(out.path.parent_path().empty() ? "." : out.path.parent_path(), ec)) {
      throw Error(path_for_message(out.path) + ": its folder does not exist");
    }
    if (!overwrite && std::filesystem::exists(std::filesystem::symlink_status(out.path, ec))) {
      throw Error(path_for_message(out.path) + ": already exists (refusing to overwrite; use --force)");
    }
  }
}

void write_images(const std::vector<std::pair<std::filesystem::path, cv::Mat>>& images, bool overwrite) {
  std::vector<std::pair<std::filesystem::path, std::string>> files;
  for (const auto& [path, image] : images) files.emplace_back(path, encode_image(path, image));
  write_outputs(files, overwrite);
}

void write_outputs(const std::vector<std::pair<std::filesystem::path, std::string>>& files, bool overwrite) {
  try {
    write_files_atomically(files, overwrite);
  } catch (const Error& e) {
    const std::string message = e.what();
    throw Error(message.ends_with("(refusing to overwrite)") ? message + "; use --force" : message);
  }
}

void write_image(const std::filesystem::path& path, const cv::Mat& image, bool overwrite) {
  write_images({{path, image}}, overwrite);
}

std::vector<std::string> split_commas(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream stream(text);
  for (std::string part; std::getline(stream, part, ',');) parts.push_back(part);
  return parts;
}

std::vector<std::string> distinct_names(const std::string& text, const std::string& option) {
  std::vector<std::string> names = split_commas(text);
  if (!text.empty() && text.back() == ',') names.emplace_back();
  if (names.empty()) throw Error(option + ": expected one or more names separated by commas, got ''");
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i].empty()) throw Error(option + ": an empty name in " + quoted_for_message(text));
    for (std::size_t j = 0; j < i; ++j) {
      if (names[j] == names[i]) throw Error(option + ": " + quoted_for_message(names[i]) + " is given twice");
    }
  }
  return names;
}

std::filesystem::path bundled_data(const std::string& name) {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto installed = exe.parent_path().parent_path() / "share" / "fishcam" / name;
    if (std::filesystem::exists(installed, ec)) return installed;
  }
  for (const char* dir : {FISHCAM_SOURCE_DATA_DIR, FISHCAM_SOURCE_TOOLS_DIR}) {
    const auto source_tree = std::filesystem::path(dir) / name;
    if (std::filesystem::exists(source_tree, ec)) return source_tree;
  }
  throw Error("bundled file " + name + " not found (looked in ../share/fishcam next to the program and in " +
              std::string(FISHCAM_SOURCE_DATA_DIR) + ")");
}

std::string describe(const Eigen::Vector3d& r, const Eigen::Vector3d& t) {
  char buffer[200];
  std::snprintf(buffer, sizeof buffer, "rotation [%.4f, %.4f, %.4f] deg, translation [%.4f, %.4f, %.4f]", r.x(), r.y(),
                r.z(), t.x(), t.y(), t.z());
  return buffer;
}

CameraFormat output_format(const std::string& format, const std::filesystem::path& out) {
  if (!format.empty()) return *parse_camera_format(format);
  if (const auto f = camera_format_for_extension(out)) return *f;
  throw Error(path_for_message(out) + ": cannot tell the format from the extension; pass --format");
}

namespace {
// The library's format names (its one table), for CLI11's checks.
std::vector<std::string> format_names() {
  std::vector<std::string> names;
  for (CameraFormat f : camera_formats()) names.emplace_back(to_string(f));
  return names;
}

}  // namespace

std::pair<int, int> parse_image_size(const std::string& text, const std::string& option) {
  const size_t at = text.find_first_of(",x");
  int w = 0, h = 0;
  size_t used_w = 0, used_h = 0;
  try {
    if (at != std::string::npos) {
      w = std::stoi(text.substr(0, at), &used_w);
      h = std::stoi(text.substr(at + 1), &used_h);
    }
  } catch (const std::exception&) {
    used_w = 0;
  }
  if (at == std::string::npos || used_w != at || used_h != text.size() - at - 1 || w < 1 || h < 1 || w > 65536 ||
      h > 65536) {
    throw Error(option + ": expected W,H or WxH (positive integers), got " + quoted_for_message(text));
  }
  return {w, h};
}

std::shared_ptr<const CameraInputs> add_camera_input_options(CLI::App* cmd) {
  auto o = std::make_shared<CameraInputs>();
  cmd->add_option("--camera", o->camera, "Which camera of a file with several (name or index; default: the first)");
  cmd->add_option("--imagersize", o->imagersize, "Image size W,H (or WxH) for camera files without one");
  const bool format_taken = cmd->get_option_no_throw("--format") != nullptr;
  cmd->add_option(format_taken ? "--input-format" : "--format", o->format,
                  "Read camera files as this format (default: detected): " + camera_format_names())
      ->check(CLI::IsMember(format_names()));
  cmd->add_option("--distortion-model", o->distortion_model,
                  "For OpenCV files that do not say: fisheye (Kannala-Brandt) or plumb_bob (radial-tangential)")
      ->check(CLI::IsMember({"fisheye", "plumb_bob"}));
  return o;
}

Camera CameraInputs::read(const std::filesystem::path& path, CameraFileInfo* info_out) const {
  CameraReadOptions options;
  if (!camera.empty()) options.camera = camera;
  if (!imagersize.empty()) options.image_size = parse_image_size(imagersize, "--imagersize");
  if (!format.empty()) options.format = parse_camera_format(format);
  if (!distortion_model.empty()) options.distortion_model = distortion_model;
  CameraFileInfo info;
  Camera result = read_camera(path, options, &info);
  for (const std::string& note : info.notes) {
    std::fprintf(stderr, "fishcam: note: %s: %s\n", path_for_message(path).c_str(), note.c_str());
  }
  if (info_out) *info_out = info;
  return result;
}

void add_camera_output_options(CLI::App* cmd, CameraOutputOptions* options) {
  cmd->add_option("--out", options->out, "Output camera file")->required();
  cmd->add_option("--format", options->format, "Output format (default: from the extension; .json = fishcam)")
      ->check(CLI::IsMember(format_names()));
  cmd->add_flag("--json", options->json, "Print the report as one JSON object");
  cmd->add_flag("--force", options->force, "Replace an existing output file");
}

void note_dropped_record(const CameraParameters& camera, CameraFormat format, const std::string& out) {
  if (camera.calibration && !camera_format_holds_calibration_record(format)) {
    std::fprintf(stderr,
                 "fishcam: note: the %s format cannot hold the calibration record (observed angles%s); %s was written "
                 "without it (fishcam JSON keeps it)\n",
                 std::string(to_string(format)).c_str(),
                 camera.calibration->covariance.size() ? ", projection uncertainty" : "", out.c_str());
  }
}

void write_camera_file(const CameraParameters& camera, const std::string& out, CameraFormat format, bool force) {
  write_camera(camera, out, format, force);
  note_dropped_record(camera, format, out);
}

void add_theta_limit_option(CLI::App* cmd, std::string* text) {
  cmd->add_option("--theta-limit", *text,
                  "data[+DEG]: cap the valid domain at the largest angle of incidence the calibration observed "
                  "(plus DEG degrees)");
}

CameraParameters apply_theta_limit(const CameraParameters& camera, const std::string& text) {
  if (text.empty()) return camera;
  double margin_deg = 0;
  if (text != "data") {
    const std::string prefix = "data+";
    if (text.rfind(prefix, 0) != 0) {
      throw Error("--theta-limit: expected data or data+DEG (degrees beyond the observed angles), got '" + text + "'");
    }
    const std::string number = text.substr(prefix.size());
    const char* end = number.c_str();
    margin_deg = number.empty() ? std::nan("") : std::strtod(number.c_str(), const_cast<char**>(&end));
    if (*end != '\0' || !std::isfinite(margin_deg) || margin_deg < 0) {
      throw Error("--theta-limit: the margin after data+ must be a number of degrees >= 0, got '" + number + "'");
    }
  }
  return limited_to_observed(camera, margin_deg * std::numbers::pi / 180);
}

void print_fit_report(const CameraParameters& fitted, const ErrorReport& report, const char* over_what) {
  std::printf("parameters      ");
  for (double p : model_params(fitted.model)) std::printf(" %.10g", p);
  std::printf("\nprincipal point  (%.6f, %.6f), pixel scale (%.10g, %.10g)\n", fitted.grid.principal_point.x(),
              fitted.grid.principal_point.y(), fitted.grid.pixel_scale.x(), fitted.grid.pixel_scale.y());
  std::printf("pixel error over %ld %s: rms %.4f, p99 %.4f, max %.4f px", report.samples, over_what, report.rms_px,
              report.p99_px, report.max_px);
  if (report.unprojectable) std::printf(" (%ld outside the new model's domain)", report.unprojectable);
  std::printf("\n  theta (deg)   samples     rms px      max px\n");
  for (const auto& b : report.by_angle) {
    std::printf("  %5.0f-%-5.0f %8ld %11.4f %11.4f\n", b.theta_from_deg, b.theta_to_deg, b.samples, b.rms_px, b.max_px);
  }
}

BoardSpec parse_board(const std::string& text, double spacing) {
  int cols = 0, rows = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &cols, &x, &rows, &extra) != 3 || x != 'x' || cols < 2 || rows < 2) {
    throw Error("--board: expected WxH inner corners (e.g. 10x10), got " + quoted_for_message(text));
  }
  const BoardSpec board{cols, rows, spacing};
  try {
    check_board(board);
  } catch (const Error& e) {
    throw Error(std::string("--board/--spacing: ") + e.what());
  }
  return board;
}

BoardSpec board_or_target(const std::string& board, double spacing, const std::string& target) {
  if (!target.empty()) return target_board(parse_target(target));
  if (board.empty() || !(spacing > 0)) {
    throw Error("give --board WxH and --spacing S (a chessboard), or --target charuco:... or aprilgrid:...");
  }
  return parse_board(board, spacing);
}

cv::Mat colourise_labels(const cv::Mat& labels) {
  cv::Mat out(labels.size(), CV_8UC3);
  for (int v = 0; v < labels.rows; ++v) {
    for (int u = 0; u < labels.cols; ++u) out.at<cv::Vec3b>(v, u) = woodscape_class_colour(labels.at<uchar>(v, u));
  }
  return out;
}

}  // namespace fishcam::cli
