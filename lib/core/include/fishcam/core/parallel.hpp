// Parallel loops of the core layer, run by whichever thread pool the application
// brings: the core links Eigen only. fishcam_augment installs OpenCV's pool
// (cv::parallel_for_, the one the warps and cv2 share) when it is loaded; without
// it the loops run on the calling thread.
#pragma once

#include <functional>

namespace fishcam {

// body(begin, end) over disjoint ranges covering [0, count), in any order and on
// any threads; returns when all have run.
using ParallelFor = void (*)(int count, const std::function<void(int begin, int end)>& body);

// Installs run for every later parallel loop (nullptr: the calling thread).
void set_parallel_for(ParallelFor run);

void parallel_for(int count, const std::function<void(int begin, int end)>& body);

// body(i) for every i in [0, count) on at most `threads` threads of its own, for
// work whose result must not depend on the thread count (each i's result is its
// own; the caller combines them in index order). The exception of the lowest
// index that threw is rethrown once all have run.
void for_each_index(int count, int threads, const std::function<void(int i)>& body);

}  // namespace fishcam
