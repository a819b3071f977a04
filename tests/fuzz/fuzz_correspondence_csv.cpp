// fishcam fit's correspondence CSV (tools/correspondence_csv.hpp).
#include "correspondence_csv.hpp"
#include "fuzz_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = fishcam::fuzz::as_file(data, size, ".csv");
  fishcam::fuzz::expect_only_errors([&] { (void)fishcam::cli::read_csv(path.string()); });
  return 0;
}
