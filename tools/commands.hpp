// The fishcam program's subcommands: each file registers one.
#pragma once

#include <CLI/CLI.hpp>

namespace fishcam::cli {

void register_info(CLI::App& app);
void register_project(CLI::App& app);
void register_unproject(CLI::App& app);
void register_bench(CLI::App& app);
void register_bench_render(CLI::App* bench);  // under bench
void register_render(CLI::App& app);
void register_map(CLI::App& app);
void register_augment(CLI::App& app);
void register_check_mrcal(CLI::App& app);
void register_demo(CLI::App& app);
void register_augment_dataset(CLI::App& app);
void register_convert(CLI::App& app);
void register_fit(CLI::App& app);
void register_diff(CLI::App& app);
void register_detect_corners(CLI::App& app);
void register_synth_corners(CLI::App& app);
void register_calibrate(CLI::App& app);
void register_sample_dataset(CLI::App& app);
void register_evaluate(CLI::App& app);
void register_compare(CLI::App& app);
void register_uncertainty(CLI::App& app);
void register_fidelity(CLI::App& app);
void register_report(CLI::App& app);

}  // namespace fishcam::cli
