// fishcam fidelity DATASET: how faithful the augmentation is to the truth, on a
// dataset of `fishcam sample-dataset --scenes N [--depth]` (dataset_fidelity).
#include <nlohmann/json.hpp>

#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/eval/fidelity.hpp"

namespace fishcam::cli {
namespace {

void run(const std::string& dataset, bool json) {
  const std::vector<DatasetFidelity> rows = dataset_fidelity(dataset);
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const DatasetFidelity& r : rows) {
      out.push_back({{"test_set", r.test_set},
                     {"prior", r.prior},
                     {"samples", r.samples},
                     {"valid_share", r.valid_share},
                     {"label_agreement", r.label_agreement},
                     {"psnr_db", r.psnr_db}});
    }
    std::printf("%s\n", nlohmann::json{{"dataset", dataset}, {"rows", out}}.dump(2).c_str());
    return;
  }
  std::printf("test set                 prior          samples  with a source  labels agree  PSNR dB\n");
  for (const DatasetFidelity& r : rows) {
    std::printf("%-24s %-14s %7d %13.1f%% %12.2f%% %8.2f\n", r.test_set.c_str(), r.prior.c_str(), r.samples,
                100 * r.valid_share, 100 * r.label_agreement, r.psnr_db);
  }
}

}  // namespace

void register_fidelity(CLI::App& app) {
  auto* cmd = app.add_subcommand("fidelity",
                                 "Augmentation against the truth: each test sample augmented by each true "
                                 "viewpoint test set's change, under every depth prior (and the depth map "
                                 "when the dataset has one), against the re-render from the moved camera");
  auto dataset = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  cmd->add_option("DATASET", *dataset, "Folder of fishcam sample-dataset --scenes N [--depth]")->required();
  cmd->add_flag("--json", *json, "Print one JSON object");
  cmd->callback([dataset, json] { run(*dataset, *json); });
}

}  // namespace fishcam::cli
