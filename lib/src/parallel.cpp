#include "fishcam/parallel.hpp"

#include <atomic>

namespace fishcam {
namespace {
std::atomic<ParallelFor> installed{nullptr};
}  // namespace

void set_parallel_for(ParallelFor run) { installed.store(run); }

void parallel_for(int count, const std::function<void(int begin, int end)>& body) {
  if (count <= 0) return;
  if (const ParallelFor run = installed.load(); run != nullptr && count > 1) return run(count, body);
  body(0, count);
}

}  // namespace fishcam
