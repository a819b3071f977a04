// fishcam evaluate: segmentation results scored the paper's way (eqs. 11-12), one
// confusion matrix per test set over all its images, printed as its Table 2.
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <map>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/augment/scene.hpp"
#include "fishcam/eval/metrics.hpp"
#include "image_files.hpp"

namespace fishcam::cli {
namespace {

namespace fs = std::filesystem;

struct TestSet {
  std::string name;
  fs::path pred, gt, valid;  // valid: empty, or a folder of masks (non-zero: scored)
};

// A WoodScape-layout folder holds its labels in semantic_annotations/gtLabels.
fs::path label_folder(const fs::path& dir) {
  const fs::path woodscape = dir / "semantic_annotations" / "gtLabels";
  return fs::is_directory(woodscape) ? woodscape : dir;
}

// Label files of a folder by stem; two files with one stem are ambiguous.
std::map<std::string, fs::path> label_files(const fs::path& dir, const std::string& what) {
  if (!fs::is_directory(dir)) throw Error(path_for_message(dir) + ": no such folder (" + what + ")");
  std::map<std::string, fs::path> files;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; it != end; it.increment(ec)) {
    if (ec) break;
    const fs::directory_entry& entry = *it;
    if (!lossless_label_format(entry.path())) continue;
    // A label name that is not a readable regular file (a symlink loop, a device) is
    // an error, not a file silently left out of the score.
    const bool regular = entry.is_regular_file(ec);
    if (ec || !regular) {
      throw Error(path_for_message(entry.path()) + ": not a regular file" +
                  (ec ? " (" + ec.message() + ")" : std::string()));
    }
    const auto [at, inserted] = files.emplace(entry.path().stem().string(), entry.path());
    if (!inserted)
      throw Error(path_for_message(entry.path()) + ": two label files named " + path_for_message(at->second.stem()));
  }
  if (ec) throw Error(path_for_message(dir) + ": cannot list (" + ec.message() + ")");
  if (files.empty()) throw Error(path_for_message(dir) + ": no label images (PNG, TIFF or PGM) (" + what + ")");
  return files;
}

cv::Mat read_labels(const fs::path& path) {
  cv::Mat labels = read_image(path.string(), cv::IMREAD_UNCHANGED);
  if (labels.channels() != 1) throw Error(path_for_message(path) + ": expected a single-channel label image");
  return labels;
}

ConfusionMatrix evaluate_set(const TestSet& set, int classes, std::optional<std::int64_t> ignore, long* images) {
  const auto truths = label_files(label_folder(set.gt), "ground truth of " + set.name);
  const auto predictions = label_files(label_folder(set.pred), "predictions of " + set.name);
  std::map<std::string, fs::path> masks;
  if (!set.valid.empty()) masks = label_files(set.valid, "validity masks of " + set.name);
  for (const auto& [stem, path] : predictions) {
    if (!truths.count(stem))
      throw Error(path_for_message(path) + ": no ground truth named " + text_for_message(stem) + " in " +
                  path_for_message(set.gt));
  }
  ConfusionMatrix matrix(classes, ignore);
  for (const auto& [stem, gt_path] : truths) {
    const auto pred = predictions.find(stem);
    if (pred == predictions.end()) {
      throw Error(path_for_message(gt_path) + ": no prediction named " + text_for_message(stem) + " in " +
                  path_for_message(set.pred));
    }
    const cv::Mat truth = read_labels(gt_path), prediction = read_labels(pred->second);
    cv::Mat valid;
    if (!set.valid.empty()) {
      const auto mask = masks.find(stem);
      if (mask == masks.end())
        throw Error(path_for_message(gt_path) + ": no validity mask named " + text_for_message(stem) + " in " +
                    path_for_message(set.valid));
      valid = read_labels(mask->second);
      if (valid.type() != CV_8UC1 || valid.size() != truth.size()) {
        throw Error(path_for_message(mask->second) + ": expected an 8-bit mask of the ground truth's size");
      }
    }
    if (prediction.size() != truth.size()) {
      throw Error(path_for_message(pred->second) + ": is " + std::to_string(prediction.cols) + "x" +
                  std::to_string(prediction.rows) + " but its ground truth " + path_for_message(gt_path) + " is " +
                  std::to_string(truth.cols) + "x" + std::to_string(truth.rows));
    }
    // A value error names the file it is in: the ground truth's are checked first.
    try {
      ConfusionMatrix(classes, ignore).update(truth, truth, valid);
    } catch (const Error& e) {
      throw Error(path_for_message(gt_path) + ": " + e.what());
    }
    try {
      matrix.update(prediction, truth, valid);
    } catch (const Error& e) {
      throw Error(path_for_message(pred->second) + ": " + e.what());
    }
  }
  *images = long(truths.size());
  return matrix;
}

// The test sets of a root that augment-dataset wrote with several presets (one
// sub-folder each, in the presets' order), else the root itself as one set.
std::vector<TestSet> sets_of(const fs::path& pred, const fs::path& gt, const fs::path& valid) {
  if (fs::is_directory(gt / "semantic_annotations" / "gtLabels") || !fs::is_directory(gt)) {
    return {{gt.filename().string(), pred, gt, valid}};
  }
  std::vector<TestSet> sets;
  for (const PosePreset& preset : pose_presets()) {
    const std::string name(preset.name);
    if (fs::is_directory(gt / name / "semantic_annotations" / "gtLabels")) {
      if (!valid.empty()) throw Error("--valid: one folder of masks cannot serve several test sets (use --set)");
      sets.push_back({name, pred / name, gt / name, {}});
    }
  }
  if (sets.empty()) return {{gt.filename().string(), pred, gt, valid}};
  return sets;
}

TestSet parse_set(const std::string& text) {
  const size_t eq = text.find('=');
  const std::string rest = eq == std::string::npos ? "" : text.substr(eq + 1);
  const size_t colon = rest.find(':');
  if (eq == 0 || eq == std::string::npos || colon == std::string::npos || colon == 0 || colon + 1 == rest.size()) {
    throw Error("--set: expected NAME=PRED_DIR:GT_DIR[:VALID_DIR], got " + quoted_for_message(text));
  }
  TestSet set{text.substr(0, eq), rest.substr(0, colon), rest.substr(colon + 1), {}};
  const std::string gt = set.gt.string();
  if (const size_t second = gt.find(':'); second != std::string::npos) {
    set.gt = gt.substr(0, second);
    set.valid = gt.substr(second + 1);
  }
  return set;
}

std::string percent(std::optional<double> value, int width) {
  char buffer[32];
  if (value) {
    std::snprintf(buffer, sizeof buffer, "%*.2f", width, 100 * *value);
  } else {
    std::snprintf(buffer, sizeof buffer, "%*s", width, "-");
  }
  return buffer;
}

struct EvaluateOptions {
  std::string pred, gt, valid, classes = "woodscape";
  std::vector<std::string> sets;
  std::int64_t ignore = 0;
  bool json = false;
};

// --classes: woodscape's names, or N classes named 0..N-1.
std::vector<std::string> class_names_of(const std::string& classes) {
  std::vector<std::string> names;
  if (classes == "woodscape") {
    for (int c = 0; c < woodscape_class::kCount; ++c) names.emplace_back(woodscape_class_name(c));
    return names;
  }
  char* end = nullptr;
  const long n = std::strtol(classes.c_str(), &end, 10);
  if (classes.empty() || *end != '\0' || n < 1 || n > 1024) {
    throw Error("--classes: expected woodscape or a number of classes from 1 to 1024, got " +
                quoted_for_message(classes));
  }
  for (long c = 0; c < n; ++c) names.push_back(std::to_string(c));
  return names;
}

// One test set's scores as --json gives them (IoU and mIoU in %) and its mIoU; for
// a set after the first, its degradation against the first set's mIoU.
struct FirstSet {
  std::optional<double> miou;
};
nlohmann::ordered_json set_result(const TestSet& set, const std::vector<std::string>& class_names,
                                  std::optional<std::int64_t> ignored, const FirstSet* first,
                                  std::optional<double>* miou_out) {
  long images = 0;
  const ConfusionMatrix matrix = evaluate_set(set, int(class_names.size()), ignored, &images);
  const auto iou = matrix.iou();
  const auto miou = matrix.miou();
  const auto percent_or_null = [](std::optional<double> v) {
    return v ? nlohmann::ordered_json(100 * *v) : nlohmann::ordered_json(nullptr);
  };
  nlohmann::ordered_json j{{"name", set.name}, {"images", images}, {"pixels", matrix.scored_pixels()}};
  j["miou"] = percent_or_null(miou);
  j["iou"] = nlohmann::ordered_json::object();
  j["absent"] = nlohmann::ordered_json::array();
  for (size_t c = 0; c < class_names.size(); ++c) {
    j["iou"][class_names[c]] = percent_or_null(iou[c]);
    if (!iou[c]) j["absent"].push_back(class_names[c]);
  }
  if (first) {
    std::optional<double> degradation;
    if (miou && first->miou && *first->miou > 0) degradation = (*miou - *first->miou) / *first->miou;
    j["degradation_pct"] = percent_or_null(degradation);
  }
  *miou_out = miou;
  return j;
}

// The paper's Table 2: a row per test set, mIoU, its relative change against the
// first set, IoU per class; then the classes left out and the ignored value.
void print_table(const std::vector<TestSet>& sets, const nlohmann::ordered_json& results,
                 const std::vector<std::string>& class_names, std::optional<std::int64_t> ignored) {
  size_t name_width = 8;
  for (const TestSet& set : sets) name_width = std::max(name_width, set.name.size());
  std::printf("%-*s %7s %9s %12s", int(name_width), "test set", "images", "mIoU (%)", "degrades (%)");
  for (const std::string& name : class_names) std::printf(" %*s", int(std::max<size_t>(6, name.size())), name.c_str());
  std::printf("\n");
  const auto value = [](const nlohmann::ordered_json& v) {
    return v.is_null() ? std::optional<double>() : std::optional<double>(v.get<double>() / 100);
  };
  for (size_t s = 0; s < sets.size(); ++s) {
    const nlohmann::ordered_json& r = results[s];
    std::printf("%-*s %7ld %9s %12s", int(name_width), sets[s].name.c_str(), r["images"].get<long>(),
                percent(value(r["miou"]), 9).c_str(),
                s == 0 ? "           -" : percent(value(r["degradation_pct"]), 12).c_str());
    for (const std::string& name : class_names) {
      std::printf(" %s", percent(value(r["iou"][name]), int(std::max<size_t>(6, name.size()))).c_str());
    }
    std::printf("\n");
  }
  for (size_t s = 0; s < sets.size(); ++s) {
    if (results[s]["absent"].empty()) continue;
    std::string names;
    for (const auto& name : results[s]["absent"]) names += (names.empty() ? "" : ", ") + name.get<std::string>();
    std::printf("%s: absent from prediction and ground truth, left out of its mIoU: %s\n", sets[s].name.c_str(),
                names.c_str());
  }
  if (ignored) std::printf("ground-truth pixels of value %lld are not scored\n", static_cast<long long>(*ignored));
}

void run_evaluate(const EvaluateOptions& o, bool ignore_given) {
  const std::vector<std::string> class_names = class_names_of(o.classes);
  std::vector<TestSet> sets;
  if (!o.sets.empty()) {
    for (const std::string& text : o.sets) sets.push_back(parse_set(text));
  } else if (!o.gt.empty()) {
    sets = sets_of(o.pred, o.gt, o.valid);
  } else {
    throw Error("give --pred and --gt, or --set NAME=PRED_DIR:GT_DIR");
  }
  const std::optional<std::int64_t> ignored = ignore_given ? std::optional(o.ignore) : std::nullopt;
  nlohmann::ordered_json results = nlohmann::ordered_json::array();
  FirstSet first;
  for (const TestSet& set : sets) {
    std::optional<double> miou;
    results.push_back(set_result(set, class_names, ignored, results.empty() ? nullptr : &first, &miou));
    if (results.size() == 1) first.miou = miou;
  }
  if (o.json) {
    const nlohmann::ordered_json out = results.size() == 1 ? results[0] : nlohmann::ordered_json{{"sets", results}};
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  print_table(sets, results, class_names, ignored);
}

}  // namespace

void register_evaluate(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "evaluate",
      "Score segmentation predictions against ground truth (the paper's eqs. 11-12): IoU per class and mIoU over one "
      "confusion matrix per test set");
  auto o = std::make_shared<EvaluateOptions>();
  auto* pred = cmd->add_option("--pred", o->pred, "Folder of predicted label images (matched to --gt by file stem)");
  auto* gt = cmd->add_option("--gt", o->gt,
                             "Folder of ground-truth label images, a WoodScape-layout folder, or a folder that "
                             "augment-dataset wrote with several presets (one test set per preset; predictions in "
                             "same-named sub-folders of --pred)");
  auto* valid = cmd->add_option("--valid", o->valid, "Folder of validity masks (non-zero: scored), matched by stem");
  auto* sets = cmd->add_option("--set", o->sets,
                               "Test set NAME=PRED_DIR:GT_DIR[:VALID_DIR]; repeat for several (degradation is "
                               "relative to the first)");
  cmd->add_option("--classes", o->classes, "woodscape (its 10 classes) or the number of classes")
      ->capture_default_str();
  auto* ignore = cmd->add_option("--ignore", o->ignore,
                                 "Ground-truth value not scored (e.g. 255 with augment-dataset --label-fill 255)");
  cmd->add_flag("--json", o->json, "Print the results as JSON (IoU and mIoU in %)");
  pred->needs(gt);
  gt->needs(pred);
  valid->needs(gt);
  sets->excludes(pred)->excludes(gt);
  cmd->callback([o, ignore] { run_evaluate(*o, ignore->count() > 0); });
}

}  // namespace fishcam::cli
