#pragma once

#include "fishcam/core/error.hpp"

#include <sstream>

namespace fishcam::detail {

// Throws Error with `parts` streamed into one message.
template <typename... T>
[[noreturn]] void fail(const T&... parts) {
  std::ostringstream message;
  (message << ... << parts);
  throw Error(message.str());
}

}  // namespace fishcam::detail
