// Reads the Python-literal subset mrcal writes .cameramodel files in: dicts, lists,
// tuples, '...' and "..." strings, numbers, True/False/None, # comments and
// trailing commas. Internal to the library.
#pragma once

#include <nlohmann/json.hpp>
#include <string_view>

namespace fishcam::detail {

// Throws fishcam::Error "line L: problem" on malformed input.
nlohmann::json parse_python_literal(std::string_view text);

}  // namespace fishcam::detail
