// fishcam augment-dataset ROOT: every image of a WoodScape-layout dataset, K copies
// each, with seeded random poses; resumable, never writes inside ROOT.
#include <fcntl.h>
#include <opencv2/imgcodecs.hpp>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/atomic_file.hpp"
#include "fishcam/camera_io.hpp"

namespace fishcam::cli {
namespace {

namespace fs = std::filesystem;

bool is_image(const fs::path& p) {
  std::string ext = p.extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

class Progress {
 public:
  explicit Progress(size_t total) : total_(total), terminal_(isatty(STDERR_FILENO)) {}
  void step(const std::string& what) {
    ++done_;
    if (!terminal_) return;
    const int width = 30, filled = int(width * done_ / std::max<size_t>(total_, 1));
    std::fprintf(stderr, "\r[%s%s] %zu/%zu %-40.40s", std::string(filled, '#').c_str(),
                 std::string(width - filled, ' ').c_str(), done_, total_, what.c_str());
    if (done_ == total_) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  }
  // A message on its own line, without breaking the bar.
  void report(const std::string& message) const {
    std::fprintf(stderr, "%s%s\n", terminal_ ? "\r\033[K" : "", message.c_str());
  }

 private:
  size_t total_, done_ = 0;
  bool terminal_;
};

// One warp per distinct calibration: building one unprojects every pixel and
// measures the grid, while a WoodScape set has a handful of cameras behind
// thousands of per-image calibration files.
class WarpCache {
 public:
  std::shared_ptr<const ViewpointWarp> get(const Camera& camera) {
    CameraParameters intrinsics = camera.parameters();
    intrinsics.pose.reset();  // the warp depends on the intrinsics and the size only
    const std::string key = format_camera(intrinsics, CameraFormat::fishcam);
    if (const auto found = warps_.find(key); found != warps_.end()) return found->second;
    if (warps_.size() >= kLimit) warps_.clear();  // a dataset with very many cameras: start over
    return warps_[key] = std::make_shared<const ViewpointWarp>(camera);
  }

 private:
  static constexpr std::size_t kLimit = 64;
  std::map<std::string, std::shared_ptr<const ViewpointWarp>> warps_;
};

// A preset's manifest (manifest.jsonl, or manifest-K-of-N.jsonl for a shard),
// locked for the whole run: a second run on the same manifest (the same --out and
// --shard) is refused instead of interleaving duplicate lines; shards have their
// own manifests and run in parallel. The lock goes with the process, killed or not.
class Manifest {
 public:
  Manifest(const fs::path& path, const std::string& method, Progress& progress) : path_(path) {
    fd_ = open(path.c_str(), O_RDWR | O_CREAT | O_APPEND | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd_ < 0) throw Error(path_for_message(path) + ": cannot write (" + std::strerror(errno) + ")");
    if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      close(fd_);
      throw Error(path_for_message(path) +
                  ": another run is writing this manifest (wait for it; parallel runs into one --out need "
                  "--shard K/N each)");
    }
    read_lines(method, progress);
  }
  ~Manifest() { close(fd_); }
  Manifest(const Manifest&) = delete;
  Manifest& operator=(const Manifest&) = delete;

  bool lists(const std::string& output) const { return listed_.count(output) != 0; }
  // Appends one line in one write (a kill leaves at most a cut last line, which the
  // next run drops).
  void append(const nlohmann::json& line) {
    const std::string text = line.dump() + "\n";
    if (write(fd_, text.data(), text.size()) != ssize_t(text.size())) {
      throw Error(path_for_message(path_) + ": write failed (" + std::strerror(errno) + ")");
    }
    listed_.insert(line.at("output").get<std::string>());
  }

 private:
  // The lines already there (a resumed run appends only what is new). A last line
  // cut short (a crash or power loss mid-write) is dropped, and said.
  void read_lines(const std::string& method, Progress& progress) {
    std::string content;
    char buffer[1 << 16];
    for (ssize_t n; (n = pread(fd_, buffer, sizeof buffer, off_t(content.size()))) != 0;) {
      if (n < 0) throw Error(path_for_message(path_) + ": cannot read (" + std::strerror(errno) + ")");
      content.append(buffer, std::size_t(n));
    }
    size_t start = 0;
    while (start < content.size()) {
      const size_t end = content.find('\n', start);
      std::string line_method;
      try {
        if (end == std::string::npos) throw std::runtime_error("cut");
        const nlohmann::json entry = nlohmann::json::parse(content.substr(start, end - start));
        listed_.insert(entry.at("output").get<std::string>());
        line_method = entry.value("method", "viewpoint");  // manifests before the affine baseline: viewpoint
      } catch (const std::exception&) {
        if (end != std::string::npos) throw Error(path_for_message(path_) + ": unreadable line (not written by fishcam?)");
        progress.report(path_for_message(path_) + ": dropped an incomplete last line (an interrupted run)");
        if (ftruncate(fd_, off_t(start)) != 0) {
          throw Error(path_for_message(path_) + ": cannot truncate (" + std::strerror(errno) + ")");
        }
        break;
      }
      if (line_method != method) {
        throw Error(path_for_message(path_) + ": written with --method " + quoted_for_message(line_method) +
                    ", not " + method + " (use another --out)");
      }
      start = end + 1;
    }
  }

  fs::path path_;
  int fd_ = -1;
  std::set<std::string> listed_;
};

struct DatasetOptions {
  std::string root, out, presets = "train", depth = "source-sphere", shard, method = "viewpoint", sampling = "grid";
  std::uint64_t seed = 0;
  int copies = 1, threads = 0, label_fill = 0;
};

// --shard K/N: images K, K+N, ... of the name-ordered list, with a manifest of its own.
struct Shard {
  bool given = false;
  int index = 0, count = 1;
  std::string manifest_name() const {
    return given ? "manifest-" + std::to_string(index) + "-of-" + std::to_string(count) + ".jsonl" : "manifest.jsonl";
  }
};

Shard parse_shard(const std::string& text) {
  Shard shard;
  if (text.empty()) return shard;
  char slash = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &shard.index, &slash, &shard.count, &extra) != 3 || slash != '/' ||
      shard.count < 1 || shard.count > 100000 || shard.index < 0 || shard.index >= shard.count) {
    throw Error("--shard: expected K/N with 0 <= K < N (e.g. 0/4), got " + quoted_for_message(text));
  }
  shard.given = true;
  return shard;
}

// The dataset's images (rgb_images/), in name order, this shard's only.
std::vector<fs::path> list_images(const fs::path& root, const Shard& shard) {
  const fs::path images_dir = root / "rgb_images";
  if (!fs::is_directory(images_dir)) throw Error(path_for_message(images_dir) + ": missing (expected WoodScape layout)");
  std::vector<fs::path> images;
  for (const auto& entry : fs::directory_iterator(images_dir)) {
    if (entry.is_regular_file() && is_image(entry.path())) images.push_back(entry.path());
  }
  std::sort(images.begin(), images.end());
  if (images.empty()) throw Error(path_for_message(images_dir) + ": no images");
  std::vector<fs::path> mine;
  for (size_t i = size_t(shard.index); i < images.size(); i += size_t(shard.count)) mine.push_back(images[i]);
  return mine;
}

// One preset's output: its folder (a sub-folder per preset when there are several)
// and its manifest, locked.
struct PresetOutput {
  PosePreset preset;
  fs::path dir;
  std::unique_ptr<Manifest> manifest;
};

// An image of the dataset with its labels and camera, loaded when first needed
// (a resumed run that has every output reads nothing).
struct DatasetImage {
  fs::path image_path, label_path, calibration_path;
  std::optional<Camera> camera;
  std::shared_ptr<const ViewpointWarp> warp;
  cv::Mat image, labels;

  void load(WarpCache& warps) {
    if (warp) return;
    camera = read_camera(calibration_path);
    warp = warps.get(*camera);
    image = read_image(image_path.string(), cv::IMREAD_UNCHANGED);
    labels = read_image(label_path.string(), cv::IMREAD_UNCHANGED);
    if (labels.channels() != 1) throw Error(path_for_message(label_path) + ": expected a single-channel label image");
  }
};

class DatasetAugmentation {
 public:
  explicit DatasetAugmentation(const DatasetOptions& o)
      : o_(o), root_(o.root), out_(o.out), prior_(depth_prior(o.depth, "--depth")),
        sampling_(*parse_sampling(o.sampling)), affine_(o.method == "affine") {}

  void run() {
    const Shard shard = parse_shard(o_.shard);
    check_output_not_input(out_, {root_}, true);
    std::stringstream list(o_.presets);
    std::vector<PosePreset> presets;
    for (std::string name; std::getline(list, name, ',');) presets.push_back(pose_preset(name, "--preset"));
    if (o_.threads > 0) cv::setNumThreads(o_.threads);
    const std::vector<fs::path> images = list_images(root_, shard);
    if (images.empty()) {
      std::printf("shard %d/%d: no images (the dataset has fewer than %d)\n", shard.index, shard.count, shard.index + 1);
      return;
    }
    Progress progress(images.size() * presets.size());
    std::vector<PresetOutput> outputs = prepare_outputs(presets, shard, progress);
    for (PresetOutput& output : outputs) {
      for (const fs::path& image_path : images) {
        const std::string stem = image_path.stem().string();
        progress.step(stem);
        try {
          augment_image(output, image_path);
        } catch (const std::exception& e) {
          failures_.push_back(path_for_message(stem) + ": " + e.what());
          progress.report("skipped " + failures_.back());
        }
      }
    }
    std::printf("%ld written, %ld already there, %zu failed, into %s\n", written_, skipped_, failures_.size(),
                out_.c_str());
    if (!failures_.empty()) {
      throw Error(std::to_string(failures_.size()) + " image/preset run(s) failed, first: " + failures_.front());
    }
  }

 private:
  // Every output folder is checked (symlinks inside --out included) before any is
  // created, then created, cleared of killed runs' temporaries, and its manifest locked.
  std::vector<PresetOutput> prepare_outputs(const std::vector<PosePreset>& presets, const Shard& shard,
                                            Progress& progress) const {
    std::vector<PresetOutput> outputs;
    for (const PosePreset& preset : presets) {
      outputs.push_back({preset, presets.size() > 1 ? out_ / std::string(preset.name) : out_, nullptr});
      for (const char* sub : {"", "rgb_images", "semantic_annotations", "semantic_annotations/gtLabels", "calibration"}) {
        check_output_not_input(outputs.back().dir / sub, {root_}, true);
      }
    }
    for (PresetOutput& output : outputs) {
      for (const char* sub : {"rgb_images", "semantic_annotations/gtLabels", "calibration"}) {
        fs::create_directories(output.dir / sub);
        remove_stale_temporaries(output.dir / sub);  // of killed runs; parallel runs' stay
      }
      output.manifest = std::make_unique<Manifest>(output.dir / shard.manifest_name(), o_.method, progress);
    }
    return outputs;
  }

  // Every copy of one image under one preset: written unless already there, and
  // listed in the manifest unless already listed.
  void augment_image(PresetOutput& output, const fs::path& image_path) {
    // The manifest is JSON: a name it cannot hold is refused before anything is written.
    if (!is_valid_utf8(image_path.filename().native())) {
      throw Error(path_for_message(image_path) + ": the file name is not valid UTF-8 (rename it)");
    }
    const std::string stem = image_path.stem().string();
    DatasetImage source{image_path, root_ / "semantic_annotations" / "gtLabels" / (stem + ".png"),
                        root_ / "calibration" / (stem + ".json"), std::nullopt, nullptr, {}, {}};
    const std::string preset_name(output.preset.name);
    for (int copy = 0; copy < o_.copies; ++copy) {
      const std::string name = stem + "_" + preset_name + std::to_string(copy);
      const fs::path out_image = output.dir / "rgb_images" / (name + image_path.extension().string());
      const fs::path out_label = output.dir / "semantic_annotations" / "gtLabels" / (name + ".png");
      const fs::path out_calibration = output.dir / "calibration" / (name + ".json");
      const std::uint64_t seed = derive_seed(o_.seed, stem + "/" + preset_name, copy);
      const RandomPose pose = random_pose(output.preset, seed);
      const AffineChange affine_change = affine_ ? random_affine(affine_preset(preset_name), seed) : AffineChange{};
      if (fs::exists(out_image) && fs::exists(out_label) && (affine_ || fs::exists(out_calibration))) {
        ++skipped_;
      } else {
        source.load(warps_);
        write_copy(source, pose, affine_change, out_image, out_label, out_calibration);
        ++written_;
      }
      const std::string listed = fs::relative(out_image, output.dir).string();
      if (!output.manifest->lists(listed)) {
        output.manifest->append(manifest_line(image_path, listed, copy, output.preset, seed, pose, affine_change));
      }
    }
  }

  void write_copy(const DatasetImage& source, const RandomPose& pose, const AffineChange& affine_change,
                  const fs::path& out_image, const fs::path& out_label, const fs::path& out_calibration) const {
    cv::Mat out_pixels, out_labels;
    const AugmentIO io{&source.image, &out_pixels, 0, &source.labels, &out_labels, o_.label_fill, nullptr};
    if (affine_) {
      affine_augment(affine_change, cv::Size(source.camera->width(), source.camera->height()), io);
    } else {
      source.warp->augment(pose.change(), prior_, io, sampling_);
    }
    std::vector<std::pair<fs::path, std::string>> files{{out_image, encode_image(out_image, out_pixels)},
                                                         {out_label, encode_image(out_label, out_labels)}};
    if (!affine_) {
      // The output camera: same intrinsics, the moved pose (translation in
      // unit-sphere units, written as metres).
      files.emplace_back(out_calibration,
                         format_camera(augmented_camera(source.camera->parameters(), pose.change()),
                                       CameraFormat::woodscape));
    }
    // The files land together (a killed run leaves none of them).
    write_files_atomically(files, true);
  }

  nlohmann::json manifest_line(const fs::path& image_path, const std::string& output, int copy,
                               const PosePreset& preset, std::uint64_t seed, const RandomPose& pose,
                               const AffineChange& affine_change) const {
    nlohmann::json line{{"image", image_path.filename().string()},
                        {"output", output},
                        {"copy", copy},
                        {"preset", preset.name},
                        {"seed", seed}};
    if (affine_) {
      line.update(affine_to_json(affine_change));
    } else {
      const auto& r = pose.rotation_deg;
      const auto& t = pose.translation;
      line.update({{"method", "viewpoint"},
                   {"sampling", o_.sampling},
                   {"rotation_deg", {r.x(), r.y(), r.z()}},
                   {"translation", {t.x(), t.y(), t.z()}},
                   {"depth", to_string(prior_)}});
    }
    return line;
  }

  const DatasetOptions& o_;
  const fs::path root_, out_;
  const DepthPrior prior_;
  const Sampling sampling_;
  const bool affine_;
  WarpCache warps_;
  long written_ = 0, skipped_ = 0;
  std::vector<std::string> failures_;
};

}  // namespace

void register_augment_dataset(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "augment-dataset",
      "Augment a WoodScape-layout dataset (rgb_images/, semantic_annotations/gtLabels/, calibration/): K copies per "
      "image with seeded random poses, a manifest.jsonl, resumable");
  auto o = std::make_shared<DatasetOptions>();
  cmd->add_option("ROOT", o->root, "Dataset folder (read only)")->required()->check(CLI::ExistingDirectory);
  cmd->add_option("--preset", o->presets,
                  "Pose preset, or several separated by commas (small,medium,large: the paper's test sets, one "
                  "sub-folder each)")
      ->required();
  cmd->add_option("--seed", o->seed, "Seed; each image and copy gets its own seed derived from it")->required();
  cmd->add_option("--out", o->out, "Output folder (must not be inside ROOT)")->required();
  cmd->add_option("--copies", o->copies, "Augmented copies per image")->check(CLI::Range(1, 1000))->capture_default_str();
  cmd->add_option("-j,--threads", o->threads, "Threads (0: all cores)")->check(CLI::Range(0, 256))->capture_default_str();
  cmd->add_option("--depth", o->depth, "Depth prior")
      ->check(CLI::IsMember(depth_prior_names()))
      ->capture_default_str();
  cmd->add_option("--method", o->method,
                  "viewpoint, or affine: the paper's baseline (no camera model; no calibration files are written, "
                  "since no camera model describes the result)")
      ->check(CLI::IsMember({"viewpoint", "affine"}))
      ->capture_default_str();
  cmd->add_option("--sampling", o->sampling,
                  "Viewpoint maps: grid (interpolated to within 1/32 px, fast) or exact (per pixel); recorded in the "
                  "manifest")
      ->check(CLI::IsMember(sampling_names()))
      ->capture_default_str();
  cmd->add_option("--label-fill", o->label_fill, "Label for pixels without a source")->capture_default_str();
  cmd->add_option("--shard", o->shard,
                  "K/N: only images K, K+N, K+2N, ... (in name order, K in [0, N)), manifest-K-of-N.jsonl; the N "
                  "shards together equal one unsharded run");
  cmd->callback([o] { DatasetAugmentation(*o).run(); });
}

}  // namespace fishcam::cli
