// The folder a calibration report goes to (fishcam calibrate --report, fishcam report).
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "fishcam/eval/calibration_report.hpp"

namespace fishcam::cli {

// Before anything is computed: the folder is no input and holds none, its parent
// exists, and unless overwrite it is absent or empty (a report never mixes with
// other files, nor replaces them).
void check_report_folder(const std::filesystem::path& folder, const std::vector<std::string>& inputs, bool overwrite);

// The report's files as paths in the folder (created if absent), to be written
// together with the command's other outputs.
std::vector<std::pair<std::filesystem::path, std::string>> report_files(const std::filesystem::path& folder,
                                                                        std::vector<ReportFile> files);

}  // namespace fishcam::cli
