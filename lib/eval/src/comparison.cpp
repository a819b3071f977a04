#include "fishcam/eval/comparison.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "fishcam/augment/augmentation.hpp"
#include "fishcam/core/error.hpp"
#include "fishcam/core/model_registry.hpp"
#include "fishcam/fit/fit.hpp"

namespace fishcam {
namespace {

// Displacements kept per model: 8 bytes each, so at most 512 MB.
constexpr double kMaxDisplacements = 64e6;
// Pixels of one comparison: the scene, the maps of every model and the per-pixel
// statistics take about 80 bytes a pixel (an 8000x8000 camera took 5.1 GB).
constexpr double kMaxComparisonPixels = 4096.0 * 4096.0;

// numpy.percentile's default: linear between the order statistics around q (n - 1).
double percentile(std::vector<float>& values, double q) {
  if (values.empty()) return 0;
  const double position = q * double(values.size() - 1);
  const auto lower = static_cast<std::size_t>(std::floor(position));
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(lower), values.end());
  const double a = values[lower];
  if (lower + 1 >= values.size()) return a;
  const double b = *std::min_element(values.begin() + std::ptrdiff_t(lower) + 1, values.end());
  return a + (position - double(lower)) * (b - a);
}

// Collects displacements, their sum in double, and their maximum.
struct Accumulator {
  std::vector<float> values;
  double sum = 0, max = 0;
  void add(double d) {
    values.push_back(float(d));
    sum += d;
    max = std::max(max, d);
  }
  DisplacementStats stats() {
    DisplacementStats s;
    s.pixels = long(values.size());
    if (values.empty()) return s;
    s.mean_px = sum / double(values.size());
    s.max_px = max;
    s.p95_px = percentile(values, 0.95);
    std::vector<float>().swap(values);
    return s;
  }
};

double distance(const WarpMaps& a, const WarpMaps& b, int v, int u) {
  return std::hypot(double(a.map_x.at<float>(v, u)) - double(b.map_x.at<float>(v, u)),
                    double(a.map_y.at<float>(v, u)) - double(b.map_y.at<float>(v, u)));
}

}  // namespace

std::vector<signed char> incidence_angle_bands(const Camera& camera) {
  const std::size_t n = std::size_t(camera.width()) * std::size_t(camera.height());
  std::vector<float> rays(3 * n);
  camera.unproject_image(rays, InversePath::robust);
  std::vector<signed char> band(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    const float x = rays[3 * i], y = rays[3 * i + 1], z = rays[3 * i + 2];
    if (std::isnan(x)) continue;
    const double theta = std::atan2(std::hypot(double(x), double(y)), double(z)) * 180 / std::numbers::pi;
    signed char b = 0;
    while (b < 3 && theta >= Comparison::kAngleBandsDeg[std::size_t(b) + 1]) ++b;
    band[i] = b;
  }
  return band;
}

AlternativeModel alternative_from_file(const std::string& path, Camera camera) {
  return {path, "read from " + path, std::move(camera), std::nullopt};
}

AlternativeModel alternative_model(const Camera& camera, const std::string& token, std::string_view method) {
  ModelSpec spec;
  try {
    spec = parse_model_spec(token);
  } catch (const Error& e) {
    // A model's name with a wrong argument ("polynomial:64") keeps its own reason.
    if (token.find(':') != std::string::npos) throw Error(std::string("alternative model: ") + e.what());
    throw Error("alternative model " + quoted_for_message(token) + ": neither a camera file nor a model (" +
                model_names_text() + ")");
  }
  check_conversion_method(method);
  const bool paper = method == "paper" && model_has_paper_form(spec.name);
  const Conversion c = convert_camera(camera, spec, paper ? "paper" : "lsq");
  return {token, paper ? "the paper's eqs. 13-14" : "least-squares fit", Camera(c.camera), c.report.rms_px};
}

void check_comparison_size(int width, int height, int samples) {
  if (samples < 1 || samples > 1000) throw Error("samples: expected 1 to 1000, got " + std::to_string(samples));
  const double pixels = double(width) * double(height);
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  if (pixels > kMaxComparisonPixels) {
    throw Error("compare: a " + size + " camera has " + std::to_string(long(pixels / 1e6)) +
                " million pixels; a comparison renders, warps and measures at most " +
                std::to_string(long(kMaxComparisonPixels / 1e6)) + " million (4096x4096): compare a resized camera");
  }
  // Every displacement is kept for the exact 95th percentile (twice: overall and by
  // band, 8 bytes each): bounded rather than growing with --samples.
  if (double(samples) * pixels > kMaxDisplacements) {
    throw Error("samples: " + std::to_string(samples) + " changes of " + size + " pixels exceed the " +
                std::to_string(long(kMaxDisplacements / 1e6)) + " million displacements a comparison keeps (at most " +
                std::to_string(long(kMaxDisplacements / pixels)) + " changes here)");
  }
}

namespace {

// The reference's maps and augmented labels for every change, computed once for every alternative.
struct ReferenceWarps {
  std::vector<WarpMaps> maps;
  std::vector<std::vector<cv::Mat>> labels;  // [change][label image]
};

// The largest distance between the two cameras' maps without a change (where both have a source).
double identity_max_px(const ViewpointWarp& reference, const ViewpointWarp& alternative, DepthPrior prior) {
  WarpMaps a, b;
  reference.compute(RigidMotion{}, prior, &a, MapKind::geometric);
  alternative.compute(RigidMotion{}, prior, &b, MapKind::geometric);
  double largest = 0;
  for (int v = 0; v < a.valid.rows; ++v) {
    for (int u = 0; u < a.valid.cols; ++u) {
      if (a.valid.at<uchar>(v, u) && b.valid.at<uchar>(v, u)) largest = std::max(largest, distance(a, b, v, u));
    }
  }
  return largest;
}

// One alternative model against the reference over every change.
ModelComparison compare_one(const AlternativeModel& alternative, const Comparison& out, const ReferenceWarps& reference,
                            const std::vector<cv::Mat>& labels, const std::vector<signed char>& band,
                            const ViewpointWarp& reference_warp) {
  const int w = alternative.camera.width(), h = alternative.camera.height();
  ModelComparison result{alternative, {}, {}, 0, std::vector<double>(labels.size(), 0), 0, {}};
  const ViewpointWarp warp(alternative.camera);
  result.identity_max_px = identity_max_px(reference_warp, warp, out.options.prior);
  Accumulator all;
  std::array<Accumulator, 4> by_angle;
  cv::Mat sum(h, w, CV_64FC1, cv::Scalar(0)), count(h, w, CV_32SC1, cv::Scalar(0));
  long either = 0, one_only = 0, both = 0;
  std::vector<long> labels_differ(labels.size(), 0);
  for (std::size_t i = 0; i < out.changes.size(); ++i) {
    const WarpMaps& a = reference.maps[i];
    WarpMaps b;
    warp.compute(out.changes[i].motion(), out.options.prior, &b, MapKind::geometric);
    std::vector<cv::Mat> warped(labels.size());
    for (std::size_t k = 0; k < labels.size(); ++k) warp_labels(labels[k], b, 0, &warped[k]);
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const bool in_a = a.valid.at<uchar>(v, u), in_b = b.valid.at<uchar>(v, u);
        either += in_a || in_b;
        one_only += in_a != in_b;
        if (!(in_a && in_b)) continue;
        ++both;
        const double d = distance(a, b, v, u);
        all.add(d);
        const signed char bin = band[std::size_t(v) * std::size_t(w) + std::size_t(u)];
        if (bin >= 0) by_angle[std::size_t(bin)].add(d);
        sum.at<double>(v, u) += d;
        ++count.at<int>(v, u);
        for (std::size_t k = 0; k < labels.size(); ++k) {
          const bool differ = labels[k].depth() == CV_8U
                                  ? warped[k].at<uchar>(v, u) != reference.labels[i][k].at<uchar>(v, u)
                                  : warped[k].at<ushort>(v, u) != reference.labels[i][k].at<ushort>(v, u);
          labels_differ[k] += differ;
        }
      }
    }
  }
  result.all = all.stats();
  for (std::size_t b = 0; b < 4; ++b) result.by_angle[b] = by_angle[b].stats();
  result.validity_differs_pct = either > 0 ? 100.0 * double(one_only) / double(either) : 0;
  for (std::size_t k = 0; k < labels.size(); ++k) {
    result.labels_differ_pct[k] = both > 0 ? 100.0 * double(labels_differ[k]) / double(both) : 0;
  }
  result.mean_displacement.create(h, w, CV_32FC1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const int n = count.at<int>(v, u);
      result.mean_displacement.at<float>(v, u) =
          n > 0 ? float(sum.at<double>(v, u) / n) : std::numeric_limits<float>::quiet_NaN();
    }
  }
  return result;
}

}  // namespace

Comparison compare_models(const Camera& reference, const std::vector<AlternativeModel>& alternatives,
                          const ComparisonOptions& options, const NamedLabels& named_labels) {
  if (options.samples < 1 || options.samples > 1000) {
    throw Error("samples: expected 1 to 1000, got " + std::to_string(options.samples));
  }
  const int w = reference.width(), h = reference.height();
  check_comparison_size(w, h, options.samples);
  for (const AlternativeModel& a : alternatives) {
    const Camera& alternative = a.camera;
    if (alternative.width() != w || alternative.height() != h) {
      throw Error("alternative model " + quoted_for_message(a.name) + ": its camera is " +
                  std::to_string(alternative.width()) + "x" + std::to_string(alternative.height()) +
                  " but the camera compared with is " + std::to_string(w) + "x" + std::to_string(h));
    }
  }
  std::vector<cv::Mat> labels;
  Comparison out;
  out.options = options;
  for (const auto& [name, l] : named_labels) {
    if (l.cols != w || l.rows != h || l.channels() != 1 || (l.depth() != CV_8U && l.depth() != CV_16U)) {
      throw Error("labels " + quoted_for_message(name) + ": expected " + std::to_string(w) + "x" + std::to_string(h) +
                  " single-channel 8- or 16-bit labels");
    }
    labels.push_back(l);
    out.label_names.push_back(name);
  }
  for (int i = 0; i < options.samples; ++i) {
    out.changes.push_back(random_change(options.preset, derive_seed(options.seed, "compare", std::uint64_t(i))));
  }
  const std::vector<signed char> band = incidence_angle_bands(reference);
  const ViewpointWarp reference_warp(reference);
  ReferenceWarps reference_warps{std::vector<WarpMaps>(out.changes.size()),
                                 std::vector<std::vector<cv::Mat>>(out.changes.size())};
  for (std::size_t i = 0; i < out.changes.size(); ++i) {
    reference_warp.compute(out.changes[i].motion(), options.prior, &reference_warps.maps[i], MapKind::geometric);
    for (const cv::Mat& l : labels) {
      reference_warps.labels[i].emplace_back();
      warp_labels(l, reference_warps.maps[i], 0, &reference_warps.labels[i].back());
    }
  }
  for (const AlternativeModel& alternative : alternatives) {
    out.models.push_back(compare_one(alternative, out, reference_warps, labels, band, reference_warp));
  }
  return out;
}

namespace {

nlohmann::ordered_json stats_json(const DisplacementStats& s) {
  return {{"pixels", s.pixels}, {"mean_px", s.mean_px}, {"p95_px", s.p95_px}, {"max_px", s.max_px}};
}

}  // namespace

std::string comparison_json(const Comparison& comparison) {
  using json = nlohmann::ordered_json;
  const ComparisonOptions& o = comparison.options;
  json j{{"preset", o.preset.name},
         {"samples", o.samples},
         {"seed", o.seed},
         {"depth", to_string(o.prior)},
         {"angle_bands_deg", Comparison::kAngleBandsDeg},
         {"changes", json::array()},
         {"models", json::array()}};
  for (const ViewpointChange& p : comparison.changes) {
    j["changes"].push_back({{"rotation_deg", {p.rotation_deg.x(), p.rotation_deg.y(), p.rotation_deg.z()}},
                            {"translation", {p.translation.x(), p.translation.y(), p.translation.z()}}});
  }
  for (const ModelComparison& r : comparison.models) {
    const AlternativeModel& a = r.alternative;
    json model{{"name", a.name},
               {"how", a.how},
               {"model", model_name(a.camera.model())},
               {"parameters", model_params(a.camera.model())},
               {"fit_rms_px", a.fit_rms_px ? json(*a.fit_rms_px) : json(nullptr)},
               {"identity_max_px", r.identity_max_px},
               {"displacement", stats_json(r.all)},
               {"by_angle", json::array()},
               {"validity_differs_pct", r.validity_differs_pct},
               {"labels_differ_pct", json::object()}};
    for (std::size_t b = 0; b < r.by_angle.size(); ++b) {
      json band{{"from_deg", Comparison::kAngleBandsDeg[b]}};
      band["to_deg"] =
          b + 2 < Comparison::kAngleBandsDeg.size() ? json(Comparison::kAngleBandsDeg[b + 1]) : json(nullptr);
      band.update(stats_json(r.by_angle[b]));
      model["by_angle"].push_back(band);
    }
    for (std::size_t k = 0; k < comparison.label_names.size(); ++k) {
      model["labels_differ_pct"][comparison.label_names[k]] = r.labels_differ_pct[k];
    }
    j["models"].push_back(model);
  }
  return j.dump(2);
}

}  // namespace fishcam
