#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <string>
#include <utility>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/core/error.hpp"

namespace {

// Every number option of every subcommand, whoever declared it: floating-point
// values must be finite (a NaN rotation used to write a black image) and unsigned
// integers must be integers in their range (CLI11 reads -1 as 2^64 - 1 and clamps
// 2^64 and more to 2^64 - 1: a seed no one gave).
void guard_number_options(CLI::App* app) {
  static const CLI::Validator finite(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        return std::isfinite(value) ? "" : "must be a finite number, got " + fishcam::quoted_for_message(text);
      },
      "", "finite");
  static const CLI::Validator non_negative(
      [](std::string& text) -> std::string {
        if (text.find('-') != std::string::npos)
          return "must not be negative, got " + fishcam::quoted_for_message(text);
        std::uint64_t value = 0;
        const char* end = text.data() + text.size();
        const auto [next, error] = std::from_chars(text.data(), end, value);
        return !text.empty() && error == std::errc() && next == end
                   ? ""
                   : "must be an integer in [0, 2^64), got " + fishcam::quoted_for_message(text);
      },
      "", "non-negative");
  for (CLI::Option* option : app->get_options()) {
    const std::string type = option->get_type_name();  // with the validators' words after it
    if (type.starts_with("FLOAT")) option->check(finite);
    if (type.starts_with("UINT")) option->check(non_negative);
  }
  for (CLI::App* sub : app->get_subcommands({})) guard_number_options(sub);
}

// Library messages name library concepts; the program says which of its options
// set them.
std::string in_cli_terms(std::string message) {
  static const std::pair<const char*, const char*> kOptions[] = {
      {"max_angle", "--max-angle"},
      {"fit_center", "--fit-center"},
      {"fit_aspect", "--fit-aspect"},
      {"image_size", "--imagersize"},
      {"say which (distortion_model", "say which (--distortion-model"},
      {"samples: ", "--samples: "}};
  for (const auto& [concept_name, option] : kOptions) {
    for (size_t at = message.find(concept_name); at != std::string::npos;
         at = message.find(concept_name, at + std::strlen(option))) {
      message.replace(at, std::strlen(concept_name), option);
    }
  }
  return message;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"fishcam: calibration-aware fisheye projection models"};
  app.require_subcommand(1);
  // One line on stderr for a usage error; --help shows the rest.
  app.failure_message([](const CLI::App* failed, const CLI::Error& e) {
    std::string what = e.what();
    // CLI11 reports a misspelt subcommand as a missing one: name the word instead.
    const std::vector<std::string> extra = failed->remaining(true);
    if (what.find("subcommand is required") != std::string::npos && !extra.empty()) {
      what = "unknown subcommand " + fishcam::quoted_for_message(extra.front());
    }
    return "fishcam: error: " + what + " (see --help)\n";
  });
  fishcam::cli::register_info(app);
  fishcam::cli::register_project(app);
  fishcam::cli::register_unproject(app);
  fishcam::cli::register_bench(app);
  fishcam::cli::register_render(app);
  fishcam::cli::register_map(app);
  fishcam::cli::register_augment(app);
  fishcam::cli::register_check_mrcal(app);
  fishcam::cli::register_demo(app);
  fishcam::cli::register_augment_dataset(app);
  fishcam::cli::register_convert(app);
  fishcam::cli::register_fit(app);
  fishcam::cli::register_detect_corners(app);
  fishcam::cli::register_synth_corners(app);
  fishcam::cli::register_calibrate(app);
  fishcam::cli::register_diff(app);
  fishcam::cli::register_uncertainty(app);
  fishcam::cli::register_fidelity(app);
  fishcam::cli::register_report(app);
  fishcam::cli::register_sample_dataset(app);
  fishcam::cli::register_evaluate(app);
  fishcam::cli::register_compare(app);
  guard_number_options(&app);
  // Our one line is the message: no OpenCV warnings around it.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const fishcam::Error& e) {
    std::fprintf(stderr, "fishcam: error: %s\n", in_cli_terms(e.what()).c_str());
    return 1;
  } catch (const cv::Exception& e) {
    std::fprintf(stderr, "fishcam: error: OpenCV: %s\n", e.err.c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fishcam: error: %s\n", e.what());
    return 1;
  }
  // Output that never arrived is a failure too (`fishcam info cam.json > /dev/full`).
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::fprintf(stderr, "fishcam: error: cannot write to standard output (%s)\n", std::strerror(errno));
    return 1;
  }
  return 0;
}
