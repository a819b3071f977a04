// numpy .npy files (maps).
#include "fishcam/io/npy.hpp"
#include "fuzz_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = fishcam::fuzz::as_file(data, size, ".npy");
  fishcam::fuzz::expect_only_errors([&] { (void)fishcam::read_npy(path); });
  return 0;
}
