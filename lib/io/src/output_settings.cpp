#include "fishcam/io/output_settings.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>

#include "fishcam/core/error.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/file_input.hpp"

namespace fishcam {
namespace {

namespace fs = std::filesystem;

// A settings record is small; anything larger is not one.
constexpr std::size_t kMaxRecordBytes = 1 << 16;

// JSON holds UTF-8 only: a value that is not (a path of Latin-1 bytes) is recorded
// with its other bytes as \xNN, the same way every time, so runs still compare.
std::string as_utf8(const std::string& value) {
  if (is_valid_utf8(value)) return value;
  std::string out;
  for (const char c : value) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x80) {
      out.push_back(c);
    } else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", byte);
      out += hex;
    }
  }
  return out;
}

nlohmann::ordered_json record_json(const OutputSettings& settings) {
  nlohmann::ordered_json values = nlohmann::ordered_json::object();
  for (const auto& [option, value] : settings.values) values[as_utf8(option)] = as_utf8(value);
  return {{"fishcam", settings.command}, {"version", fishcam_version()}, {"settings", values}};
}

}  // namespace

const char* fishcam_version() { return FISHCAM_VERSION; }

std::string OutputSettings::record() const { return record_json(*this).dump(); }

bool OutputSettings::is_record(const std::string& line, const std::string& command) {
  const nlohmann::json parsed = nlohmann::json::parse(line, nullptr, false);
  return parsed.is_object() && parsed.contains("settings") && parsed["settings"].is_object() &&
         parsed.value("fishcam", std::string()) == command && parsed.contains("version");
}

bool claim_output_settings(const fs::path& file, const OutputSettings& settings, bool record) {
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(file, ec))) {
    if (!record) return false;
    try {
      write_file_atomically(file, settings.record() + "\n", false);
      return false;
    } catch (const Error&) {
      if (!fs::exists(fs::symlink_status(file, ec))) throw;  // not another run's record: a real failure
    }
  }
  const std::string text = read_bounded_file(file, kMaxRecordBytes);
  const std::string where = path_for_message(file);
  const nlohmann::json theirs = nlohmann::json::parse(text, nullptr, false);
  if (!OutputSettings::is_record(text, settings.command)) {
    throw Error(where + ": not a record of fishcam " + settings.command +
                "'s settings (this folder holds files of something else: use another output folder)");
  }
  const std::string their_version = theirs["version"].is_string() ? theirs["version"].get<std::string>() : "?";
  if (their_version != fishcam_version()) {
    throw Error(where + ": this folder was written by fishcam " + text_for_message(their_version) + ", this is " +
                fishcam_version() + " (outputs may differ: use another output folder)");
  }
  const nlohmann::json& values = theirs["settings"];
  for (const auto& [raw_option, raw_value] : settings.values) {
    const std::string option = as_utf8(raw_option), value = as_utf8(raw_value);
    const auto found = values.find(option);
    const std::string their_value = found == values.end() ? "(not given)"
                                    : found->is_string()  ? found->get<std::string>()
                                                          : found->dump();
    if (their_value != value) {
      throw Error(option + ": this folder was written with " + quoted_for_message(their_value) + ", this run has " +
                  quoted_for_message(value) + " (" + where + "; use another output folder, or the same settings)");
    }
  }
  for (const auto& [option, value] : values.items()) {
    bool known = false;
    for (const auto& mine_value : settings.values) known = known || as_utf8(mine_value.first) == option;
    if (!known) {
      throw Error(where + ": this folder was written with " + text_for_message(option) +
                  ", which this run does not have (use another output folder, or the same settings)");
    }
  }
  return true;
}

}  // namespace fishcam
