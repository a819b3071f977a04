// The project/unproject filters' stdin records (tools/line_input.hpp).
#include <sstream>

#include "fuzz_harness.hpp"
#include "line_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fishcam::fuzz::expect_only_errors([&] {
    std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
    double sum = 0;
    fishcam::cli::for_each_record<3>(in, "x y z", [&](const auto& v) { sum += v[0] + v[1] + v[2]; });
  });
  return 0;
}
