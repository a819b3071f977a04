// fishcam fidelity DATASET: how faithful the augmentation is to the truth, on a
// dataset of `fishcam sample-dataset --scenes N [--depth]`: per depth prior
// (dataset_fidelity), or with --models per model of the camera (the paper's Table 5
// by geometry: dataset_model_fidelity).
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/eval/fidelity.hpp"

namespace fishcam::cli {
namespace {

struct FidelityOptions {
  std::string dataset;
  std::string models;  // not given: the table per depth prior
  std::string depth = "source-sphere";
  bool json = false;
};

void print_priors(const FidelityOptions& o) {
  const std::vector<DatasetFidelity> rows = dataset_fidelity(o.dataset);
  if (o.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const DatasetFidelity& r : rows) {
      out.push_back({{"test_set", r.test_set},
                     {"prior", r.prior},
                     {"samples", r.samples},
                     {"valid_share", r.valid_share},
                     {"label_agreement", r.label_agreement},
                     {"psnr_db", r.psnr_db}});
    }
    std::printf("%s\n", nlohmann::json{{"dataset", o.dataset}, {"rows", out}}.dump(2).c_str());
    return;
  }
  std::printf("test set                 prior          samples  with a source  labels agree  PSNR dB\n");
  for (const DatasetFidelity& r : rows) {
    std::printf("%-24s %-14s %7d %13.1f%% %12.2f%% %8.2f\n", r.test_set.c_str(), r.prior.c_str(), r.samples,
                100 * r.valid_share, 100 * r.label_agreement, r.psnr_db);
  }
}

// NaN (a band without pixels) as JSON null.
nlohmann::json number_or_null(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(); }

void print_models(const FidelityOptions& o) {
  const DepthPrior prior = depth_prior(o.depth, "--depth");
  const std::vector<ModelFidelity> rows =
      dataset_model_fidelity(o.dataset, check_fidelity_models(distinct_names(o.models, "--models")), prior);
  if (o.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const ModelFidelity& r : rows) {
      nlohmann::json bands = nlohmann::json::array();
      for (double b : r.endpoint_by_angle_px) bands.push_back(number_or_null(b));
      out.push_back({{"test_set", r.test_set},
                     {"model", r.model},
                     {"how", r.how},
                     {"samples", r.samples},
                     {"valid_share", r.valid_share},
                     {"label_agreement", r.label_agreement},
                     {"psnr_db", r.psnr_db},
                     {"endpoint_px", number_or_null(r.endpoint_px)},
                     {"endpoint_by_angle_px", bands}});
    }
    std::printf(
        "%s\n",
        nlohmann::json{
            {"dataset", o.dataset}, {"depth", o.depth}, {"angle_bands_deg", Comparison::kAngleBandsDeg}, {"rows", out}}
            .dump(2)
            .c_str());
    return;
  }
  std::printf("depth prior %s; endpoint: the model's map against the camera's own (px), by angle of incidence\n",
              o.depth.c_str());
  std::printf(
      "test set                 model                   samples  with a source  labels agree  PSNR dB  endpoint px"
      "   0-30   30-60   60-90    90+\n");
  for (const ModelFidelity& r : rows) {
    std::printf("%-24s %-22s %8d %13.1f%% %12.2f%% %8.2f %12.3f", r.test_set.c_str(), r.model.c_str(), r.samples,
                100 * r.valid_share, 100 * r.label_agreement, r.psnr_db, r.endpoint_px);
    for (double b : r.endpoint_by_angle_px) std::printf(" %7.3f", b);
    std::printf("\n");
  }
}

}  // namespace

void register_fidelity(CLI::App& app) {
  auto* cmd = app.add_subcommand("fidelity",
                                 "Augmentation against the truth: each test sample augmented by each true "
                                 "viewpoint test set's change, under every depth prior (and the depth map "
                                 "when the dataset has one), or with --models through each model of the camera, "
                                 "against the re-render from the moved camera");
  auto o = std::make_shared<FidelityOptions>();
  cmd->add_option("DATASET", o->dataset, "Folder of fishcam sample-dataset --scenes N [--depth]")->required();
  auto* models =
      cmd->add_option("--models", o->models,
                      "Comma-separated models to augment through (the paper's Table 5 by geometry): own (the camera "
                      "itself), or a model fitted to each sample's camera, with :paper (eqs. 13-14, equidistant and "
                      "stereographic) or :lsq (least squares, the default), e.g. "
                      "own,equidistant:paper,equidistant:lsq,stereographic:paper,kannala-brandt");
  auto* depth = cmd->add_option("--depth", o->depth, "Depth prior of the --models table")
                    ->check(CLI::IsMember(depth_prior_names()))
                    ->capture_default_str();
  cmd->add_flag("--json", o->json, "Print one JSON object");
  cmd->callback([o, models, depth] {
    if (!models->count()) {
      if (depth->count()) throw Error("--depth: used by the --models table only (the other compares every prior)");
      print_priors(*o);
    } else {
      print_models(*o);
    }
  });
}

}  // namespace fishcam::cli
