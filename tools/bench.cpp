// fishcam bench roots CAMERA [--json]: the cost of theta(rho), every method in one
// run on one camera (this machine is shared and noisy: compare within a run).
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/augment/augmentation.hpp"
#include "fishcam/augment/chessboard.hpp"
#include "fishcam/augment/scene.hpp"
#include "fishcam/fit/calibration.hpp"
#include "fishcam/fit/fit.hpp"
#include "fishcam/io/camera_io.hpp"
#include "fishcam/testing/testing.hpp"

namespace fishcam::cli {
namespace {

// Median wall time of `repeats` runs of fn(), in seconds.
template <class Fn>
double median_seconds(int repeats, const Fn& fn) {
  std::vector<double> times;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    fn();
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::nth_element(times.begin(), times.begin() + repeats / 2, times.end());
  return times[repeats / 2];
}

// The OpenCV-style baseline: 10 plain Newton steps from theta = rho / rho'(0), no bracket.
template <class Model>
double newton10(const Model& model, double rho) {
  double theta = rho / model.drho(0.0);
  for (int i = 0; i < 10; ++i) theta -= (model.rho(theta) - rho) / model.drho(theta);
  return theta;
}

volatile double g_sink;  // keeps the timed loops from being optimised away

// theta(rho) per call by each solver, and full-image unprojection, as JSON.
nlohmann::json measure_roots(const Camera& camera, const std::string& path, int repeats) {
  // Radii of the image (the largest pixel radius, capped at rho_max), uniformly.
  double rho_hi = 0;
  for (double u : {-0.5, camera.width() - 0.5}) {
    for (double v : {-0.5, camera.height() - 0.5}) rho_hi = std::max(rho_hi, camera.rho_of_pixel({u, v}));
  }
  if (camera.domain().closed) rho_hi = std::min(rho_hi, camera.domain().rho_max);
  constexpr size_t kSamples = 1 << 20;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uniform(0.0, rho_hi);
  std::vector<double> rhos(kSamples);
  for (auto& r : rhos) r = uniform(rng);

  const int threads_before = cv::getNumThreads();
  cv::setNumThreads(1);
  auto per_call_ns = [&](size_t n, const auto& theta_of) {
    return 1e9 / double(n) * median_seconds(repeats, [&] {
             double sum = 0;
             for (size_t i = 0; i < n; ++i) sum += theta_of(rhos[i]);
             g_sink = sum;
           });
  };
  nlohmann::json out = {{"camera", path}, {"samples", kSamples}, {"rho_range_px", {0.0, rho_hi}}};
  out["robust_ns"] = per_call_ns(kSamples, [&](double r) { return camera.theta_from_rho(r); });
  out["robust_cold_ns"] = std::visit(
      [&](const auto& m) {
        return per_call_ns(kSamples, [&](double r) { return solve_theta(m, r, camera.domain()); });
      },
      camera.model());
  out["table_ns"] = per_call_ns(kSamples, [&](double r) { return camera.theta_from_rho_table(r); });
  out["newton10_ns"] = std::visit(
      [&](const auto& m) { return per_call_ns(kSamples, [&](double r) { return newton10(m, r); }); }, camera.model());
  std::visit(
      [&](const auto& m) {
        if constexpr (PolynomialInTheta<std::decay_t<decltype(m)>>) {
          const auto c = m.power_coefficients();
          out["companion_ns"] =
              per_call_ns(kSamples / 64, [&](double r) { return testing::algebraic_theta(c, r, camera.domain()); });
        }
      },
      camera.model());
  // Worst residual of the Newton baseline over the same radii (it has no bracket).
  double newton_worst = 0;
  std::visit(
      [&](const auto& m) {
        for (size_t i = 0; i < kSamples; i += 16) {
          const double e = std::abs(m.rho(newton10(m, rhos[i])) - rhos[i]);
          newton_worst = std::isfinite(e) ? std::max(newton_worst, e) : INFINITY;
        }
      },
      camera.model());
  out["newton10_worst_residual_px"] = newton_worst;
  out["table_worst_error_px"] = camera.inverse_table().worst_error_px();

  std::vector<float> rays(3 * size_t(camera.width()) * size_t(camera.height()));
  for (int threads : {1, 2}) {
    cv::setNumThreads(threads);
    for (auto [name, path_kind] : {std::pair{"robust", InversePath::robust}, std::pair{"table", InversePath::table}}) {
      out["unproject_image_ms"][name][std::to_string(threads)] =
          1e3 * median_seconds(repeats, [&, path = path_kind] { camera.unproject_image(rays, path); });
    }
  }
  cv::setNumThreads(threads_before);
  return out;
}

void print_roots(const nlohmann::json& out, const Camera& camera, const std::string& path, int repeats) {
  std::printf("theta(rho) on %s, %zu radii uniform in [0, %.1f] px, median of %d runs, 1 thread\n", path.c_str(),
              out["samples"].get<size_t>(), out["rho_range_px"][1].get<double>(), repeats);
  std::printf("  robust solver (bracketed Newton)  %8.1f ns/call  (started from the table, as Camera does)\n",
              out["robust_ns"].get<double>());
  std::printf("  robust solver, cold start         %8.1f ns/call  (theta0 = rho / rho'(0))\n",
              out["robust_cold_ns"].get<double>());
  std::printf("  bulk path (inverse table)         %8.1f ns/call  (worst error %.2g px)\n",
              out["table_ns"].get<double>(), camera.inverse_table().worst_error_px());
  if (out.contains("companion_ns")) {
    std::printf("  companion-matrix eigenvalues      %8.1f ns/call\n", out["companion_ns"].get<double>());
  }
  std::printf("  plain 10-step Newton (OpenCV)     %8.1f ns/call  (worst residual %.2g px)\n",
              out["newton10_ns"].get<double>(), out["newton10_worst_residual_px"].get<double>());
  std::printf("full-image unprojection %dx%d (ms):\n", camera.width(), camera.height());
  for (const char* name : {"robust", "table"}) {
    std::printf("  %-7s 1 thread %7.2f   2 threads %7.2f\n", name, out["unproject_image_ms"][name]["1"].get<double>(),
                out["unproject_image_ms"][name]["2"].get<double>());
  }
}

void run_roots(const std::string& path, bool json, int repeats) {
  const Camera camera = read_camera(path);
  const nlohmann::json out = measure_roots(camera, path, repeats);
  if (json) {
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    print_roots(out, camera, path, repeats);
  }
}

// Augmentation of one training sample (RGB bilinear + labels nearest), a new random
// `train` pose per sample, against the fastest cv::remap of the same sample with
// maps computed beforehand (the floor): fixed-point maps from cv::convertMaps
// (CV_16SC2 + interpolation table for the image, rounded for the labels), or the
// float maps themselves, whichever is faster. Per sample the total and both floors
// run interleaved (in rotating order) on the same pose and inputs.
nlohmann::json measure_augment(const Camera& camera, const ViewpointWarp& warp, int samples, Sampling sampling) {
  const SceneRender scene = render_street_scene(camera, *camera.parameters().pose);
  const PosePreset train = *find_pose_preset("train");
  cv::Mat image, labels;
  const int threads_before = cv::getNumThreads();
  nlohmann::json results = nlohmann::json::array();
  auto seconds = [](const auto& fn) {
    const auto start = std::chrono::steady_clock::now();
    fn();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  for (int threads : {1, 2}) {
    cv::setNumThreads(threads);
    std::vector<double> total, map, fixed_floor, float_floor;
    for (int i = 0; i < samples; ++i) {
      const RigidMotion change = random_change(train, std::uint64_t(1000 * threads + i)).motion();
      // The floor's maps, computed beforehand for this very pose.
      WarpMaps maps;
      warp.compute(change, DepthPrior::source_sphere, &maps);
      cv::Mat fixed_xy, fixed_fraction, nearest_xy, unused;
      cv::convertMaps(maps.map_x, maps.map_y, fixed_xy, fixed_fraction, CV_16SC2, false);
      cv::convertMaps(maps.map_x, maps.map_y, nearest_xy, unused, CV_16SC2, true);
      const AugmentIO io{&scene.image, &image, 0, &scene.labels, &labels, 0, nullptr};
      const std::function<void()> runs[] = {
          [&] { total.push_back(seconds([&] { warp.augment(change, DepthPrior::source_sphere, io, sampling); })); },
          [&] {
            fixed_floor.push_back(seconds([&] {
              cv::remap(scene.image, image, fixed_xy, fixed_fraction, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
              cv::remap(scene.labels, labels, nearest_xy, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT);
            }));
          },
          [&] {
            float_floor.push_back(seconds([&] {
              cv::remap(scene.image, image, maps.map_x, maps.map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
              cv::remap(scene.labels, labels, maps.map_x, maps.map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT);
            }));
          },
          [&] { map.push_back(seconds([&] { warp.compute(change, DepthPrior::source_sphere, &maps); })); },
      };
      for (int k = 0; k < 4; ++k) runs[(i + k) % 4]();  // a rotating order: no run always first or last
    }
    const double fixed_ms = 1e3 * median(fixed_floor), float_ms = 1e3 * median(float_floor);
    const double total_ms = 1e3 * median(total), floor_ms = std::min(fixed_ms, float_ms);
    results.push_back({{"threads", threads},
                       {"map_ms", 1e3 * median(map)},
                       {"total_ms", total_ms},
                       {"remap_only_ms", floor_ms},
                       {"floor_fixed_ms", fixed_ms},
                       {"floor_float_ms", float_ms},
                       {"floor", fixed_ms <= float_ms ? "fixed" : "float"},
                       {"total_over_remap", total_ms / floor_ms}});
  }
  cv::setNumThreads(threads_before);
  return results;
}

void run_augment(const std::string& path, bool json, int samples, Sampling sampling, std::optional<cv::Size> size) {
  Camera camera = read_camera(path);
  if (!camera.parameters().pose) throw Error(path + ": the benchmark renders the scene and needs a camera pose");
  if (size) camera = Camera(resized(camera.parameters(), size->width, size->height));
  const ViewpointWarp warp(camera);
  const nlohmann::json results = measure_augment(camera, warp, samples, sampling);
  nlohmann::json out = results.back();  // the 2-thread numbers at the top level
  out["camera"] = path;
  out["width"] = camera.width();
  out["height"] = camera.height();
  out["samples"] = samples;
  out["sampling"] = to_string(sampling);
  out["grid_spacing_px"] = warp.grid_spacing();
  out["grid_error_px"] = warp.grid_error_px();
  out["results"] = results;
  if (json) {
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf(
      "augmentation of a %dx%d sample (RGB bilinear + labels nearest), new train pose each, median of %d, "
      "sampling %s (grid spacing %d px, measured error %.4f px)\n",
      camera.width(), camera.height(), samples, std::string(to_string(sampling)).c_str(), warp.grid_spacing(),
      warp.grid_error_px());
  std::printf("threads  map ms  total ms  floor: fixed ms  float ms  total / fastest floor\n");
  for (const auto& r : results) {
    std::printf("%7d %7.2f %9.2f %16.2f %9.2f %22.3f\n", r["threads"].get<int>(), r["map_ms"].get<double>(),
                r["total_ms"].get<double>(), r["floor_fixed_ms"].get<double>(), r["floor_float_ms"].get<double>(),
                r["total_over_remap"].get<double>());
  }
}

// The grid path's accuracy: over 20 fixed `large` changes (seeds 0-19, every depth
// prior in turn), its float map against compute_exact, the inside/outside decisions,
// and the augmented scene's labels against the exact path's.
void run_grid_accuracy(const std::string& path, bool json, std::optional<cv::Size> size) {
  Camera camera = read_camera(path);
  if (!camera.parameters().pose) throw Error(path + ": the benchmark renders the scene and needs a camera pose");
  if (size) camera = Camera(resized(camera.parameters(), size->width, size->height));
  const SceneRender scene = render_street_scene(camera, *camera.parameters().pose);
  const ViewpointWarp warp(camera);
  const DepthPrior priors[] = {DepthPrior::source_sphere, DepthPrior::target_sphere, DepthPrior::infinity};
  double worst = 0;
  long valid = 0, decisions = 0, labels_differ = 0;
  for (int seed = 0; seed < 20; ++seed) {
    const RigidMotion change = random_change(*find_pose_preset("large"), std::uint64_t(seed)).motion();
    const DepthPrior prior = priors[seed % 3];
    WarpMaps grid, exact;
    warp.compute_grid(change, prior, &grid);
    warp.compute_exact(change, prior, &exact);
    for (int v = 0; v < exact.map_x.rows; ++v) {
      for (int u = 0; u < exact.map_x.cols; ++u) {
        const bool e = exact.valid.at<uchar>(v, u), g = grid.valid.at<uchar>(v, u);
        valid += e;
        decisions += e != g;
        if (e && g) {
          worst = std::max<double>(worst, std::hypot(grid.map_x.at<float>(v, u) - exact.map_x.at<float>(v, u),
                                                     grid.map_y.at<float>(v, u) - exact.map_y.at<float>(v, u)));
        }
      }
    }
    cv::Mat grid_labels, exact_labels, exact_valid;
    warp.augment(change, prior, {nullptr, nullptr, 0, &scene.labels, &grid_labels, 255, nullptr}, Sampling::grid);
    warp.augment(change, prior, {nullptr, nullptr, 0, &scene.labels, &exact_labels, 255, &exact_valid},
                 Sampling::exact);
    labels_differ += cv::countNonZero((grid_labels != exact_labels) & (exact_valid != 0));
  }
  const nlohmann::json out{{"camera", path},
                           {"width", camera.width()},
                           {"height", camera.height()},
                           {"changes", 20},
                           {"grid_spacing_px", warp.grid_spacing()},
                           {"measured_at_construction_px", warp.grid_error_px()},
                           {"worst_error_px", worst},
                           {"decisions_differ_share", double(decisions) / double(std::max(1L, valid))},
                           {"labels_differ_share", double(labels_differ) / double(std::max(1L, valid))}};
  if (json) {
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf(
      "grid sampling of a %dx%d camera (spacing %d px), 20 large changes against compute_exact:\n"
      "  worst map error %.4f px (1/32 = 0.03125), inside/outside decisions differing %.2g, labels differing "
      "%.2g of the valid pixels\n",
      camera.width(), camera.height(), warp.grid_spacing(), worst, out["decisions_differ_share"].get<double>(),
      out["labels_differ_share"].get<double>());
}

// Conversion of the WoodScape front camera and calibration from 50 boards of 10x10
// corners (synthetic, 0.3 px noise): the costs the fitting issue sets targets for.
void run_fit(bool json, int repeats) {
  const Camera source = read_camera(bundled_data("woodscape_front.json"));
  nlohmann::json out = {{"repeats", repeats}};
  for (const char* model : {"kannala-brandt", "polynomial:4", "equidistant"}) {
    const ModelSpec spec = parse_model_spec(model);
    out["convert_ms"][model] =
        1e3 * median_seconds(repeats, [&] {
          g_sink = model_params(fit_camera(sample_image(source, 4, 1), spec, source.parameters()).model)[0];
        });
    out["convert_fit_center_ms"][model] =
        1e3 * median_seconds(repeats, [&] {
          g_sink =
              model_params(fit_camera(sample_image(source, 4, 1), spec, source.parameters(), {true, true}).model)[0];
        });
  }
  const BoardSpec board{10, 10, 0.1};
  const auto boards = testing::synthesize_boards(source, board, 50, 0.3, 1);
  out["calibrate_50_boards_ms"] =
      1e3 * median_seconds(std::max(1, repeats / 2), [&] {
        g_sink = calibrate(boards.observations, board, source.width(), source.height(), {"polynomial", 4}).rms_px;
      });
  if (json) {
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf("conversion of the WoodScape front camera (every 4th pixel, fit only), median of %d:\n", repeats);
  for (const char* model : {"kannala-brandt", "polynomial:4", "equidistant"}) {
    std::printf("  %-15s %7.1f ms   with --fit-center --fit-aspect %7.1f ms\n", model,
                out["convert_ms"][model].get<double>(), out["convert_fit_center_ms"][model].get<double>());
  }
  std::printf("calibration, 50 boards of 10x10 corners, WoodScape polynomial with centre and aspect: %.0f ms\n",
              out["calibrate_50_boards_ms"].get<double>());
}

struct CornerMethod {
  const char* name;
  std::function<std::optional<std::vector<Eigen::Vector2d>>(const cv::Mat&)> detect;
  double seconds = 0;
  long found = 0, corners = 0;
  double sum2 = 0, worst = 0;
};

// OpenCV's findChessboardCorners + cornerSubPix (the baseline), fishcam's detector, and
// findChessboardCornersSB for reference.
std::vector<CornerMethod> corner_methods(const BoardSpec& board) {
  const cv::TermCriteria until(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.01);
  const auto as_eigen = [](const std::vector<cv::Point2f>& c) {
    std::vector<Eigen::Vector2d> out;
    for (const auto& p : c) out.emplace_back(p.x, p.y);
    return out;
  };
  return {
      {"findChessboardCorners + cornerSubPix",
       [=](const cv::Mat& gray) -> std::optional<std::vector<Eigen::Vector2d>> {
         std::vector<cv::Point2f> c;
         if (!cv::findChessboardCorners(gray, {board.cols, board.rows}, c,
                                        cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
           return std::nullopt;
         }
         cv::cornerSubPix(gray, c, {5, 5}, {-1, -1}, until);
         return as_eigen(c);
       }},
      {"fishcam detect_chessboard", [=](const cv::Mat& gray) { return detect_chessboard(gray, board); }},
      {"findChessboardCornersSB (exhaustive, accuracy)",
       [=](const cv::Mat& gray) -> std::optional<std::vector<Eigen::Vector2d>> {
         std::vector<cv::Point2f> c;
         if (!cv::findChessboardCornersSB(gray, {board.cols, board.rows}, c,
                                          cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY)) {
           return std::nullopt;
         }
         return as_eigen(c);
       }},
  };
}

// A detection's corners against the truth, in the closer of the two orders (OpenCV may
// number the corners from either end), added to the method's error.
void score_corners(const std::vector<Eigen::Vector2d>& found, const std::vector<Eigen::Vector2d>& truth,
                   CornerMethod* m) {
  double direct = 0, reversed = 0;
  const size_t n = truth.size();
  for (size_t i = 0; i < n; ++i) {
    direct += (found[i] - truth[i]).squaredNorm();
    reversed += (found[n - 1 - i] - truth[i]).squaredNorm();
  }
  const bool flip = reversed < direct;
  for (size_t i = 0; i < n; ++i) m->worst = std::max(m->worst, (found[flip ? n - 1 - i : i] - truth[i]).norm());
  m->sum2 += std::min(direct, reversed);
  m->corners += long(n);
  ++m->found;
}

void print_corners(const nlohmann::json& out, size_t images, const Camera& camera, int repeats) {
  std::printf(
      "chessboard detection, %zu rendered %dx%d images (9x6 boards, blur 0.8 px, noise 2), %d repeats, one "
      "thread:\n",
      images, camera.width(), camera.height(), repeats);
  for (const auto& m : out["methods"]) {
    std::printf("  %-48s %7.1f ms/image (%.2fx)  found %ld, corner error rms %.3f px, max %.3f px\n",
                m["name"].get<std::string>().c_str(), m["ms_per_image"].get<double>(),
                m["ratio_to_findChessboardCorners"].get<double>(), m["found"].get<long>(), m["rms_px"].get<double>(),
                m["max_px"].get<double>());
  }
}

// Chessboard detection on rendered photographs with known corners (the Kannala-Brandt
// camera at 960 px wide, boards all over the image, blur 0.8 px, noise 2 grey levels):
// time per image of detect_chessboard against OpenCV's findChessboardCorners +
// cornerSubPix (11 x 11 window), interleaved, and the old findChessboardCornersSB
// (exhaustive, accuracy) for reference; the corner error of each against the truth.
void run_corners(bool json, int boards_count, int repeats) {
  const CameraParameters full = read_camera(bundled_data("kannala_brandt.yaml")).parameters();
  const Camera camera(resized(full, 960, int(std::lround(full.height * 960.0 / full.width))));
  const BoardSpec board{9, 6, 0.1};
  const auto poses = testing::synthesize_boards(camera, board, boards_count, 0.0, 1).poses;
  const auto points = board_points(board);
  std::vector<CornerMethod> methods = corner_methods(board);
  std::vector<cv::Mat> images;
  std::vector<std::vector<Eigen::Vector2d>> truths;
  for (size_t b = 0; b < poses.size(); ++b) {
    const auto pixels = testing::render_board_image(camera, board, poses[b], 3, 0.8, 2.0, b);
    images.push_back(
        cv::Mat(camera.height(), camera.width(), CV_8UC1, const_cast<std::uint8_t*>(pixels.data())).clone());
    std::vector<Eigen::Vector2d> truth;
    for (const auto& p : points) {
      Eigen::Vector2d q;
      camera.project(poses[b].rotation * p + poses[b].translation, &q);
      truth.push_back(q);
    }
    truths.push_back(truth);
  }
  const int saved_threads = cv::getNumThreads();
  cv::setNumThreads(1);  // per image on one thread: detect-corners runs images in parallel
  for (int r = 0; r < repeats; ++r) {
    for (size_t b = 0; b < images.size(); ++b) {
      for (auto& m : methods) {  // interleaved: the same image through every method in turn
        const auto start = std::chrono::steady_clock::now();
        const auto found = m.detect(images[b]);
        m.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (r == 0 && found) score_corners(*found, truths[b], &m);
      }
    }
  }
  cv::setNumThreads(saved_threads);
  nlohmann::json out = {{"images", images.size()}, {"repeats", repeats}, {"size", {camera.width(), camera.height()}}};
  const double baseline = methods[0].seconds;
  for (const auto& m : methods) {
    out["methods"].push_back({{"name", m.name},
                              {"ms_per_image", 1e3 * m.seconds / double(repeats * images.size())},
                              {"ratio_to_findChessboardCorners", m.seconds / baseline},
                              {"found", m.found},
                              {"rms_px", m.corners ? std::sqrt(m.sum2 / double(m.corners)) : 0.0},
                              {"max_px", m.worst}});
  }
  if (json) {
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  print_corners(out, images.size(), camera, repeats);
}

}  // namespace

void register_bench(CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "Benchmarks (numbers for docs/performance.md)");
  bench->require_subcommand(1);
  auto* roots = bench->add_subcommand("roots",
                                      "ns per theta(rho) for every inversion method, and full-image "
                                      "unprojection on 1 and 2 threads");
  auto path = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  auto repeats = std::make_shared<int>(7);
  roots->add_option("CAMERA", *path, "Camera file (e.g. data/woodscape_front.json)")->required();
  roots->add_flag("--json", *json, "Print one JSON object");
  roots->add_option("--repeats", *repeats, "Runs per measurement (the median is reported)")->check(CLI::Range(1, 1000));
  roots->callback([=] { run_roots(*path, *json, *repeats); });

  auto* augment = bench->add_subcommand("augment",
                                        "Augmentation per training sample on 1 and 2 threads, against "
                                        "the fastest cv::remap of the same sample with maps computed "
                                        "beforehand");
  auto augment_camera = std::make_shared<std::string>();
  auto augment_json = std::make_shared<bool>(false);
  auto samples = std::make_shared<int>(41);
  auto sampling = std::make_shared<std::string>("grid");
  auto bench_size = std::make_shared<std::string>();
  augment->add_option("CAMERA", *augment_camera,
                      "Camera file with a pose (default: the bundled WoodScape front camera)");
  augment->add_flag("--json", *augment_json, "Print one JSON object");
  augment->add_option("--samples", *samples, "Samples (poses) per thread count (the median is reported)")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  augment->add_option("--sampling", *sampling, "grid or exact (ViewpointWarp::augment)")
      ->check(CLI::IsMember(sampling_names()))
      ->capture_default_str();
  augment->add_option("--size", *bench_size, "Resize the camera (and the rendered sample) to WxH first");
  auto accuracy = std::make_shared<bool>(false);
  augment->add_flag("--accuracy", *accuracy,
                    "Instead of timing: the grid path against the exact maps over 20 large changes");
  auto* fit = bench->add_subcommand("fit", "Model conversion and chessboard calibration times");
  auto fit_json = std::make_shared<bool>(false);
  auto fit_repeats = std::make_shared<int>(5);
  fit->add_flag("--json", *fit_json, "Print one JSON object");
  fit->add_option("--repeats", *fit_repeats, "Runs per measurement (the median is reported)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  fit->callback([=] { run_fit(*fit_json, *fit_repeats); });

  auto* corners = bench->add_subcommand("corners",
                                        "Chessboard detection time and corner accuracy on rendered "
                                        "photographs with known corners");
  auto corners_json = std::make_shared<bool>(false);
  auto corners_boards = std::make_shared<int>(24);
  auto corners_repeats = std::make_shared<int>(3);
  corners->add_flag("--json", *corners_json, "Print one JSON object");
  corners->add_option("--boards", *corners_boards, "Rendered images")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  corners->add_option("--repeats", *corners_repeats, "Passes over the images")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  corners->callback([=] { run_corners(*corners_json, *corners_boards, *corners_repeats); });
  register_bench_render(bench);

  augment->callback([=] {
    const std::string camera =
        augment_camera->empty() ? bundled_data("woodscape_front.json").string() : *augment_camera;
    std::optional<cv::Size> size;
    if (!bench_size->empty()) {
      const auto [w, h] = parse_image_size(*bench_size, "--size");
      size = cv::Size(w, h);
    }
    if (*accuracy) {
      run_grid_accuracy(camera, *augment_json, size);
    } else {
      run_augment(camera, *augment_json, *samples, *parse_sampling(*sampling), size);
    }
  });
}

}  // namespace fishcam::cli
