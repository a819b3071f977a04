// Reading whitespace-separated numbers from stdin, one record a line, for the
// project/unproject filters. Blank lines and lines starting with '#' are skipped.
#pragma once

#include <array>
#include <charconv>
#include <cstdio>
#include <iostream>
#include <string>

#include "fishcam/core/error.hpp"

namespace fishcam::cli {

// Calls on_record(values) for every record of N numbers; throws Error naming the
// line on anything else. "nan" and "inf" are numbers (they give invalid results).
// Records are short lines: a longer one (/dev/zero, a binary file) is refused as soon
// as it passes kMaxRecordChars, and a stream of more than kMaxRecords lines is cut
// off with an error, so no input grows memory or runs without end.
constexpr std::streamsize kMaxRecordChars = 4096;
constexpr long kMaxRecords = 100'000'000;

template <size_t N, class OnRecord>
void for_each_record(std::istream& in, const char* what, const OnRecord& on_record) {
  // getline stores at most size - 1 characters: a line of kMaxRecordChars fits, one more fails.
  std::string buffer(std::size_t(kMaxRecordChars) + 1, '\0');
  for (long number = 1;; ++number) {
    in.getline(buffer.data(), std::streamsize(buffer.size()));
    const std::streamsize got = in.gcount();
    if (in.bad()) throw Error("stdin line " + std::to_string(number) + ": read error");
    if (in.fail() && !in.eof()) {
      throw Error("stdin line " + std::to_string(number) + ": longer than " + std::to_string(kMaxRecordChars) +
                  " characters (not " + what + ")");
    }
    if (in.eof() && got == 0) break;
    if (number > kMaxRecords)
      throw Error("stdin: more than " + std::to_string(kMaxRecords) + " records (split the input)");
    const std::string line(buffer.data(), std::size_t(in.eof() ? got : got - 1));
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
        throw Error("stdin line " + std::to_string(number) + ": expected " + what + ", got " +
                    quoted_for_message(line));
      }
      p = next;
    }
    skip_space();
    if (p != end) {
      throw Error("stdin line " + std::to_string(number) + ": expected " + what + " (too many values), got " +
                  quoted_for_message(line));
    }
    on_record(values);
    if (in.eof()) break;
  }
}

}  // namespace fishcam::cli
