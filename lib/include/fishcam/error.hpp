#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

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

}  // namespace fishcam
