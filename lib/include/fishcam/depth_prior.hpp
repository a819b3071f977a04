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

}  // namespace fishcam
