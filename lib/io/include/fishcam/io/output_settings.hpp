// What a command that fills an output folder ran with, kept in the folder so that a
// later run (a resume, another shard) can tell whether it would continue the same
// work: outputs depend on every setting, so a resume with another seed, preset or
// method would mix two datasets under one manifest. The settings are (option, value)
// pairs as the command names them ("--seed", "5"); the record is one JSON object,
//   {"fishcam": COMMAND, "version": VERSION, "settings": {OPTION: VALUE, ...}}
// written once, atomically, by the first run, and put as the first line of the
// command's manifests, where it also tells a manifest fishcam wrote from any other file.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace fishcam {

struct OutputSettings {
  std::string command;                                      // "augment-dataset"
  std::vector<std::pair<std::string, std::string>> values;  // ("--seed", "5"), in a fixed order

  // The record as one line of JSON (no newline); the library's version included.
  std::string record() const;
  // Whether line is a record of `command`'s settings (any version or values).
  static bool is_record(const std::string& line, const std::string& command);
};

// fishcam's version (CMake's project version), part of every settings record.
const char* fishcam_version();

// Compares settings with the record in `file` when it exists; when it does not and
// `record` is set, records them there (created exclusively: of two runs starting
// together one records, the other compares). Throws Error naming the file and the
// first difference ("--seed: this folder was written with '5', this run has '6' (...;
// use another output folder, or the same settings)"), or that the file is not such a
// record. Returns whether it existed.
bool claim_output_settings(const std::filesystem::path& file, const OutputSettings& settings, bool record = true);

}  // namespace fishcam
