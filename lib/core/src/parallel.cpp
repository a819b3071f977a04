#include "fishcam/core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>
#include <vector>

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

void for_each_index(int count, int threads, const std::function<void(int i)>& body) {
  if (count <= 0) return;
  std::vector<std::exception_ptr> errors(size_t(count), nullptr);
  std::atomic<int> next{0};
  const auto work = [&] {
    for (int i = next++; i < count; i = next++) {
      try {
        body(i);
      } catch (...) {
        errors[size_t(i)] = std::current_exception();
      }
    }
  };
  std::vector<std::jthread> pool;
  for (int t = 1; t < std::min(threads, count); ++t) pool.emplace_back(work);
  work();
  pool.clear();  // joins
  for (const auto& error : errors) {
    if (error) std::rethrow_exception(error);
  }
}

}  // namespace fishcam
