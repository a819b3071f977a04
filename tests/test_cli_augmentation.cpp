// The augmentation subcommands end to end: render, map, augment, augment-dataset,
// check-mrcal, demo, bench augment.
#include <opencv2/imgcodecs.hpp>

#include <nlohmann/json.hpp>

#include <cstring>
#include <map>
#include <set>
#include <sstream>

#include "fishcam/augment/scene.hpp"
#include "fishcam/io/npy.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

using test::run_fishcam;

using test::quoted;

std::string data(const char* name) { return quoted(test::data_path(name)); }

// A seeded street with its range: the .npy holds the library's render, bit for bit;
// outputs are checked before anything is drawn.
TEST(CliAugmentation, RenderSeededStreetWithDepth) {
  const auto dir = test::scratch_dir("cli_render_seeded");
  const std::string base = "render " + data("equidistant.json") + " --mount " + data("woodscape_front.json") +
                           " --scene-seed 17 --out-image " + quoted(dir / "s.png") + " --out-label " +
                           quoted(dir / "l.png");
  auto r = run_fishcam(base + " --out-depth " + quoted(dir / "d.npy") + " --supersampling 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Camera camera = read_camera(test::data_path("equidistant.json"));
  const SceneRender expected = StreetScene::generate(17).render(
      camera, *read_camera(test::data_path("woodscape_front.json")).parameters().pose, 1);
  const NpyArray depth = read_npy(dir / "d.npy");
  ASSERT_EQ(depth.shape, (std::vector<size_t>{size_t(camera.height()), size_t(camera.width())}));
  EXPECT_EQ(std::memcmp(depth.data.data(), expected.range.data, depth.data.size() * sizeof(float)), 0);
  const cv::Mat labels = cv::imread((dir / "l.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(cv::norm(labels, expected.labels, cv::NORM_INF), 0);
  // Refused, nothing written: a depth file that is not .npy, a supersampling out of range.
  for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
           {" --out-depth " + quoted(dir / "d2.png") + " --force", "is written as .npy"},
           {" --out-depth " + quoted(dir / "d3.npy") + " --supersampling 5 --force", "--supersampling"}}) {
    r = run_fishcam(base + args);
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "d2.png"));
  EXPECT_FALSE(std::filesystem::exists(dir / "d3.npy"));
}

// The surround-view dataset: splits by scene, true viewpoint test sets with their
// changes, the same bytes for the same seed; and the fidelity of the augmentation
// on it: exact for rotations under every prior, and the depth map exact with translations.
TEST(CliAugmentation, SurroundViewDatasetAndFidelity) {
  const auto dir = test::scratch_dir("cli_surround_view");
  const std::string args =
      " --scenes 3 --size 200x151 --seed 9 --depth --splits 0.34,0,0.66 --test-sets small "
      "--supersampling 1";
  auto r = run_fishcam("sample-dataset " + quoted(dir / "a") + args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_fishcam("sample-dataset " + quoted(dir / "b") + args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto count = [](const std::filesystem::path& folder) {
    return std::distance(std::filesystem::directory_iterator(folder), std::filesystem::directory_iterator{});
  };
  EXPECT_EQ(count(dir / "a" / "train" / "rgb_images"), 4);  // 1 scene x FV, MVL, MVR, RV
  EXPECT_EQ(count(dir / "a" / "val" / "rgb_images"), 0);
  EXPECT_EQ(count(dir / "a" / "test" / "rgb_images"), 8);
  EXPECT_EQ(count(dir / "a" / "test" / "depth"), 8);
  EXPECT_EQ(count(dir / "a" / "test-small" / "rgb_images"), 8);
  EXPECT_EQ(count(dir / "a" / "test-small-rotation" / "calibration"), 8);
  EXPECT_EQ(count(dir / "a" / "test-small-paper" / "rgb_images"), 8);
  // The paper's protocol: each original test image augmented by its recorded change,
  // byte for byte what fishcam augment (augment-dataset's warp) writes from the files.
  {
    std::istringstream paper(test::read_file(dir / "a" / "test-small-paper" / "changes.jsonl"));
    std::string line;
    ASSERT_TRUE(std::getline(paper, line));
    const auto change = nlohmann::json::parse(line);
    const std::string name = change.at("name");
    const auto numbers = [&](const char* key) {
      const auto v = change.at(key);
      return v[0].dump() + "," + v[1].dump() + "," + v[2].dump();
    };
    const auto test = dir / "a" / "test";
    r = run_fishcam("augment " + quoted(test / "calibration" / (name + ".json")) + " --image " +
                    quoted(test / "rgb_images" / (name + ".png")) + " --label " +
                    quoted(test / "semantic_annotations" / "gtLabels" / (name + ".png")) + " --out-image " +
                    quoted(dir / "paper.png") + " --out-label " + quoted(dir / "paper-labels.png") + " --rotate " +
                    numbers("rotation_deg") + " --translate " + numbers("translation") +
                    " --depth source-sphere --sampling grid --label-fill 0");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto set = dir / "a" / "test-small-paper";
    EXPECT_TRUE(test::read_file(dir / "paper.png") == test::read_file(set / "rgb_images" / (name + ".png")));
    EXPECT_TRUE(test::read_file(dir / "paper-labels.png") ==
                test::read_file(set / "semantic_annotations" / "gtLabels" / (name + ".png")));
    EXPECT_EQ(test::read_file(set / "changes.jsonl"), test::read_file(dir / "a" / "test-small" / "changes.jsonl"));
  }
  for (const char* file :
       {"scenes.jsonl", "test-small/changes.jsonl", "test/rgb_images/00002_MVR.png", "test-small/depth/00001_RV.npy"}) {
    EXPECT_EQ(test::read_file(dir / "a" / file), test::read_file(dir / "b" / file)) << file;
  }
  std::istringstream changes(test::read_file(dir / "a" / "test-small-rotation" / "changes.jsonl"));
  int lines = 0;
  for (std::string line; std::getline(changes, line); ++lines) {
    const auto t = nlohmann::json::parse(line).at("translation").get<std::vector<double>>();
    EXPECT_EQ(t, std::vector<double>(3, 0.0)) << line;
  }
  EXPECT_EQ(lines, 8);
  // Samples are never replaced: the same settings resume, writing nothing.
  const auto sample = dir / "a" / "test" / "rgb_images" / "00002_MVR.png";
  ASSERT_TRUE(std::filesystem::exists(sample));
  const auto written = std::filesystem::last_write_time(sample);
  r = run_fishcam("sample-dataset " + quoted(dir / "a") + args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(std::filesystem::last_write_time(sample), written);
  // Fidelity: 2 sets x (3 priors + the depth map).
  r = run_fishcam("fidelity " + quoted(dir / "a") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = nlohmann::json::parse(r.out).at("rows");
  ASSERT_EQ(rows.size(), 8u) << r.out;
  for (const auto& row : rows) {
    EXPECT_EQ(row.at("samples").get<int>(), 8);
    const double agreement = row.at("label_agreement").get<double>();
    const bool exact = row.at("test_set") == "test-small-rotation" || row.at("prior") == "map";
    if (exact) {
      EXPECT_GE(agreement, 0.99) << row.dump();
    }
    EXPECT_TRUE(std::isfinite(row.at("psnr_db").get<double>())) << row.dump();
  }
  r = run_fishcam("fidelity " + quoted(dir / "a" / "train"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("no test/ folder"), std::string::npos) << r.err;

  // Table 5 by geometry: 2 sets x 3 models. The camera's own model is the truth on
  // rotations; the paper's equidistant fit of a WoodScape lens moves pixels, most
  // beyond 90 degrees, and agrees less.
  r = run_fishcam("fidelity " + quoted(dir / "a") + " --models own,equidistant:paper,kannala-brandt --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto by_model = nlohmann::json::parse(r.out).at("rows");
  ASSERT_EQ(by_model.size(), 6u) << r.out;
  std::map<std::pair<std::string, std::string>, nlohmann::json> row_of;
  for (const auto& row : by_model) {
    EXPECT_EQ(row.at("samples").get<int>(), 8);
    row_of[{row.at("test_set").get<std::string>(), row.at("model").get<std::string>()}] = row;
  }
  const auto own = row_of[{"test-small-rotation", "own"}], paper = row_of[{"test-small-rotation", "equidistant:paper"}],
             kb = row_of[{"test-small-rotation", "kannala-brandt"}];
  EXPECT_EQ(own.at("how"), "the camera itself");
  EXPECT_EQ(paper.at("how"), "the paper's eqs. 13-14");
  EXPECT_EQ(kb.at("how"), "least-squares fit");
  EXPECT_GE(own.at("label_agreement").get<double>(), 0.99) << own.dump();
  EXPECT_EQ(own.at("endpoint_px").get<double>(), 0.0) << own.dump();
  EXPECT_LT(paper.at("label_agreement").get<double>(), own.at("label_agreement").get<double>()) << paper.dump();
  EXPECT_GT(paper.at("endpoint_px").get<double>(), 1.0) << paper.dump();
  EXPECT_LT(kb.at("endpoint_px").get<double>(), paper.at("endpoint_px").get<double>()) << kb.dump();
  const auto bands = paper.at("endpoint_by_angle_px");
  ASSERT_EQ(bands.size(), 4u);
  for (int b = 0; b < 3; ++b) {  // beyond 90 degrees, where the fit and the lens part most
    EXPECT_GT(bands[3].get<double>(), bands[b].get<double>()) << paper.dump();
  }
  for (const auto& [args, expected] : std::vector<std::pair<std::string, std::string>>{
           {" --models own,own", "--models: 'own' is given twice"},
           {" --models ''", "--models: expected one or more names"},
           {" --models kannala-brandt:paper", "kannala-brandt has no closed form in the paper"},
           {" --models fisheye", "models: 'fisheye': not 'own' or a model"},
           {" --depth infinity", "--depth: used by the --models table only"}}) {
    r = run_fishcam("fidelity " + quoted(dir / "a") + args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_NE(r.err.find(expected), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

// The prior at infinity sees rotations only: augment's record and augment-dataset's
// manifest and calibration files drop the translation the image never got (as the
// Python transforms do), the image being the full change's.
TEST(CliAugmentation, DepthAtInfinityDropsTheTranslationEverywhere) {
  const auto dir = test::scratch_dir("cli_infinity");
  auto r = run_fishcam("sample-dataset " + quoted(dir / "ds") + " --images 2 --seed 1 --size 96x73");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto image = dir / "ds" / "rgb_images" / "00000_FV.png";
  const auto camera = dir / "ds" / "calibration" / "00000_FV.json";
  const std::string augment = "augment " + quoted(camera) + " --image " + quoted(image) + " --preset large --seed 5";
  r = run_fishcam(augment + " --depth infinity --json --out-image " + quoted(dir / "infinity.png"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto infinity = nlohmann::json::parse(r.out);
  EXPECT_EQ(infinity.at("translation"), nlohmann::json({0.0, 0.0, 0.0})) << r.out;
  r = run_fishcam(augment + " --depth source-sphere --json --out-image " + quoted(dir / "sphere.png"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto sphere = nlohmann::json::parse(r.out);
  EXPECT_NE(sphere.at("translation"), nlohmann::json({0.0, 0.0, 0.0})) << "the preset's change has a translation";
  EXPECT_EQ(infinity.at("rotation_deg"), sphere.at("rotation_deg"));
  r = run_fishcam("augment-dataset " + quoted(dir / "ds") + " --preset large --seed 5 --depth infinity --out " +
                  quoted(dir / "out"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream manifest(test::read_file(dir / "out" / "manifest.jsonl"));
  int lines = 0;
  for (std::string line; std::getline(manifest, line);) {
    const auto entry = nlohmann::json::parse(line);
    if (!entry.contains("translation")) continue;  // the settings record
    EXPECT_EQ(entry.at("translation"), nlohmann::json({0.0, 0.0, 0.0})) << line;
    ++lines;
  }
  EXPECT_EQ(lines, 2);
}

TEST(CliAugmentation, RenderAugmentAndMap) {
  const auto dir = test::scratch_dir("cli_augment");
  auto r = run_fishcam("render " + data("woodscape_front.json") + " --out-image " + quoted(dir / "render.png") +
                       " --out-label " + quoted(dir / "labels.png"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Refuses to overwrite without --force.
  r = run_fishcam("render " + data("woodscape_front.json") + " --out-image " + quoted(dir / "render.png") +
                  " --out-label " + quoted(dir / "labels.png"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("refusing to overwrite"), std::string::npos) << r.err;

  r = run_fishcam("augment " + data("woodscape_front.json") + " --image " + quoted(dir / "render.png") + " --label " +
                  quoted(dir / "labels.png") + " --out-image " + quoted(dir / "aug.png") + " --out-label " +
                  quoted(dir / "aug_labels.png") + " --out-mask " + quoted(dir / "mask.png") +
                  " --preset medium --seed 7 --label-fill 255");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("pose: rotation ["), std::string::npos) << r.out;
  const cv::Mat labels = cv::imread((dir / "aug_labels.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat mask = cv::imread((dir / "mask.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(labels.size(), cv::Size(1280, 966));
  EXPECT_EQ(cv::countNonZero((labels == 255) != (mask == 0)), 0) << "the fill marks exactly the invalid pixels";

  // The same seed gives the same pose.
  const auto again = run_fishcam("augment " + data("woodscape_front.json") + " --image " + quoted(dir / "render.png") +
                                 " --out-image " + quoted(dir / "aug2.png") + " --preset medium --seed 7");
  EXPECT_EQ(again.out, r.out);

  r = run_fishcam("map " + data("woodscape_front.json") + " --rotate 10,-5,3 --translate 0.1,0,0 --out " +
                  quoted(dir / "map.npy"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const NpyArray map = read_npy(dir / "map.npy");
  EXPECT_EQ(map.shape, (std::vector<size_t>{966, 1280, 2}));
  // numpy reads it too.
  const std::string check =
      "/usr/bin/python3 -c \"import numpy as np; m = np.load('" + (dir / "map.npy").string() +
      "'); assert m.dtype == np.float32 and m.shape == (966, 1280, 2); print(np.isnan(m).sum())\"";
  EXPECT_EQ(std::system(check.c_str()), 0);
}

TEST(CliAugmentation, BadArguments) {
  const auto dir = test::scratch_dir("cli_augment_bad");
  const struct {
    std::string args, expected;
  } cases[] = {
      {"augment " + data("woodscape_front.json") + " --image /no/such.png --out-image " + quoted(dir / "o.png"),
       "/no/such.png: no such file"},
      {"augment " + data("woodscape_front.json") + " --image " + data("woodscape_front.json") + " --out-image " +
           quoted(dir / "o.png"),
       "cannot read image"},
      {"augment " + data("woodscape_front.json") + " --image x.png --out-image o.png --preset huge --seed 1",
       "--preset"},
      {"augment " + data("woodscape_front.json") + " --image x.png --out-image o.png --preset small", "--seed"},
      {"augment " + data("woodscape_front.json") +
           " --image x.png --out-image o.png --preset small --seed 1 --rotate "
           "1,2,3",
       "excludes"},
      {"map " + data("woodscape_front.json") + " --rotate 1,2 --out " + quoted(dir / "m.npy"), "--rotate"},
      {"map " + data("woodscape_front.json") + " --depth sideways --out " + quoted(dir / "m.npy"), "--depth"},
      {"render " + data("equidistant.json") + " --out-image " + quoted(dir / "a.png") + " --out-label " +
           quoted(dir / "b.png"),
       "has no pose"},
      {"check-mrcal " + data("woodscape_front.json") + " --rotate 1,2,3", "mrcal-representable"},
      {"augment-dataset /no/such/root --preset small --seed 1 --out " + quoted(dir / "x"), "ROOT"},
  };
  for (const auto& c : cases) {
    const auto r = run_fishcam(c.args);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << " -> " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << " -> " << r.err;
  }
}

TEST(CliAugmentation, CheckMrcal) {
  const auto r = run_fishcam("check-mrcal " + data("stereographic.cameramodel") + " --target " +
                             data("pinhole.cameramodel") + " --rotate 10,-20,5 --translate 0.1,0.2,-0.1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto pos = r.out.find("max difference ");
  ASSERT_NE(pos, std::string::npos) << r.out;
  EXPECT_LT(std::stod(r.out.substr(pos + 15)), 1e-3) << r.out;
}

TEST(CliAugmentation, DatasetIsMirroredResumableAndReportsBadFiles) {
  const auto root = test::scratch_dir("dataset_root"), out = test::scratch_dir("dataset_out") / "sets";
  // Small images: the test is about the files, not the pixels (those are the library tests').
  auto r = run_fishcam("sample-dataset " + quoted(root) + " --images 2 --seed 3 --size 160x121");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // A third image whose calibration is broken, a fourth without labels.
  std::filesystem::copy_file(root / "rgb_images/00000_FV.png", root / "rgb_images/broken.png");
  test::write_file(root / "calibration/broken.json", "{\"intrinsic\": {");
  std::filesystem::copy_file(root / "rgb_images/00000_FV.png", root / "rgb_images/unlabelled.png");
  std::filesystem::copy_file(root / "calibration/00000_FV.json", root / "calibration/unlabelled.json");

  const std::string command = "augment-dataset " + quoted(root) +
                              " --preset small,medium,large --seed 5 --copies 2 "
                              "-j 2 --out " +
                              quoted(out);
  r = run_fishcam(command);
  EXPECT_NE(r.exit_code, 0) << "failures make the exit code non-zero";
  EXPECT_NE(r.err.find("broken"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("unlabelled"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("12 written"), std::string::npos) << r.out;
  for (const char* preset : {"small", "medium", "large"}) {
    const auto dir = out / preset;
    for (int i = 0; i < 2; ++i) {
      for (int copy = 0; copy < 2; ++copy) {
        const std::string name = "0000" + std::to_string(i) + "_FV_" + preset + std::to_string(copy);
        EXPECT_TRUE(std::filesystem::exists(dir / "rgb_images" / (name + ".png"))) << name;
        EXPECT_TRUE(std::filesystem::exists(dir / "semantic_annotations/gtLabels" / (name + ".png"))) << name;
        EXPECT_NO_THROW(read_camera(dir / "calibration" / (name + ".json"))) << name;
      }
    }
    const std::string manifest = test::read_file(dir / "manifest.jsonl");
    EXPECT_EQ(std::count(manifest.begin(), manifest.end(), '\n'), 5);  // the settings record, then 4 outputs
    const auto record = nlohmann::json::parse(manifest.substr(0, manifest.find('\n')));
    EXPECT_EQ(record["fishcam"], "augment-dataset");
    EXPECT_EQ(record["settings"]["--seed"], "5");
    const size_t second = manifest.find('\n') + 1;
    const auto first = nlohmann::json::parse(manifest.substr(second, manifest.find('\n', second) - second));
    for (const char* key : {"image", "copy", "seed", "rotation_deg", "translation", "depth"}) {
      EXPECT_TRUE(first.contains(key)) << key;
    }
  }
  // The dataset is untouched.
  EXPECT_FALSE(std::filesystem::exists(root / "manifest.jsonl"));
  // Resuming: nothing new is written, the manifest does not grow.
  const auto before = std::filesystem::last_write_time(out / "small/rgb_images/00000_FV_small0.png");
  r = run_fishcam(command);
  EXPECT_NE(r.out.find("0 written, 12 already there"), std::string::npos) << r.out;
  EXPECT_EQ(std::filesystem::last_write_time(out / "small/rgb_images/00000_FV_small0.png"), before);
  const std::string manifest = test::read_file(out / "small/manifest.jsonl");
  EXPECT_EQ(std::count(manifest.begin(), manifest.end(), '\n'), 5);
  // Never inside ROOT.
  r = run_fishcam("augment-dataset " + quoted(root) + " --preset small --seed 1 --out " + quoted(root / "augmented"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("lies inside the input"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(root / "augmented"));
}

TEST(CliAugmentation, DemoAndBench) {
  const auto dir = test::scratch_dir("demo");
  auto r = run_fishcam("demo --out " + quoted(dir));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* name : {"demo-fig5.png", "demo-presets.png", "demo-render.png", "demo-render-labels.png"}) {
    EXPECT_FALSE(cv::imread((dir / name).string()).empty()) << name;
    EXPECT_NE(r.out.find(name), std::string::npos) << r.out;
  }
  r = run_fishcam("bench augment --json --samples 2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"total_ms", "map_ms", "remap_only_ms", "threads"}) EXPECT_TRUE(j.contains(key)) << key;
}

}  // namespace
}  // namespace fishcam

namespace fishcam {
namespace {

std::set<std::string> lines(const std::string& text) {
  std::set<std::string> out;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);) out.insert(line);
  return out;
}

// sample-dataset makes a WoodScape-layout set; 3 shards of augment-dataset
// together give exactly the unsharded run's files and manifest lines.
TEST(CliAugmentation, ShardsTogetherEqualOneRun) {
  const auto dir = test::scratch_dir("shards");
  auto r = run_fishcam("sample-dataset " + quoted(dir / "root") + " --images 7 --seed 3 --size 160x121");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto samples = test::files_below(dir / "root");
  EXPECT_EQ(samples.size(), 22u);  // 7 x (image, labels, camera) and the settings record
  r = run_fishcam("sample-dataset " + quoted(dir / "root") + " --images 7 --seed 3 --size 160x121");
  EXPECT_EQ(r.exit_code, 0) << "the same settings resume: " << r.err;
  EXPECT_TRUE(test::files_below(dir / "root") == samples) << "never replaces samples";

  const std::string common = "augment-dataset " + quoted(dir / "root") + " --preset small --seed 9 --copies 2";
  r = run_fishcam(common + " --out " + quoted(dir / "whole"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (int k = 0; k < 3; ++k) {
    r = run_fishcam(common + " --shard " + std::to_string(k) + "/3 --out " + quoted(dir / "sharded"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  auto whole = test::files_below(dir / "whole"), sharded = test::files_below(dir / "sharded");
  const std::set<std::string> whole_lines = lines(whole["manifest.jsonl"]);
  std::set<std::string> shard_lines;
  for (int k = 0; k < 3; ++k) {
    const std::string name = "manifest-" + std::to_string(k) + "-of-3.jsonl";
    ASSERT_TRUE(sharded.count(name)) << name;
    for (const auto& line : lines(sharded[name])) {
      // Each manifest starts with the run's settings record, the same in all.
      if (line.starts_with("{\"fishcam\":")) {
        EXPECT_TRUE(whole_lines.count(line)) << line;
        continue;
      }
      EXPECT_TRUE(shard_lines.insert(line).second) << "twice: " << line;
    }
    sharded.erase(name);
  }
  whole.erase("manifest.jsonl");
  EXPECT_EQ(whole_lines.size(), 15u);
  std::set<std::string> whole_outputs = whole_lines;
  std::erase_if(whole_outputs, [](const std::string& line) { return line.starts_with("{\"fishcam\":"); });
  EXPECT_TRUE(shard_lines == whole_outputs);
  EXPECT_TRUE(sharded == whole) << "the shards' files differ from the unsharded run's";

  for (const char* bad : {"3/3", "-1/3", "1/0", "a/b", "1/3/4"}) {
    r = run_fishcam(common + " --shard " + bad + " --out " + quoted(dir / "bad"));
    EXPECT_NE(r.exit_code, 0) << bad;
  }
}

// The affine baseline through augment-dataset: images and labels only (no camera
// model describes the result), the method in the manifest, no mixing of methods.
TEST(CliAugmentation, AffineDatasetAndOptions) {
  const auto dir = test::scratch_dir("affine_dataset");
  auto r = run_fishcam("sample-dataset " + quoted(dir / "root") + " --images 2 --seed 1 --size 160x121");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string common = "augment-dataset " + quoted(dir / "root") + " --preset train --seed 4 --out ";
  r = run_fishcam(common + quoted(dir / "affine") + " --method affine");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto files = test::files_below(dir / "affine");
  EXPECT_EQ(files.size(), 6u);  // 2 images, 2 labels, the manifest, the settings record
  for (const auto& line : lines(files.at("manifest.jsonl"))) {
    const auto j = nlohmann::json::parse(line);
    if (j.contains("settings")) continue;
    EXPECT_EQ(j["method"], "affine");
    EXPECT_TRUE(j.contains("scale") && j["translation"].size() == 2) << line;
  }
  r = run_fishcam(common + quoted(dir / "affine"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--method: this folder was written with 'affine', this run has 'viewpoint'"), std::string::npos)
      << r.err;
  r = run_fishcam(common + quoted(dir / "viewpoint"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string viewpoint_manifest = test::read_file(dir / "viewpoint/manifest.jsonl");
  EXPECT_NE(viewpoint_manifest.find("\"method\":\"viewpoint\""), std::string::npos);
  EXPECT_NE(viewpoint_manifest.find("\"sampling\":\"grid\""), std::string::npos);
  r = run_fishcam(common + quoted(dir / "exact") + " --sampling exact");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(test::read_file(dir / "exact/manifest.jsonl").find("\"sampling\":\"exact\""), std::string::npos);

  const std::string image =
      quoted(dir / "root/rgb_images/" / test::files_below(dir / "root/rgb_images").begin()->first);
  const std::string camera =
      quoted(dir / "root/calibration/" / test::files_below(dir / "root/calibration").begin()->first);
  const std::string augment = "augment " + camera + " --image " + image + " --out-image " + quoted(dir / "a.png");
  for (const auto& [args, expected] : std::vector<std::pair<std::string, std::string>>{
           {" --affine 1,0,0,1", "--affine needs --method affine"},
           {" --method affine --rotate 1,0,0", "--rotate: not used by --method affine"},
           {" --method affine --sampling exact", "--sampling: not used by --method affine"},
           {" --sampling nearest", "--sampling"},
           {" --method affine --affine 1,0,0,0", "scale must be positive"},
           {" --method affine --affine 1,0,0", "--affine"},
           {" --method shear", "--method"},
       }) {
    r = run_fishcam(augment + args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_NE(r.err.find(expected), std::string::npos) << args << " -> " << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "a.png")) << args;
  }
}

// A run killed while writing its manifest leaves a cut last line: the next run
// drops it (and says so) and completes the manifest (temporaries of killed runs:
// test_cli_outputs.cpp).
TEST(CliAugmentation, ResumeAfterACutManifestLine) {
  const auto dir = test::scratch_dir("cut_manifest");
  ASSERT_EQ(run_fishcam("sample-dataset " + quoted(dir / "root") + " --images 2 --seed 1 --size 160x121").exit_code, 0);
  const std::string command =
      "augment-dataset " + quoted(dir / "root") + " --preset small --seed 2 --out " + quoted(dir / "out");
  ASSERT_EQ(run_fishcam(command).exit_code, 0);
  const auto manifest_path = dir / "out" / "manifest.jsonl";
  const std::string full = test::read_file(manifest_path);
  // Killed while appending the last output's line: its files had not landed yet
  // (a line is appended before its files).
  test::write_file(manifest_path, full.substr(0, full.size() - 20));
  for (const char* file : {"rgb_images/00001_FV_small0.png", "semantic_annotations/gtLabels/00001_FV_small0.png",
                           "calibration/00001_FV_small0.json"}) {
    ASSERT_TRUE(std::filesystem::remove(dir / "out" / file)) << file;
  }
  const auto r = run_fishcam(command);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("dropped an incomplete last line"), std::string::npos) << r.err;
  EXPECT_EQ(test::read_file(manifest_path), full);
}

}  // namespace
}  // namespace fishcam
