#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace fishcam {

// Every failure the library reports: a one-line message naming what was wrong
// ("front.json: intrinsic.k1: expected a number, got string").
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Untrusted text for a message: in single quotes, with C-style escapes for quotes,
// backslashes, control and non-ASCII bytes, cut after `limit` characters with
// "..." (so every message stays one line).
std::string quoted_for_message(std::string_view text, std::size_t limit = 60);

// Text from a file or an argument for a message: as it is when it is printable
// ASCII of at most 80 characters (names and numbers stay readable), else
// quoted_for_message's form.
std::string text_for_message(std::string_view text);

// A path for a message: as it is when it is printable UTF-8 without control
// characters (the common case stays readable), else quoted_for_message's form.
std::string path_for_message(const std::filesystem::path& path);

// A number for a message: the shortest %g form that reads back as the same double
// (90 is "90", 90 + 1e-9 is "90.000000001", the largest double "1.7976931348623157e+308").
std::string number_for_message(double value);

// "a, b or c" (or "a, b and c"): names for a message.
std::string choices_for_message(const std::vector<std::string>& names, std::string_view conjunction = "or");

// Whether text is well-formed UTF-8 (no overlong forms, surrogates or bytes past U+10FFFF).
bool is_valid_utf8(std::string_view text);

}  // namespace fishcam
