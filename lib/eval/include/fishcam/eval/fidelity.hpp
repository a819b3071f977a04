// How faithful an augmentation is to the truth: an image augmented by a viewpoint
// change against the scene rendered from the camera really moved (issue 23; the
// paper graded its augmentation with augmented test sets, so could not measure this).
#pragma once

#include <opencv2/core.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fishcam/augment/augmentation.hpp"

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
// (`source_depth`, range, ViewpointWarp::compute_from_depth) -- against the truth
// (output size). Throws Error for mismatched inputs.
Fidelity augmentation_fidelity(const ViewpointWarp& warp, const ViewpointChange& change,
                               std::optional<DepthPrior> prior, const cv::Mat& source_image,
                               const cv::Mat& source_labels, const cv::Mat& source_depth, const cv::Mat& truth_image,
                               const cv::Mat& truth_labels);

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

}  // namespace fishcam
