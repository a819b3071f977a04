// Camera files: detection and every format's reader (FISHCAM_FUZZ_FORMAT forces
// one format; unset, the format is detected from the content as read_camera does).
#include "fishcam/io/camera_io.hpp"
#include "fuzz_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  fishcam::fuzz::expect_only_errors([&] {
#ifdef FISHCAM_FUZZ_FORMAT
    const fishcam::Camera camera(
        fishcam::parse_camera(text, "fuzz", *fishcam::parse_camera_format(FISHCAM_FUZZ_FORMAT)));
#else
    const fishcam::Camera camera(fishcam::parse_camera(text, "fuzz"));
#endif
    // What reads must write (or refuse in one line) and read back.
    for (const char* format : {"fishcam", "woodscape", "mrcal", "opencv"}) {
      try {
        const std::string out = fishcam::format_camera(camera.parameters(), *fishcam::parse_camera_format(format));
        (void)fishcam::parse_camera(out, "round trip", *fishcam::parse_camera_format(format));
      } catch (const fishcam::Error&) {
      }
    }
  });
  return 0;
}
