// fishcam report CAMERA --corners FILE: a calibration's report page (HTML and PNG
// figures) from a camera file and the corners it was calibrated from.
#include <cstdio>
#include <filesystem>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/eval/calibration_report.hpp"
#include "fishcam/fit/calibration.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/corners.hpp"
#include "report_folder.hpp"

namespace fishcam::cli {

namespace {
// "rep/" is the folder "rep".
std::filesystem::path without_trailing_separator(const std::filesystem::path& folder) {
  return folder.has_filename() ? folder : folder.parent_path();
}
}  // namespace

void check_report_folder(const std::filesystem::path& given, const std::vector<std::string>& inputs, bool overwrite,
                         const std::vector<std::string>& outputs) {
  const std::filesystem::path folder = without_trailing_separator(given);
  const std::string name = path_for_message(given);
  if (folder.empty()) throw Error("--report: no folder given");
  check_output_not_input(folder, std::vector<std::filesystem::path>(inputs.begin(), inputs.end()), true);
  for (const std::string& output : outputs) {
    if (!output.empty() && is_same_file(folder, output)) throw Error(name + ": given as more than one output");
  }
  std::error_code ec;
  const std::filesystem::path parent = folder.parent_path().empty() ? "." : folder.parent_path();
  if (!std::filesystem::is_directory(parent, ec)) throw Error(name + ": its folder does not exist");
  const auto status = std::filesystem::status(folder, ec);  // a link to a folder is that folder
  if (!std::filesystem::exists(status)) return;
  if (!std::filesystem::is_directory(status)) throw Error(name + ": exists and is not a folder");
  if (!overwrite && !std::filesystem::is_empty(folder, ec)) {
    throw Error(name + ": exists and is not empty (refusing to mix a report with other files; use --force)");
  }
}

std::vector<std::pair<std::filesystem::path, std::string>> report_files(const std::filesystem::path& given,
                                                                        std::vector<ReportFile> files) {
  const std::filesystem::path folder = without_trailing_separator(given);
  std::vector<std::pair<std::filesystem::path, std::string>> out;
  for (auto& file : files) out.emplace_back(folder / file.name, std::move(file.bytes));
  return out;
}

void write_outputs_with_report(const std::vector<std::pair<std::filesystem::path, std::string>>& files,
                               const std::filesystem::path& given, bool overwrite) {
  const std::filesystem::path folder = without_trailing_separator(given);
  std::error_code ec;
  const bool created = !folder.empty() && std::filesystem::create_directory(folder, ec);
  if (ec) throw Error(path_for_message(given) + ": cannot create the folder (" + ec.message() + ")");
  try {
    write_outputs(files, overwrite);
  } catch (const Error&) {
    if (created) std::filesystem::remove(folder, ec);  // empty: nothing was renamed into it
    throw;
  }
}

void register_report(CLI::App& app) {
  auto* cmd = app.add_subcommand("report",
                                 "A calibration's report to look at: an HTML page with PNG figures (residuals over "
                                 "the image and per image, their histogram, board coverage, the observed domain, the "
                                 "projection uncertainty, per-image rms) from a camera and its corners");
  struct Options {
    std::string camera, corners, board, target, out;
    double spacing = 0;
    bool force = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("CAMERA", o->camera, "The calibrated camera (fishcam JSON from calibrate: with its uncertainty)")
      ->required();
  cmd->add_option("--corners", o->corners, "The corners it was calibrated from (corners.vnl)")->required();
  auto* board = cmd->add_option("--board", o->board, "Inner corners WxH (with --spacing)");
  auto* spacing = cmd->add_option("--spacing", o->spacing, "Corner spacing (m)")->check(CLI::PositiveNumber);
  cmd->add_option("--target", o->target,
                  "The target instead of --board and --spacing (charuco:... or aprilgrid:..., as calibrate --target)")
      ->excludes(board)
      ->excludes(spacing);
  cmd->add_option("--out", o->out, "The report's folder (created; index.html and the figures)")->required();
  cmd->add_flag("--force", o->force, "Write into a folder that is not empty, replacing the report's files");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, inputs] {
    check_report_folder(o->out, {o->camera, o->corners}, o->force, {});
    const BoardSpec board = board_or_target(o->board, o->spacing, o->target);
    const Camera camera = inputs->read(o->camera);
    // The boards are located without the valid domain's cap: a corner just past a
    // per-azimuth limit is still a corner of the calibration.
    CameraParameters unlimited = camera.parameters();
    unlimited.theta_limit.reset(), unlimited.theta_limit_by_azimuth.reset();
    const auto observations = read_corners(o->corners, board);
    const CalibrationResult located = locate_boards(observations, board, Camera(unlimited));
    auto files = report_files(o->out, calibration_report(located, camera.parameters(), observations, board,
                                                         std::filesystem::path(o->corners).filename().string()));
    const size_t count = files.size();
    write_outputs_with_report(files, o->out, o->force);
    std::printf("wrote %s (%zu figures): %zu images, rms %.4f px, %zu outliers\n",
                (std::filesystem::path(o->out) / "index.html").c_str(), count - 1, located.used_images.size(),
                located.rms_px, located.outliers.size());
  });
}

}  // namespace fishcam::cli
