#include "fishcam/eval/fidelity.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "fishcam/core/model_registry.hpp"
#include "fishcam/fit/fit.hpp"
#include "fishcam/io/camera_io.hpp"
#include "fishcam/io/file_input.hpp"
#include "fishcam/io/npy.hpp"
#include "fishcam/io/png_image.hpp"

namespace fishcam {
namespace {
Fidelity fidelity_of_maps(const WarpMaps& maps, const cv::Mat& source_image, const cv::Mat& source_labels,
                          const cv::Mat& truth_image, const cv::Mat& truth_labels);
}  // namespace

Fidelity augmentation_fidelity(const ViewpointWarp& warp, const RigidMotion& change, std::optional<DepthPrior> prior,
                               const cv::Mat& source_image, const cv::Mat& source_labels, const cv::Mat& source_depth,
                               const cv::Mat& truth_image, const cv::Mat& truth_labels) {
  const cv::Size out(warp.target().width(), warp.target().height());
  if (truth_image.size() != out || truth_labels.size() != out) {
    throw Error("fidelity: the truth is not the output camera's size");
  }
  WarpMaps maps;
  if (prior) {
    warp.compute(change, *prior, &maps);
  } else {
    if (source_depth.empty()) throw Error("fidelity: the depth-map prior needs the source's depth map");
    warp.compute(change, DepthMap{source_depth, DepthValues::range}, &maps);
  }
  return fidelity_of_maps(maps, source_image, source_labels, truth_image, truth_labels);
}

namespace {

// The source image and labels resampled by `maps` against the truth.
Fidelity fidelity_of_maps(const WarpMaps& maps, const cv::Mat& source_image, const cv::Mat& source_labels,
                          const cv::Mat& truth_image, const cv::Mat& truth_labels) {
  if (source_image.type() != CV_8UC3 || truth_image.type() != CV_8UC3 || source_labels.type() != CV_8UC1 ||
      truth_labels.type() != CV_8UC1) {
    throw Error("fidelity: expected 8-bit 3-channel images and 8-bit labels");
  }
  if (source_labels.size() != source_image.size() || truth_labels.size() != truth_image.size() ||
      truth_image.size() != maps.map_x.size()) {
    throw Error("fidelity: the images and labels are not their cameras' sizes");
  }
  cv::Mat image, labels;
  warp_image(source_image, maps, &image);
  warp_labels(source_labels, maps, 255, &labels);
  // Away from boundaries: one label in the truth's 5 x 5 neighbourhood, and a source
  // all around.
  const cv::Mat kernel = cv::Mat::ones(5, 5, CV_8U);
  cv::Mat low, high, valid_inner;
  cv::erode(truth_labels, low, kernel);
  cv::dilate(truth_labels, high, kernel);
  const cv::Mat valid = maps.validity();
  cv::erode(valid, valid_inner, kernel);
  const cv::Mat where = (low == high) & (valid_inner != 0);
  Fidelity f;
  f.valid_share = cv::countNonZero(valid) / double(valid.total());
  f.compared = cv::countNonZero(where);
  if (f.compared == 0) {
    f.label_agreement = f.psnr_db = std::numeric_limits<double>::quiet_NaN();
    return f;
  }
  f.label_agreement = cv::countNonZero((labels == truth_labels) & where) / double(f.compared);
  cv::Mat difference;
  cv::absdiff(image, truth_image, difference);
  difference.convertTo(difference, CV_64FC3);
  cv::Mat squared = difference.mul(difference);
  squared.setTo(cv::Scalar::all(0), where == 0);
  const cv::Scalar sum = cv::sum(squared);
  const double mse = (sum[0] + sum[1] + sum[2]) / (3.0 * double(f.compared));
  f.psnr_db = mse > 0 ? 10 * std::log10(255.0 * 255.0 / mse) : std::numeric_limits<double>::infinity();
  return f;
}

namespace fs = std::filesystem;

// One sample of a WoodScape-layout folder: image, labels and (when asked) the range.
struct SampleFiles {
  cv::Mat image, labels, depth;
};

SampleFiles read_sample(const fs::path& root, const std::string& name, bool depth) {
  const fs::path label_path = root / "semantic_annotations" / "gtLabels" / (name + ".png");
  SampleFiles f{
      read_png(root / "rgb_images" / (name + ".png"), PngPixels::bgr8), read_png(label_path, PngPixels::gray8), {}};
  if (depth) {
    const fs::path depth_path = root / "depth" / (name + ".npy");
    const NpyArray range = read_npy(depth_path);
    if (range.shape != std::vector<size_t>{size_t(f.image.rows), size_t(f.image.cols)}) {
      throw Error(path_for_message(depth_path) + ": not the image's size");
    }
    f.depth = cv::Mat(f.image.rows, f.image.cols, CV_32FC1, const_cast<float*>(range.data.data())).clone();
  }
  return f;
}

RigidMotion change_of(const nlohmann::json& entry, const fs::path& file, std::string* name) {
  try {
    *name = entry.at("name").get<std::string>();
    const auto r = entry.at("rotation_deg").get<std::vector<double>>();
    const auto t = entry.at("translation").get<std::vector<double>>();
    if (r.size() != 3 || t.size() != 3) throw Error(path_for_message(file) + ": " + *name + ": expected 3 values");
    // sample-dataset's presets turn by tens of degrees and move by metres at most.
    for (double v : r) {
      if (!(std::abs(v) <= 360)) {
        throw Error(path_for_message(file) + ": " + text_for_message(*name) +
                    ": rotation_deg: expected angles within "
                    "[-360, 360], got " +
                    number_for_message(v));
      }
    }
    for (double v : t) {
      if (!(std::abs(v) <= 1000)) {
        throw Error(path_for_message(file) + ": " + text_for_message(*name) +
                    ": translation: expected metres within "
                    "[-1000, 1000], got " +
                    number_for_message(v));
      }
    }
    return RigidMotion::from_euler_deg({r[0], r[1], r[2]}, {t[0], t[1], t[2]});
  } catch (const nlohmann::json::exception&) {
    throw Error(path_for_message(file) + ": a line lacks name, rotation_deg or translation");
  }
}

// The dataset's true viewpoint test sets (test-*/ with their changes.jsonl), sorted;
// not the paper protocol's (test-*-paper/: augmented images, no truth to score against).
std::vector<fs::path> true_test_sets(const fs::path& root) {
  if (!fs::is_directory(root / "test")) {
    throw Error(path_for_message(root) + ": no test/ folder (expected a dataset of fishcam sample-dataset --scenes N)");
  }
  std::vector<fs::path> sets;
  for (const auto& entry : fs::directory_iterator(root)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory() && name.starts_with("test-") && !name.ends_with("-paper")) {
      // A test set without its changes cannot be scored: an interrupted sample-dataset
      // or a folder of something else, never skipped in silence.
      if (!fs::exists(entry.path() / "changes.jsonl")) {
        throw Error(path_for_message(entry.path()) +
                    ": a test set without changes.jsonl (incomplete: make the "
                    "dataset again with fishcam sample-dataset, or move the folder out)");
      }
      sets.push_back(entry.path());
    }
  }
  std::sort(sets.begin(), sets.end());
  if (sets.empty()) throw Error(path_for_message(root) + ": no true viewpoint test sets (test-PRESET/changes.jsonl)");
  return sets;
}

// SET/changes.jsonl: each sample's name and true change, in the file's order.
std::vector<std::pair<std::string, RigidMotion>> true_changes(const fs::path& set) {
  const fs::path changes = set / "changes.jsonl";
  std::istringstream lines(read_bounded_file(changes, std::size_t(64) << 20, "a changes.jsonl file"));
  std::vector<std::pair<std::string, RigidMotion>> out;
  for (std::string line; std::getline(lines, line);) {
    if (line.empty()) continue;
    nlohmann::json entry;
    try {
      entry = nlohmann::json::parse(line);
    } catch (const nlohmann::json::exception&) {
      throw Error(path_for_message(changes) + ": a line is not JSON");
    }
    std::string name;
    const RigidMotion change = change_of(entry, changes, &name);
    out.emplace_back(std::move(name), change);
  }
  return out;
}

// A token of check_fidelity_models: the camera itself, or a model spec and the
// conversion method.
struct FidelityModel {
  bool own = false;
  std::string spec, method = "lsq";
};

FidelityModel parse_fidelity_model(const std::string& token) {
  if (token == "own") return {true, "", ""};
  FidelityModel m{false, token, "lsq"};
  const std::size_t colon = token.rfind(':');
  if (colon != std::string::npos) {
    const std::string suffix = token.substr(colon + 1);
    const auto& methods = conversion_method_names();
    if (std::find(methods.begin(), methods.end(), suffix) != methods.end()) {
      m.spec = token.substr(0, colon), m.method = suffix;
    }
  }
  ModelSpec spec;
  try {
    spec = parse_model_spec(m.spec);
  } catch (const Error& e) {
    throw Error("models: " + quoted_for_message(token) + ": not 'own' or a model (" + model_names_text() +
                ") with an optional :METHOD (" + choices_for_message(conversion_method_names()) + "): " + e.what());
  }
  if (m.method == "paper" && !model_has_paper_form(spec.name)) {
    throw Error("models: " + quoted_for_message(token) + ": " + spec.name +
                " has no closed form in the paper (eqs. 13-14 give equidistant and stereographic): use :lsq");
  }
  return m;
}

}  // namespace

std::vector<DatasetFidelity> dataset_fidelity(const fs::path& root) {
  const std::vector<fs::path> sets = true_test_sets(root);
  const bool depth = fs::is_directory(root / "test" / "depth");
  std::vector<std::pair<std::string, std::optional<DepthPrior>>> priors;
  for (DepthPrior p : {DepthPrior::source_sphere, DepthPrior::target_sphere, DepthPrior::infinity}) {
    priors.emplace_back(std::string(to_string(p)), p);
  }
  if (depth) priors.emplace_back(std::string(kDepthMapName), std::nullopt);
  std::map<std::string, ViewpointWarp> warps;  // per calibration file
  std::vector<DatasetFidelity> rows;
  for (const fs::path& set : sets) {
    std::vector<DatasetFidelity> set_rows;
    for (const auto& [prior_name, prior] : priors)
      set_rows.push_back({set.filename().string(), prior_name, 0, 0, 0, 0});
    for (const auto& [name, change] : true_changes(set)) {
      const fs::path calibration = root / "test" / "calibration" / (name + ".json");
      auto warp = warps.find(calibration.string());
      if (warp == warps.end())
        warp = warps.emplace(calibration.string(), ViewpointWarp(read_camera(calibration))).first;
      const SampleFiles source = read_sample(root / "test", name, depth);
      const SampleFiles truth = read_sample(set, name, false);
      for (size_t k = 0; k < priors.size(); ++k) {
        const Fidelity f = augmentation_fidelity(warp->second, change, priors[k].second, source.image, source.labels,
                                                 source.depth, truth.image, truth.labels);
        DatasetFidelity& row = set_rows[k];
        row.valid_share += f.valid_share, row.label_agreement += f.label_agreement, row.psnr_db += f.psnr_db;
        ++row.samples;
      }
    }
    for (DatasetFidelity& row : set_rows) {
      if (row.samples == 0) continue;
      row.valid_share /= row.samples, row.label_agreement /= row.samples, row.psnr_db /= row.samples;
      rows.push_back(row);
    }
  }
  return rows;
}

std::vector<std::string> check_fidelity_models(const std::vector<std::string>& models) {
  if (models.empty()) throw Error("models: expected at least one model (own, equidistant:paper, ...)");
  std::map<std::string, std::string> seen;  // by meaning: "equidistant" is "equidistant:lsq"
  for (const std::string& token : models) {
    const FidelityModel m = parse_fidelity_model(token);
    if (!m.own && (parse_model_spec(m.spec).tangential_terms > 0 || !parse_model_spec(m.spec).mrcal_lens.empty())) {
      throw Error("models: " + quoted_for_message(token) +
                  ": fidelity fits radial models (no +tangential, no mrcal lens)");
    }
    const std::string key = m.own ? "own"
                                  : std::string(parse_model_spec(m.spec).name) + "/" +
                                        std::to_string(parse_model_spec(m.spec).order) + "/" + m.method;
    const auto [at, inserted] = seen.emplace(key, token);
    if (!inserted) {
      throw Error("models: " + quoted_for_message(token) +
                  (at->second == token ? " is given twice" : " is " + quoted_for_message(at->second) + " again"));
    }
  }
  return models;
}

namespace {

// Per calibration file: the camera's own warp, each model's, and the bands of its pixels.
struct CameraModels {
  std::vector<ViewpointWarp> warps;  // own first, then one per model
  std::vector<std::string> how;
  std::vector<signed char> band;
};

CameraModels camera_models(const fs::path& calibration, const std::vector<std::string>& models) {
  const Camera camera = read_camera(calibration);
  CameraModels c;
  c.warps.emplace_back(camera);
  c.band = incidence_angle_bands(camera);
  for (const std::string& token : models) {
    const FidelityModel m = parse_fidelity_model(token);
    if (m.own) {
      c.warps.emplace_back(camera);
      c.how.emplace_back("the camera itself");
      continue;
    }
    try {
      AlternativeModel alternative = alternative_model(camera, m.spec, m.method);
      c.warps.emplace_back(alternative.camera);
      c.how.push_back(alternative.how);
    } catch (const Error& e) {
      throw Error(path_for_message(calibration) + ": model " + quoted_for_message(token) + ": " + e.what());
    }
  }
  return c;
}

constexpr std::size_t kBands = Comparison::kAngleBandsDeg.size() - 1;
// Endpoint distances of one model: sum and count per band (the last slot: all bands).
struct EndpointSums {
  std::array<double, kBands + 1> sum{}, count{};
};

// The distances between a model's geometric map and the camera's own, where both have a source.
void add_endpoints(const WarpMaps& maps, const WarpMaps& own, const cv::Mat& own_valid,
                   const std::vector<signed char>& band, EndpointSums* sums) {
  const cv::Mat valid = maps.validity();
  for (int v = 0; v < maps.map_x.rows; ++v) {
    for (int u = 0; u < maps.map_x.cols; ++u) {
      if (!valid.at<uchar>(v, u) || !own_valid.at<uchar>(v, u)) continue;
      const double d = std::hypot(double(maps.map_x.at<float>(v, u)) - double(own.map_x.at<float>(v, u)),
                                  double(maps.map_y.at<float>(v, u)) - double(own.map_y.at<float>(v, u)));
      const signed char b = band[std::size_t(v) * std::size_t(maps.map_x.cols) + std::size_t(u)];
      if (b >= 0) sums->sum[std::size_t(b)] += d, sums->count[std::size_t(b)] += 1;
      sums->sum[kBands] += d, sums->count[kBands] += 1;
    }
  }
}

void check_sample_sizes(const fs::path& set, const std::string& name, const cv::Size& size, const SampleFiles& source,
                        const SampleFiles& truth) {
  for (const auto& [what, image] :
       {std::pair{"rgb_images", &truth.image}, std::pair{"labels", &truth.labels},
        std::pair{"rgb_images (source)", &source.image}, std::pair{"labels (source)", &source.labels}}) {
    if (image->size() != size)
      throw Error(path_for_message(set) + ": " + name + ": " + what + " is not its camera's size");
  }
}

// A test set's rows, one per model: the sums of the samples' scores made means.
void finish_rows(const fs::path& set, const std::vector<std::string>& models, const std::vector<std::string>& how,
                 const std::vector<EndpointSums>& sums, std::vector<ModelFidelity>& set_rows,
                 std::vector<ModelFidelity>* rows) {
  const auto mean = [](double total, double n) { return n > 0 ? total / n : std::numeric_limits<double>::quiet_NaN(); };
  for (std::size_t k = 0; k < models.size(); ++k) {
    ModelFidelity& row = set_rows[k];
    if (row.samples == 0) continue;
    row.test_set = set.filename().string();
    row.model = models[k];
    row.how = how[k];
    row.valid_share /= row.samples, row.label_agreement /= row.samples, row.psnr_db /= row.samples;
    row.endpoint_px = mean(sums[k].sum[kBands], sums[k].count[kBands]);
    for (std::size_t b = 0; b < kBands; ++b) row.endpoint_by_angle_px[b] = mean(sums[k].sum[b], sums[k].count[b]);
    rows->push_back(row);
  }
}

}  // namespace

std::vector<ModelFidelity> dataset_model_fidelity(const fs::path& root, const std::vector<std::string>& models,
                                                  DepthPrior prior) {
  check_fidelity_models(models);
  const std::vector<fs::path> sets = true_test_sets(root);
  std::map<std::string, CameraModels> cameras;  // per calibration file
  std::vector<ModelFidelity> rows;
  for (const fs::path& set : sets) {
    std::vector<ModelFidelity> set_rows(models.size());
    std::vector<EndpointSums> sums(models.size());
    for (const auto& [name, change] : true_changes(set)) {
      const fs::path calibration = root / "test" / "calibration" / (name + ".json");
      auto found = cameras.find(calibration.string());
      if (found == cameras.end())
        found = cameras.emplace(calibration.string(), camera_models(calibration, models)).first;
      const CameraModels& c = found->second;
      const SampleFiles source = read_sample(root / "test", name, false);
      const SampleFiles truth = read_sample(set, name, false);
      check_sample_sizes(set, name, cv::Size(c.warps[0].target().width(), c.warps[0].target().height()), source, truth);
      // The endpoint on geometric maps (the sampling maps clamp coordinates near the
      // source's border), as compare measures it; the images through the sampling maps.
      WarpMaps own;
      c.warps[0].compute(change, prior, &own, MapKind::geometric);
      const cv::Mat own_valid = own.validity();
      for (std::size_t k = 0; k < models.size(); ++k) {
        WarpMaps sampling;
        c.warps[k + 1].compute(change, prior, &sampling);
        const Fidelity f = fidelity_of_maps(sampling, source.image, source.labels, truth.image, truth.labels);
        WarpMaps maps;
        c.warps[k + 1].compute(change, prior, &maps, MapKind::geometric);
        ModelFidelity& row = set_rows[k];
        row.valid_share += f.valid_share, row.label_agreement += f.label_agreement, row.psnr_db += f.psnr_db;
        ++row.samples;
        add_endpoints(maps, own, own_valid, c.band, &sums[k]);
      }
    }
    if (!cameras.empty()) finish_rows(set, models, cameras.begin()->second.how, sums, set_rows, &rows);
  }
  return rows;
}

}  // namespace fishcam
