#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace fishcam {

// Where a source pixel's scene point is assumed to be (docs/augmentation.md).
enum class DepthPrior {
  source_sphere,  // on the source camera's unit sphere (the paper)
  target_sphere,  // at distance 1 along the output ray (mrcal's distance = 1)
  infinity,       // at infinity: rotation only, translation ignored (mrcal's default)
};
std::string_view to_string(DepthPrior prior);
std::optional<DepthPrior> parse_depth_prior(std::string_view name);
// The names, in the enum's order: the one list the CLI's choices, Python and
// messages use.
const std::vector<std::string>& depth_prior_names();
// The prior called `name`, or Error "WHAT: expected source-sphere, target-sphere or
// infinity, got 'NAME'".
DepthPrior depth_prior(std::string_view name, std::string_view what = "depth");

// A depth map of the source image in place of a prior (DepthMap, augmentation.hpp):
// the name `fishcam augment --depth` and Python's depth= take for it. Not a
// DepthPrior: it needs the per-pixel data, which the priors' callers do not have.
inline constexpr std::string_view kDepthMapName = "map";
// depth_prior_names() and kDepthMapName: what takes either.
const std::vector<std::string>& depth_prior_and_map_names();

}  // namespace fishcam
