#include "format.hpp"

namespace fishcam::detail {

extern const FormatSpec kWoodScapeFormat, kFishcamFormat, kMrcalFormat, kOpenCvFormat, kKalibrFormat, kBasaltFormat,
    kColmapFormat, kRosFormat, kCamodocalFormat, kOrbSlam3Format;

// The one table of formats: one line each.
const std::vector<const FormatSpec*>& format_table() {
  static const std::vector<const FormatSpec*> table = {
      &kWoodScapeFormat, &kMrcalFormat, &kOpenCvFormat,    &kFishcamFormat,  &kKalibrFormat,
      &kBasaltFormat,    &kColmapFormat, &kRosFormat,      &kCamodocalFormat, &kOrbSlam3Format,
  };
  return table;
}

const FormatSpec& format_spec(CameraFormat format) {
  for (const FormatSpec* spec : format_table()) {
    if (spec->id == format) return *spec;
  }
  throw Error("unknown camera format");
}

}  // namespace fishcam::detail
