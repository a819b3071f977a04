// The core layer's parallel loops on OpenCV's thread pool, installed when this
// library (fishcam_augment) is loaded.
#include <opencv2/core.hpp>

#include "fishcam/core/parallel.hpp"

namespace fishcam {
namespace {

void opencv_parallel_for(int count, const std::function<void(int begin, int end)>& body) {
  cv::parallel_for_(cv::Range(0, count), [&](const cv::Range& r) { body(r.start, r.end); });
}

const bool installed = (set_parallel_for(&opencv_parallel_for), true);

}  // namespace
}  // namespace fishcam
