// Reading whitespace-separated numbers from stdin, one record a line, for the
// project/unproject filters. Blank lines and lines starting with '#' are skipped.
#pragma once

#include <array>
#include <charconv>
#include <cstdio>
#include <iostream>
#include <string>

#include "fishcam/error.hpp"

namespace fishcam::cli {

// Calls on_record(values) for every record of N numbers; throws Error naming the
// line on anything else. "nan" and "inf" are numbers (they give invalid results).
template <size_t N, class OnRecord>
void for_each_record(std::istream& in, const char* what, const OnRecord& on_record) {
  std::string line;
  for (long number = 1; std::getline(in, line); ++number) {
    const char* p = line.data();
    const char* end = p + line.size();
    auto skip_space = [&] {
      while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
    };
    skip_space();
    if (p == end || *p == '#') continue;
    std::array<double, N> values{};
    for (size_t i = 0; i < N; ++i) {
      skip_space();
      const auto [next, ec] = std::from_chars(p, end, values[i]);
      if (ec != std::errc() || (next < end && *next != ' ' && *next != '\t' && *next != '\r')) {
        throw Error("stdin line " + std::to_string(number) + ": expected " + what + ", got " + quoted_for_message(line));
      }
      p = next;
    }
    skip_space();
    if (p != end) {
      throw Error("stdin line " + std::to_string(number) + ": expected " + what + " (too many values), got " +
                  quoted_for_message(line));
    }
    on_record(values);
  }
}

}  // namespace fishcam::cli
