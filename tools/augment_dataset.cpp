// fishcam augment-dataset ROOT: every image of a WoodScape-layout dataset, K copies
// each, with seeded random poses; resumable, never writes inside ROOT.
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include <opencv2/imgcodecs.hpp>

#include <cerrno>
#include <cstring>

#include <cstdio>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/camera_io.hpp"
#include "fishcam/io/file_input.hpp"
#include "fishcam/io/output_settings.hpp"
#include "image_files.hpp"

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

constexpr const char* kCommand = "augment-dataset";
// Manifests hold a line per output; far larger than any dataset fishcam augments.
constexpr std::size_t kMaxManifestBytes = std::size_t(1) << 30;

// Why a manifest whose first line is not this run's record is not touched: another
// run's settings, an earlier fishcam's manifest (entries from the first line: no
// settings record), or not fishcam's at all.
Error manifest_refusal(const fs::path& path, const std::string& first_line) {
  const nlohmann::json entry = nlohmann::json::parse(first_line, nullptr, false);
  const char* why = OutputSettings::is_record(first_line, kCommand) ? "written with other settings than this run's"
                    : entry.is_object() && entry.contains("image") && entry.contains("output") &&
                            entry.contains("copy") && entry.contains("preset") && entry.contains("seed")
                        ? "written by an earlier fishcam, whose manifests have no settings record"
                        : "not a manifest of fishcam augment-dataset";
  return Error(path_for_message(path) + ": " + why + " (refusing to touch it: use another --out)");
}

// The outputs a manifest lists, read without locking it (another shard may be
// appending: a last line without its newline is not counted). A manifest whose first
// line is not this run's settings record was not written by this run's settings, or
// not by fishcam: refused, never touched.
std::set<std::string> listed_outputs(const fs::path& path, const std::string& record) {
  std::set<std::string> listed;
  const std::string content = read_bounded_file(path, kMaxManifestBytes, "a manifest");
  // Another shard's, just created: its record is being written (a file of someone
  // else's without a full line lists nothing either: nothing is taken for ours).
  if (content.find('\n') == std::string::npos) return listed;
  std::istringstream lines(content);
  std::string line;
  if (!std::getline(lines, line) || line != record) throw manifest_refusal(path, line);
  while (std::getline(lines, line)) {
    if (lines.eof()) break;  // cut: being written, or an interrupted run's
    const nlohmann::json entry = nlohmann::json::parse(line, nullptr, false);
    if (!entry.is_object() || !entry.contains("output") || !entry["output"].is_string()) {
      throw Error(path_for_message(path) + ": unreadable line (not written by fishcam?)");
    }
    listed.insert(entry["output"].get<std::string>());
  }
  return listed;
}

// A preset's manifest (manifest.jsonl, or manifest-K-of-N.jsonl for a shard): the
// settings record, then a line per output, appended before the output's files land
// (so every file this command writes is listed, and a later run knows it as its
// own). Locked for the whole run: a second run on the same manifest (the same --out
// and --shard) is refused instead of interleaving duplicate lines; shards have their
// own manifests and run in parallel. The lock goes with the process, killed or not.
class Manifest {
 public:
  Manifest(const fs::path& path, const std::string& record, Progress& progress) : path_(path) {
    fd_ = open(path.c_str(), O_RDWR | O_CREAT | O_APPEND | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd_ < 0) throw Error(path_for_message(path) + ": cannot write (" + std::strerror(errno) + ")");
    if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      close(fd_);
      throw Error(path_for_message(path) +
                  ": another run is writing this manifest (wait for it; parallel runs into one --out need "
                  "--shard K/N each)");
    }
    try {
      read_lines(record, progress);
    } catch (...) {
      close(fd_);
      throw;
    }
  }
  ~Manifest() { close(fd_); }
  Manifest(const Manifest&) = delete;
  Manifest& operator=(const Manifest&) = delete;

  bool lists(const std::string& output) const { return listed_.count(output) != 0; }
  // Appends one line in one write (a kill leaves at most a cut last line, which the
  // next run drops).
  void append(const nlohmann::json& line) {
    struct stat info {};
    if (fstat(fd_, &info) != 0) throw Error(path_for_message(path_) + ": cannot read (" + std::strerror(errno) + ")");
    last_start_ = info.st_size;
    last_output_ = line.at("output").get<std::string>();
    append_text(line.dump() + "\n");
    listed_.insert(last_output_);
  }
  // Takes the last line back (its files did not land: a file that appeared meanwhile,
  // a full disk), so that no later run takes a file there for this run's.
  void withdraw_last() {
    if (last_start_ < 0) return;
    if (ftruncate(fd_, last_start_) != 0) {
      throw Error(path_for_message(path_) + ": cannot truncate (" + std::strerror(errno) + ")");
    }
    listed_.erase(last_output_);
    last_start_ = -1;
  }

 private:
  void append_text(const std::string& text) {
    const off_t before = lseek(fd_, 0, SEEK_END);
    if (write(fd_, text.data(), text.size()) != ssize_t(text.size())) {
      const int error = errno;
      // A short write (a full disk) leaves no partial line behind for later runs (if
      // even that fails, the write's own error is the one to report).
      [[maybe_unused]] const int undone = before >= 0 ? ftruncate(fd_, before) : 0;
      throw Error(path_for_message(path_) + ": write failed (" + std::strerror(error) + ")");
    }
  }

  // The lines already there (a resumed run appends only what is new). A new manifest
  // starts with the settings record; an existing one must start with it (checked
  // before the lock by listed_outputs too). Only then is a last line cut short (a
  // crash or power loss mid-write) dropped, and said.
  void read_lines(const std::string& record, Progress& progress) {
    std::string content;
    char buffer[1 << 16];
    for (ssize_t n; (n = pread(fd_, buffer, sizeof buffer, off_t(content.size()))) != 0;) {
      if (n < 0) throw Error(path_for_message(path_) + ": cannot read (" + std::strerror(errno) + ")");
      content.append(buffer, std::size_t(n));
      if (content.size() > kMaxManifestBytes) throw Error(path_for_message(path_) + ": larger than a manifest can be");
    }
    if (content.empty()) return append_text(record + "\n");
    if (!content.starts_with(record + "\n")) {
      throw Error(path_for_message(path_) +
                  ": not this run's manifest (its first line is not this run's settings "
                  "record; refusing to touch it: use another --out)");
    }
    size_t start = record.size() + 1;
    while (start < content.size()) {
      const size_t end = content.find('\n', start);
      if (end == std::string::npos) {
        progress.report(path_for_message(path_) + ": dropped an incomplete last line (an interrupted run)");
        if (ftruncate(fd_, off_t(start)) != 0) {
          throw Error(path_for_message(path_) + ": cannot truncate (" + std::strerror(errno) + ")");
        }
        break;
      }
      const nlohmann::json entry = nlohmann::json::parse(content.substr(start, end - start), nullptr, false);
      if (!entry.is_object() || !entry.contains("output") || !entry["output"].is_string()) {
        throw Error(path_for_message(path_) + ": unreadable line (not written by fishcam?)");
      }
      listed_.insert(entry["output"].get<std::string>());
      start = end + 1;
    }
  }

  fs::path path_;
  int fd_ = -1;
  std::set<std::string> listed_;
  off_t last_start_ = -1;
  std::string last_output_;
};

struct DatasetOptions {
  std::string root, out, presets = "train", depth = "source-sphere", shard, method = "viewpoint", sampling = "grid";
  std::uint64_t seed = 0;
  int copies = 1, threads = 0, label_fill = 0;
  bool force = false;
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
  if (!fs::is_directory(images_dir))
    throw Error(path_for_message(images_dir) + ": missing (expected WoodScape layout)");
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
      : o_(o),
        root_(o.root),
        out_(o.out),
        prior_(depth_prior(o.depth, "--depth")),
        sampling_(*parse_sampling(o.sampling)),
        affine_(o.method == "affine") {}

  void run() {
    const Shard shard = parse_shard(o_.shard);
    if (o_.out.empty()) throw Error("--out: expected a folder, got ''");
    check_output_not_input(out_, {root_}, true);
    std::vector<PosePreset> presets;
    for (const std::string& name : distinct_names(o_.presets, "--preset"))
      presets.push_back(pose_preset(name, "--preset"));
    if (o_.threads > 0) cv::setNumThreads(o_.threads);
    const std::vector<fs::path> images = list_images(root_, shard);
    if (images.empty()) {
      std::printf("shard %d/%d: no images (the dataset has fewer than %d)\n", shard.index, shard.count,
                  shard.index + 1);
      return;
    }
    // Before anything is written: the folder's settings are this run's, and no file
    // this run would write is one it did not write before (unless --force).
    const OutputSettings settings = settings_of(presets);
    check_output_folders(presets);
    claim_output_settings(settings_path(), settings, false);
    check_foreign_files(presets, images, settings.record(), shard.manifest_name());
    fs::create_directories(out_);
    claim_output_settings(settings_path(), settings, true);
    Progress progress(images.size() * presets.size());
    std::vector<PresetOutput> outputs = prepare_outputs(presets, shard, settings.record(), progress);
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
  fs::path settings_path() const { return out_ / "augment-dataset.json"; }
  fs::path preset_dir(const PosePreset& preset, std::size_t presets) const {
    return presets > 1 ? out_ / std::string(preset.name) : out_;
  }

  // Everything the outputs depend on (not --shard or --threads: the N shards of a
  // run equal the unsharded run, and so do runs on any number of threads).
  OutputSettings settings_of(const std::vector<PosePreset>& presets) const {
    // Sorted: the outputs do not depend on the order the presets are given in.
    std::vector<std::string> names;
    for (const PosePreset& preset : presets) names.emplace_back(preset.name);
    std::sort(names.begin(), names.end());
    std::string preset_names;
    for (const std::string& name : names) preset_names += (preset_names.empty() ? "" : ",") + name;
    return {kCommand,
            {{"ROOT", fs::weakly_canonical(fs::absolute(root_)).string()},
             {"--preset", preset_names},
             {"--seed", std::to_string(o_.seed)},
             {"--copies", std::to_string(o_.copies)},
             {"--method", o_.method},
             {"--depth", affine_ ? "" : o_.depth},
             {"--sampling", affine_ ? "" : o_.sampling},
             {"--label-fill", std::to_string(o_.label_fill)}}};
  }

  // The files an output of one image copy lands in (no camera file for affine copies).
  std::vector<fs::path> copy_files(const fs::path& dir, const std::string& name, const fs::path& image_path) const {
    std::vector<fs::path> files{dir / "rgb_images" / (name + image_path.extension().string()),
                                dir / "semantic_annotations" / "gtLabels" / (name + ".png")};
    if (!affine_) files.push_back(dir / "calibration" / (name + ".json"));
    return files;
  }
  static std::string copy_name(const fs::path& image_path, const PosePreset& preset, int copy) {
    return image_path.stem().string() + "_" + std::string(preset.name) + std::to_string(copy);
  }

  // Refuses, before anything is written, to replace a file that no manifest of this
  // run's settings lists (the user's, or another command's) unless --force.
  void check_foreign_files(const std::vector<PosePreset>& presets, const std::vector<fs::path>& images,
                           const std::string& record, const std::string& own_manifest) {
    std::size_t foreign = 0;
    fs::path first;
    for (const PosePreset& preset : presets) {
      const fs::path dir = preset_dir(preset, presets.size());
      std::error_code ec;
      if (!fs::is_directory(dir, ec)) continue;
      check_own_manifest(dir / own_manifest, record);
      std::set<std::string> listed;
      for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        if (name.starts_with("manifest") && name.ends_with(".jsonl"))
          listed.merge(listed_outputs(entry.path(), record));
      }
      listed_before_[dir] = listed;
      for (const fs::path& image_path : images) {
        for (int copy = 0; copy < o_.copies; ++copy) {
          const std::vector<fs::path> files = copy_files(dir, copy_name(image_path, preset, copy), image_path);
          if (listed.count(fs::relative(files[0], dir).string())) continue;
          for (const fs::path& file : files) {
            if (!fs::exists(fs::symlink_status(file, ec))) continue;
            if (foreign++ == 0) first = file;
          }
        }
      }
    }
    if (foreign > 0 && !o_.force) {
      throw Error(path_for_message(first) + ": exists and no manifest of this run lists it (" +
                  std::to_string(foreign) +
                  " such file(s) where this run would write: not written by augment-dataset with these settings); "
                  "nothing written (--force replaces them)");
    }
  }

  // The manifest this run will append to, before anything is written: unlocked (no
  // run is writing it), it must be empty or start with this run's settings record; a
  // file of someone else's (one line without its newline looks like an interrupted
  // run's) is refused, never truncated.
  static void check_own_manifest(const fs::path& path, const std::string& record) {
    const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return;  // not there yet (or not readable: the lock's open says why)
    const bool locked = flock(fd, LOCK_SH | LOCK_NB) != 0;
    close(fd);
    if (locked) {
      throw Error(path_for_message(path) +
                  ": another run is writing this manifest (wait for it; parallel runs into one --out need "
                  "--shard K/N each)");
    }
    const std::string content = read_bounded_file(path, kMaxManifestBytes, "a manifest");
    if (!content.empty() && !content.starts_with(record + "\n")) {
      throw manifest_refusal(path, content.substr(0, content.find('\n')));
    }
  }

  // Every output folder is checked (symlinks inside --out included) before any is
  // created or anything read or written there.
  void check_output_folders(const std::vector<PosePreset>& presets) const {
    for (const PosePreset& preset : presets) {
      for (const char* sub :
           {"", "rgb_images", "semantic_annotations", "semantic_annotations/gtLabels", "calibration"}) {
        check_output_not_input(preset_dir(preset, presets.size()) / sub, {root_}, true);
      }
    }
  }

  // Every output folder created, cleared of killed runs' temporaries, and its manifest locked.
  std::vector<PresetOutput> prepare_outputs(const std::vector<PosePreset>& presets, const Shard& shard,
                                            const std::string& record, Progress& progress) const {
    std::vector<PresetOutput> outputs;
    for (const PosePreset& preset : presets) outputs.push_back({preset, preset_dir(preset, presets.size()), nullptr});
    for (PresetOutput& output : outputs) {
      for (const char* sub : {"rgb_images", "semantic_annotations/gtLabels", "calibration"}) {
        fs::create_directories(output.dir / sub);
        remove_stale_temporaries(output.dir / sub);  // of killed runs; parallel runs' stay
      }
      output.manifest = std::make_unique<Manifest>(output.dir / shard.manifest_name(), record, progress);
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
    DatasetImage source{image_path,
                        root_ / "semantic_annotations" / "gtLabels" / (stem + ".png"),
                        root_ / "calibration" / (stem + ".json"),
                        std::nullopt,
                        nullptr,
                        {},
                        {}};
    const std::string preset_name(output.preset.name);
    for (int copy = 0; copy < o_.copies; ++copy) {
      const std::vector<fs::path> files =
          copy_files(output.dir, copy_name(image_path, output.preset, copy), image_path);
      const std::uint64_t seed = derive_seed(o_.seed, stem + "/" + preset_name, copy);
      const ViewpointChange pose = applied_under(random_change(output.preset, seed), prior_);
      const AffineChange affine_change = affine_ ? random_affine(affine_preset(preset_name), seed) : AffineChange{};
      const std::string listed = fs::relative(files[0], output.dir).string();
      // Its own manifest's, or another run's of the same settings (the unsharded run
      // before this shard, another shard count).
      const bool ours = output.manifest->lists(listed) || listed_before_[output.dir].count(listed) != 0;
      if (ours && std::all_of(files.begin(), files.end(), [](const fs::path& f) { return fs::exists(f); })) {
        ++skipped_;
        continue;
      }
      source.load(warps_);
      std::vector<std::pair<fs::path, std::string>> contents = render_copy(source, pose, affine_change, files);
      // Listed before its files land: a kill in between leaves a listed output whose
      // files the next run writes, never a file of ours that no manifest lists.
      if (!ours)
        output.manifest->append(manifest_line(image_path, listed, copy, output.preset, seed, pose, affine_change));
      // The files land together (a killed run leaves none of them); they replace only
      // files this run's manifest lists, or any with --force.
      try {
        write_files_atomically(contents, ours || o_.force);
      } catch (const Error&) {
        if (!ours) output.manifest->withdraw_last();
        throw;
      }
      ++written_;
    }
  }

  std::vector<std::pair<fs::path, std::string>> render_copy(const DatasetImage& source, const ViewpointChange& pose,
                                                            const AffineChange& affine_change,
                                                            const std::vector<fs::path>& files) const {
    cv::Mat out_pixels, out_labels;
    const AugmentIO io{&source.image, &out_pixels, 0, &source.labels, &out_labels, o_.label_fill, nullptr};
    if (affine_) {
      affine_augment(affine_change, cv::Size(source.camera->width(), source.camera->height()), io);
    } else {
      source.warp->augment(pose.motion(), prior_, io, sampling_);
    }
    std::vector<std::pair<fs::path, std::string>> contents{{files[0], encode_image(files[0], out_pixels)},
                                                           {files[1], encode_image(files[1], out_labels)}};
    if (!affine_) {
      // The output camera: same intrinsics, the moved pose (translation in
      // unit-sphere units, written as metres).
      contents.emplace_back(files[2], format_camera(augmented_camera(source.camera->parameters(), pose.motion()),
                                                    CameraFormat::woodscape));
    }
    return contents;
  }

  nlohmann::json manifest_line(const fs::path& image_path, const std::string& output, int copy,
                               const PosePreset& preset, std::uint64_t seed, const ViewpointChange& pose,
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
  std::map<fs::path, std::set<std::string>> listed_before_;  // per output folder: what its manifests listed
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
  cmd->add_option("--copies", o->copies, "Augmented copies per image")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("-j,--threads", o->threads, "Threads (0: all cores)")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  cmd->add_option("--depth", o->depth, "Depth prior")->check(CLI::IsMember(depth_prior_names()))->capture_default_str();
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
  cmd->add_flag("--force", o->force,
                "Replace files in --out that no manifest of a run with these settings lists (without it they are "
                "refused before anything is written)");
  cmd->add_option("--shard", o->shard,
                  "K/N: only images K, K+N, K+2N, ... (in name order, K in [0, N)), manifest-K-of-N.jsonl; the N "
                  "shards together equal one unsharded run");
  cmd->callback([o] { DatasetAugmentation(*o).run(); });
}

}  // namespace fishcam::cli
