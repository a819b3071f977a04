// The warp kernel for AVX2 + FMA (8 floats per vector), compiled with -mavx2
// -mfma and used only where the CPU has them. CV_CPU_DISPATCH_MODE puts OpenCV's
// intrinsics in their own namespace, so nothing is shared with the baseline object.
// Outside OpenCV's own build its headers derive only SSE2 from the compiler's
// flags, so the instruction sets this file is compiled for are named here.
#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#define CV_SSE3 1
#define CV_SSSE3 1
#define CV_SSE4_1 1
#define CV_SSE4_2 1
#define CV_AVX 1
#define CV_FMA3 1
#define CV_AVX2 1
#endif
#define CV_CPU_DISPATCH_MODE AVX2
#define FISHCAM_KERNEL_ISA avx2
#include "warp_kernel_impl.hpp"

namespace fishcam::detail {

RangeKernel select_kernel_avx2(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  return avx2::select_kernel(prior, inside_sphere, kind, sampling);
}

GridRowLoops grid_row_loops_avx2() { return {avx2::interpolate4, avx2::to_fixed_point}; }

}  // namespace fishcam::detail
