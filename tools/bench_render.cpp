// fishcam bench render: scene rendering throughput on one thread (issue 23's
// target: >= 20 images/s at 320x242 with 2x2 supersampling).
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/augment/scene.hpp"
#include "fishcam/io/camera_io.hpp"

namespace fishcam::cli {
namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
  return v[v.size() / 2];
}

void run_render(const std::string& size_text, int scenes, int supersampling, bool json) {
  const auto [w, h] = parse_image_size(size_text, "--size");
  const Camera front = read_camera(bundled_data("woodscape_front.json"));
  const Camera camera(resized(front.parameters(), w, h));
  const int threads_before = cv::getNumThreads();
  cv::setNumThreads(1);
  std::vector<double> generate_ms, render_ms;
  for (int s = 1; s <= scenes; ++s) {
    const auto t0 = std::chrono::steady_clock::now();
    const StreetScene scene = StreetScene::generate(std::uint64_t(s));
    const auto t1 = std::chrono::steady_clock::now();
    const SceneRender render = scene.render(camera, *camera.parameters().pose, supersampling);
    const auto t2 = std::chrono::steady_clock::now();
    generate_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    render_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
  }
  cv::setNumThreads(threads_before);
  const double per_image = median(render_ms) + median(generate_ms);
  if (json) {
    std::printf("%s\n", nlohmann::json{{"width", w},
                                       {"height", h},
                                       {"scenes", scenes},
                                       {"supersampling", supersampling},
                                       {"generate_ms", median(generate_ms)},
                                       {"render_ms", median(render_ms)},
                                       {"images_per_second", 1000 / per_image}}
                            .dump()
                            .c_str());
    return;
  }
  std::printf("%dx%d, %dx%d supersampling, %d scene seeds, 1 thread (medians):\n", w, h, supersampling, supersampling,
              scenes);
  std::printf("  generate %.2f ms  render %.2f ms  -> %.1f images/s\n", median(generate_ms), median(render_ms),
              1000 / per_image);
}

}  // namespace

void register_bench_render(CLI::App* bench) {
  auto* cmd = bench->add_subcommand("render", "Scene generation and rendering per image on one thread");
  struct Options {
    std::string size = "320x242";
    int scenes = 21, supersampling = 2;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("--size", o->size, "Image size (the bundled front camera resized)")->capture_default_str();
  cmd->add_option("--scenes", o->scenes, "Scene seeds 1..N, one image each")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  cmd->add_option("--supersampling", o->supersampling, "RGB rays per pixel side")
      ->check(CLI::Range(1, 4))
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "Print one JSON object");
  cmd->callback([o] { run_render(o->size, o->scenes, o->supersampling, o->json); });
}

}  // namespace fishcam::cli
