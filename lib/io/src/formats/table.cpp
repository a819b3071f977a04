#include "format.hpp"

namespace fishcam::detail {

// Each format's FormatSpec, NAME_format in lib/io/src/formats/NAME.cpp.
#define FISHCAM_DECLARE_FORMAT(name) extern const FormatSpec name##_format;
FISHCAM_CAMERA_FORMATS(FISHCAM_DECLARE_FORMAT)
#undef FISHCAM_DECLARE_FORMAT

const std::vector<const FormatSpec*>& format_table() {
#define FISHCAM_FORMAT_ENTRY(name) &name##_format,
  static const std::vector<const FormatSpec*> table = {FISHCAM_CAMERA_FORMATS(FISHCAM_FORMAT_ENTRY)};
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
