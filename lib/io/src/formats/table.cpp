#include <algorithm>

#include "format.hpp"

namespace fishcam::detail {

// Each format's FormatSpec, NAME_format in lib/io/src/formats/NAME.cpp.
#define FISHCAM_DECLARE_FORMAT(name) extern const FormatSpec name##_format;
FISHCAM_CAMERA_FORMATS(FISHCAM_DECLARE_FORMAT)
#undef FISHCAM_DECLARE_FORMAT

const std::vector<const FormatSpec*>& format_table() {
#define FISHCAM_FORMAT_ENTRY(name) &name##_format,
  static const std::vector<const FormatSpec*> table = [] {
    std::vector<const FormatSpec*> specs = {FISHCAM_CAMERA_FORMATS(FISHCAM_FORMAT_ENTRY)};
    // A format declares registered plane distortions only (a misspelt one would make
    // the format refuse the part without a word): checked once, on first use.
    const auto& parts = plane_distortion_names();
    for (const FormatSpec* spec : specs) {
      for (const HeldDistortion& held : spec->distortions) {
        if (std::find(parts.begin(), parts.end(), held.part) == parts.end()) {
          throw Error("internal: the " + std::string(spec->name) + " format declares an unknown plane distortion " +
                      std::string(held.part));
        }
      }
    }
    return specs;
  }();
#undef FISHCAM_FORMAT_ENTRY
  return table;
}

const FormatSpec& format_spec(CameraFormat format) {
  for (const FormatSpec* spec : format_table()) {
    if (spec->id == format) return *spec;
  }
  throw Error("unknown camera format");
}

}  // namespace fishcam::detail
