// The warp kernel for the baseline instruction set of the build (SSE2 on x86-64).
#define FISHCAM_KERNEL_ISA baseline
#include "warp_kernel_impl.hpp"

namespace fishcam::detail {

RangeKernel select_kernel_baseline(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  return baseline::select_kernel(prior, inside_sphere, kind, sampling);
}

// No fused bilinear: SSE2 has no pshufb / pmaddubsw (cv::remap then samples the image).
GridRowLoops grid_row_loops_baseline() { return {baseline::interpolate4, baseline::to_fixed_point, nullptr, nullptr}; }

}  // namespace fishcam::detail
