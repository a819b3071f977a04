// mrcal corners files (calibration input).
#include "fishcam/fit/calibration.hpp"
#include "fishcam/io/corners.hpp"
#include "fuzz_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = fishcam::fuzz::as_file(data, size, ".vnl");
  fishcam::fuzz::expect_only_errors([&] { (void)fishcam::read_corners(path, fishcam::BoardSpec{10, 10, 0.1}); });
  return 0;
}
