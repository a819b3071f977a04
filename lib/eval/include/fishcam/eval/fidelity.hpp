// How faithful an augmentation is to the truth: an image augmented by a viewpoint
// change against the scene rendered from the camera really moved (issue 23; the
// paper graded its augmentation with augmented test sets, so could not measure this).
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fishcam/augment/augmentation.hpp"
#include "fishcam/eval/comparison.hpp"

namespace fishcam {

struct Fidelity {
  // Output pixels with a source, over all output pixels.
  double valid_share = 0;
  // Over the pixels with a source whose 5 x 5 neighbourhood in the truth holds one
  // label only (away from class boundaries, where resampling decides): the share
  // whose augmented label equals the truth's, and the RGB PSNR (dB, peak 255).
  double label_agreement = 0;
  double psnr_db = 0;
  long compared = 0;  // those pixels
};

// The source image and labels (source size, CV_8UC3 and CV_8UC1) augmented by
// `change` under `prior` -- or, without one, under the source's depth map
// (`source_depth`, range, a DepthMap) -- against the truth
// (output size). Throws Error for mismatched inputs.
Fidelity augmentation_fidelity(const ViewpointWarp& warp, const RigidMotion& change, std::optional<DepthPrior> prior,
                               const cv::Mat& source_image, const cv::Mat& source_labels, const cv::Mat& source_depth,
                               const cv::Mat& truth_image, const cv::Mat& truth_labels);

// One row of a dataset's fidelity: a true viewpoint test set under one prior ("map":
// the sample's depth map), means over the set's samples.
struct DatasetFidelity {
  std::string test_set;  // the folder's name: test-small, test-small-rotation, ...
  std::string prior;     // source-sphere, target-sphere, infinity, map
  int samples = 0;
  double valid_share = 0, label_agreement = 0, psnr_db = 0;
};

// Every test-*/changes.jsonl of a dataset of `fishcam sample-dataset --scenes N`:
// each test sample (test/) augmented by its change under every depth prior -- and
// its depth map when the dataset has test/depth/ -- against the re-render in that
// folder. Rows by test set (sorted by name), then prior. Throws Error naming the
// file for a missing or malformed dataset.
std::vector<DatasetFidelity> dataset_fidelity(const std::filesystem::path& root);

// One row of the paper's Table 5 answered by geometry: a true viewpoint test set
// augmented through one model of each sample's camera (the change applied by
// unprojecting with that model, moving, reprojecting with it: what a user who only
// has that model does), against the re-render from the truly moved camera.
struct ModelFidelity {
  std::string test_set;  // test-small, test-small-rotation, ...
  std::string model;     // as asked: "own", "equidistant:paper", "kannala-brandt", "polynomial:4:lsq"
  std::string how;       // "the camera itself", "the paper's eqs. 13-14", "least-squares fit"
  int samples = 0;
  // Means over the samples, as DatasetFidelity's.
  double valid_share = 0, label_agreement = 0, psnr_db = 0;
  // The model's sampling map against the camera's own under the same change and
  // prior: mean distance (px) over the output pixels with a source in both, over
  // all the set's pixels, and by the output pixel's angle of incidence under the
  // camera (Comparison::kAngleBandsDeg; NaN for a band without pixels).
  double endpoint_px = 0;
  std::array<double, 4> endpoint_by_angle_px{};
};

// The models `fishcam fidelity --models` takes: "own" (the camera itself), or a
// model (a registry name, "polynomial:N") fitted to each sample's camera, optionally
// with ":METHOD" (conversion_method_names(): "paper" -- eqs. 13-14, for the models
// that have them -- or "lsq", the default). Checks a list (not empty, no duplicates,
// every token a model) and returns it; throws Error naming the token.
std::vector<std::string> check_fidelity_models(const std::vector<std::string>& models);

// Every true viewpoint test set of a dataset (as dataset_fidelity) augmented through
// each of `models` (check_fidelity_models) under `prior`. Rows by test set (sorted
// by name), then model in the order given. Throws Error naming the file for a
// missing or malformed dataset, or the model for one that cannot be fitted.
std::vector<ModelFidelity> dataset_model_fidelity(const std::filesystem::path& root,
                                                  const std::vector<std::string>& models,
                                                  DepthPrior prior = DepthPrior::source_sphere);

}  // namespace fishcam
