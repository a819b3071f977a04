// The float kernel's pose form and the kernel for this CPU (warp_kernel.hpp).
#include <opencv2/core.hpp>

#include <cstdlib>

#include "grid_warp.hpp"
#include "warp_kernel.hpp"

namespace fishcam::detail {

PoseParams pose_params(const RigidMotion& change) {
  PoseParams p;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) p.rt[3 * r + k] = float(change.rotation(k, r));
  }
  for (int k = 0; k < 3; ++k) p.t[k] = float(change.translation[k]);
  p.c = float(change.translation.squaredNorm() - 1);
  return p;
}

// The kernel for this CPU: AVX2 + FMA where available, else the build's baseline.
// FISHCAM_NO_AVX2 (set to anything) forces the baseline: how the tests cover it.
bool use_avx2() {
  static const bool avx2 =
      !std::getenv("FISHCAM_NO_AVX2") && cv::checkHardwareSupport(CV_CPU_AVX2) && cv::checkHardwareSupport(CV_CPU_FMA3);
  return avx2;
}

RangeKernel select_kernel_for_cpu(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  return use_avx2() ? select_kernel_avx2(prior, inside_sphere, kind, sampling)
                    : select_kernel_baseline(prior, inside_sphere, kind, sampling);
}

GridRowLoops grid_row_loops_for_cpu() { return use_avx2() ? grid_row_loops_avx2() : grid_row_loops_baseline(); }

}  // namespace fishcam::detail
