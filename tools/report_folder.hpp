// The folder a calibration report goes to (fishcam calibrate --report, fishcam report).
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "fishcam/eval/calibration_report.hpp"

namespace fishcam::cli {

// Before anything is computed: the folder ("rep/" is "rep") is no input and holds
// none, is none of the command's other outputs, its parent exists, and unless
// overwrite it is absent or empty (a report never mixes with other files, nor
// replaces them).
void check_report_folder(const std::filesystem::path& folder, const std::vector<std::string>& inputs, bool overwrite,
                         const std::vector<std::string>& outputs);

// The report's files as paths in the folder, to be written together with the
// command's other outputs (write_outputs_with_report).
std::vector<std::pair<std::filesystem::path, std::string>> report_files(const std::filesystem::path& folder,
                                                                        std::vector<ReportFile> files);

// write_outputs, the folder created first (if absent) and removed again if the
// writing fails: a refused command leaves nothing behind.
void write_outputs_with_report(const std::vector<std::pair<std::filesystem::path, std::string>>& files,
                               const std::filesystem::path& folder, bool overwrite);

}  // namespace fishcam::cli
