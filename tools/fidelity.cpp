// fishcam fidelity DATASET: how faithful the augmentation is to the truth, on a
// dataset of `fishcam sample-dataset --scenes N --depth`: each test sample augmented
// by the change of each true viewpoint test set, under every depth prior and the
// sample's depth map, against the test set's re-render from the moved camera.
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <fstream>
#include <map>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/camera_io.hpp"
#include "fishcam/fidelity.hpp"
#include "fishcam/npy.hpp"

namespace fishcam::cli {
namespace {

namespace fs = std::filesystem;

struct Sum {
  double valid = 0, agreement = 0, psnr = 0;
  int samples = 0;
};

// One sample of a WoodScape-layout root: image, labels and (when there) the range.
struct Files {
  cv::Mat image, labels, depth;
};

Files read_sample(const fs::path& root, const std::string& name, bool depth) {
  Files f{read_image((root / "rgb_images" / (name + ".png")).string(), cv::IMREAD_COLOR),
          read_image((root / "semantic_annotations" / "gtLabels" / (name + ".png")).string(), cv::IMREAD_UNCHANGED),
          {}};
  if (f.labels.type() != CV_8UC1) throw Error((root / "semantic_annotations" / "gtLabels" / name).string() + ".png: expected 8-bit labels");
  if (depth) {
    const NpyArray range = read_npy(root / "depth" / (name + ".npy"));
    if (range.shape != std::vector<size_t>{size_t(f.image.rows), size_t(f.image.cols)}) {
      throw Error((root / "depth" / (name + ".npy")).string() + ": not the image's size");
    }
    f.depth = cv::Mat(f.image.rows, f.image.cols, CV_32FC1, const_cast<float*>(range.data.data())).clone();
  }
  return f;
}

void run(const std::string& dataset, bool json) {
  const fs::path root = dataset;
  if (!fs::is_directory(root / "test")) {
    throw Error(dataset + ": no test/ folder (expected a dataset of fishcam sample-dataset --scenes N --depth)");
  }
  const bool depth = fs::is_directory(root / "test" / "depth");
  std::vector<fs::path> sets;
  for (const auto& entry : fs::directory_iterator(root)) {
    if (entry.is_directory() && entry.path().filename().string().starts_with("test-") &&
        fs::exists(entry.path() / "changes.jsonl")) {
      sets.push_back(entry.path());
    }
  }
  std::sort(sets.begin(), sets.end());
  if (sets.empty()) throw Error(dataset + ": no true viewpoint test sets (test-PRESET/changes.jsonl)");
  std::vector<std::pair<std::string, std::optional<DepthPrior>>> priors;
  for (DepthPrior p : {DepthPrior::source_sphere, DepthPrior::target_sphere, DepthPrior::infinity}) {
    priors.emplace_back(std::string(to_string(p)), p);
  }
  if (depth) priors.emplace_back("map", std::nullopt);
  std::map<std::string, Sum> sums;  // set|prior
  std::map<std::string, ViewpointWarp> warps;  // per calibration file content
  for (const fs::path& set : sets) {
    std::ifstream lines(set / "changes.jsonl");
    for (std::string line; std::getline(lines, line);) {
      nlohmann::json entry;
      try {
        entry = nlohmann::json::parse(line);
      } catch (const nlohmann::json::exception&) {
        throw Error((set / "changes.jsonl").string() + ": a line is not JSON");
      }
      const std::string name = entry.at("name").get<std::string>();
      const auto r = entry.at("rotation_deg").get<std::vector<double>>();
      const auto t = entry.at("translation").get<std::vector<double>>();
      if (r.size() != 3 || t.size() != 3) throw Error((set / "changes.jsonl").string() + ": " + name + ": expected 3 values");
      const ViewpointChange change = ViewpointChange::from_euler_deg({r[0], r[1], r[2]}, {t[0], t[1], t[2]});
      const fs::path calibration = root / "test" / "calibration" / (name + ".json");
      auto warp = warps.find(calibration.string());
      if (warp == warps.end()) warp = warps.emplace(calibration.string(), ViewpointWarp(read_camera(calibration))).first;
      const Files source = read_sample(root / "test", name, depth);
      const Files truth = read_sample(set, name, false);
      for (const auto& [prior_name, prior] : priors) {
        const Fidelity f = augmentation_fidelity(warp->second, change, prior, source.image, source.labels, source.depth,
                                                 truth.image, truth.labels);
        Sum& s = sums[set.filename().string() + "|" + prior_name];
        s.valid += f.valid_share, s.agreement += f.label_agreement, s.psnr += f.psnr_db, ++s.samples;
      }
    }
  }
  nlohmann::json rows = nlohmann::json::array();
  if (!json) std::printf("test set                 prior          samples  with a source  labels agree  PSNR dB\n");
  for (const fs::path& set : sets) {
    for (const auto& [prior_name, prior] : priors) {
      const Sum& s = sums[set.filename().string() + "|" + prior_name];
      if (s.samples == 0) continue;
      const double n = s.samples;
      rows.push_back({{"test_set", set.filename().string()}, {"prior", prior_name}, {"samples", s.samples},
                      {"valid_share", s.valid / n}, {"label_agreement", s.agreement / n}, {"psnr_db", s.psnr / n}});
      if (!json) {
        std::printf("%-24s %-14s %7d %13.1f%% %12.2f%% %8.2f\n", set.filename().c_str(), prior_name.c_str(), s.samples,
                    100 * s.valid / n, 100 * s.agreement / n, s.psnr / n);
      }
    }
  }
  if (json) std::printf("%s\n", nlohmann::json{{"dataset", dataset}, {"rows", rows}}.dump(2).c_str());
}

}  // namespace

void register_fidelity(CLI::App& app) {
  auto* cmd = app.add_subcommand("fidelity", "Augmentation against the truth: each test sample augmented by each true "
                                             "viewpoint test set's change, under every depth prior (and the depth map "
                                             "when the dataset has one), against the re-render from the moved camera");
  auto dataset = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  cmd->add_option("DATASET", *dataset, "Folder of fishcam sample-dataset --scenes N [--depth]")->required();
  cmd->add_flag("--json", *json, "Print one JSON object");
  cmd->callback([dataset, json] { run(*dataset, *json); });
}

}  // namespace fishcam::cli
