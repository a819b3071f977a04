// Reading a --target spec ("charuco:8x6:0.04:0.03", "aprilgrid:6x6:0.088:0.3"): one
// place for the fields and numbers both targets' parsers take.
#pragma once

#include <charconv>
#include <string_view>
#include <system_error>
#include <vector>

namespace fishcam::detail {

// The colon-separated fields of `text` (an empty one where two colons meet).
inline std::vector<std::string_view> target_fields(std::string_view text) {
  std::vector<std::string_view> fields;
  for (size_t start = 0;;) {
    const size_t colon = text.find(':', start);
    fields.push_back(text.substr(start, colon == std::string_view::npos ? std::string_view::npos : colon - start));
    if (colon == std::string_view::npos) return fields;
    start = colon + 1;
  }
}

// The whole of `text` as a number (std::from_chars: "nan" and "inf" are numbers; the
// callers check ranges).
template <typename T>
bool parse_number(std::string_view text, T* value) {
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), *value);
  return error == std::errc() && end == text.data() + text.size();
}

// "COLSxROWS" as two integers.
inline bool parse_size(std::string_view text, int* cols, int* rows) {
  const size_t x = text.find('x');
  return x != std::string_view::npos && parse_number(text.substr(0, x), cols) && parse_number(text.substr(x + 1), rows);
}

}  // namespace fishcam::detail
