// The source camera in the float kernel's form, decided once per ViewpointWarp: which
// cameras the kernel evaluates (float_source_params) and the check that it agrees with
// Camera::project (float_kernel_agrees). kernel_source.cpp.
#pragma once

#include <memory>
#include <vector>

#include "fishcam/core/camera.hpp"
#include "warp_kernel.hpp"

namespace fishcam::detail {

// The float kernel is used only where it agrees with the exact path to this.
constexpr double kFloatTolerancePx = 1e-3;

// SourceParams with the arrays its pointers refer to.
struct KernelSource {
  SourceParams params;
  std::vector<float> lens_cells;
};

// The source camera for the float kernel, or null where float arithmetic cannot be
// trusted to kFloatTolerancePx: the one place that decides.
std::shared_ptr<KernelSource> float_source_params(const Camera& camera);

// The kernel for this CPU against Camera::project over the source's whole valid
// domain (kernel_source.cpp says how): true when they agree to kFloatTolerancePx.
bool float_kernel_agrees(const Camera& camera, const SourceParams& src);

}  // namespace fishcam::detail
