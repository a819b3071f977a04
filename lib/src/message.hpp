// Untrusted text inside error messages: every message stays one line.
#pragma once

#include <string>
#include <string_view>

namespace fishcam::detail {

// 'text' in single quotes with C-style escapes for quotes, backslashes, control
// and non-ASCII bytes, cut after `limit` characters with "...".
std::string quoted_for_message(std::string_view text, size_t limit = 60);

}  // namespace fishcam::detail
