#include "fishcam/error.hpp"

#include <cstdio>

namespace fishcam {

std::string quoted_for_message(std::string_view text, size_t limit) {
  std::string out = "'";
  size_t shown = 0;
  for (const char c : text) {
    if (shown++ == limit) {
      out += "...";
      break;
    }
    const auto byte = static_cast<unsigned char>(c);
    switch (c) {
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      case '\'': out += "\\'"; break;
      case '\\': out += "\\\\"; break;
      default:
        if (byte < 0x20 || byte >= 0x7f) {
          char hex[5];
          std::snprintf(hex, sizeof hex, "\\x%02x", byte);
          out += hex;
        } else {
          out += c;
        }
    }
  }
  return out + "'";
}

}  // namespace fishcam
