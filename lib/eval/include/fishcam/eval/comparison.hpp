// What the projection model used for augmentation changes (the paper's Table 5 and
// Fig. 8): the same seeded viewpoint changes applied once with the camera's own
// model and once with an alternative model of the same camera (unprojected with
// it, moved, reprojected with it: what a user who only has that model does), and
// the two sampling maps compared pixel by pixel.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "fishcam/augment/viewpoint.hpp"
#include "fishcam/core/camera.hpp"

namespace fishcam {

struct ComparisonOptions {
  PosePreset preset = *find_pose_preset("train");
  int samples = 8;  // viewpoint changes; change i is random_change(preset, derive_seed(seed, "compare", i))
  std::uint64_t seed = 0;
  DepthPrior prior = DepthPrior::source_sphere;
};

// Distances (px) between where the two augmentations sample the source image.
struct DisplacementStats {
  long pixels = 0;                             // (output pixel, change) pairs with a source inside the image in both
  double mean_px = 0, p95_px = 0, max_px = 0;  // p95: linear between order statistics (numpy's default)
};

// An alternative model of the camera and where it came from.
struct AlternativeModel {
  std::string name;  // as the user named it: a model name or a file
  std::string how;   // "least-squares fit", "the paper's eqs. 13-14", "read from FILE", ...
  Camera camera;
  std::optional<double> fit_rms_px;  // the fit's error over the camera's image, when fitted
};
// `token` names a registry model, fitted to `camera` as convert_camera does (with
// method "paper", eqs. 13-14 for equidistant and stereographic, least squares for
// the rest). Throws Error naming the token when it is not a model: the callers
// read camera files themselves (the comparison layer reads no files) and say
// "neither a camera file nor a model".
AlternativeModel alternative_model(const Camera& camera, const std::string& token, std::string_view method = "lsq");
// An alternative the caller read from a file.
AlternativeModel alternative_from_file(const std::string& path, Camera camera);

struct ModelComparison {
  AlternativeModel alternative;
  DisplacementStats all;
  // By the output pixel's angle of incidence under the reference camera:
  // [0, 30), [30, 60), [60, 90), [90, ...) degrees.
  std::array<DisplacementStats, 4> by_angle;
  // Output pixels with a source inside the image in exactly one of the two, over
  // those with one in either (%).
  double validity_differs_pct = 0;
  // Per label image given (in order): pixels whose nearest-neighbour label differs between
  // the two augmentations, over the pixels with a source in both (%).
  std::vector<double> labels_differ_pct;
  // The identity change through both: the largest displacement (a check: zero up
  // to the float maps' 1e-3 px).
  double identity_max_px = 0;
  // Mean displacement per output pixel over the changes (CV_32FC1; NaN where no
  // change had a source in both).
  cv::Mat mean_displacement;
};

// Label images of the reference camera's size (CV_8UC1 or CV_16UC1), by name,
// whose augmentation is compared too.
using NamedLabels = std::vector<std::pair<std::string, cv::Mat>>;

struct Comparison {
  ComparisonOptions options;
  std::vector<std::string> label_names;
  std::vector<ViewpointChange> changes;
  std::vector<ModelComparison> models;
  static constexpr std::array<double, 5> kAngleBandsDeg = {0, 30, 60, 90, 360};
};

// The band of each pixel (row-major) by its angle of incidence under the camera,
// an index into Comparison::kAngleBandsDeg's bands; -1 where the pixel has no ray.
std::vector<signed char> incidence_angle_bands(const Camera& camera);

// Compares each alternative (same image size as the reference) with the
// reference. Throws Error for a size mismatch, samples outside 1..1000, or more
// than 64 million (change, pixel) pairs (the exact percentiles keep them all).
// What a comparison of a width x height camera over `samples` changes may take,
// checked before any work (compare_models checks it too): samples 1..1000, at most
// 4096 x 4096 pixels, and at most 64 million (change, pixel) pairs. Throws Error
// naming the limit.
void check_comparison_size(int width, int height, int samples);

Comparison compare_models(const Camera& reference, const std::vector<AlternativeModel>& alternatives,
                          const ComparisonOptions& options, const NamedLabels& labels = {});

// The comparison as one JSON object (what `fishcam compare --json` prints and
// fishcam.compare returns): preset, samples, seed, depth, angle_bands_deg,
// changes, and per model name, how, model, parameters, fit_rms_px,
// identity_max_px, displacement {pixels, mean_px, p95_px, max_px}, by_angle,
// validity_differs_pct, labels_differ_pct {label name: %}.
std::string comparison_json(const Comparison& comparison);

}  // namespace fishcam
