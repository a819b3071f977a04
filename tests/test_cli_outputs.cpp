// Outputs against hostile file systems: a dataset or an input is never written,
// whatever symlinks, hard links or flags say; temporaries never follow links;
// parallel shards and concurrent runs into one --out lose and repeat nothing;
// names the manifest cannot hold are refused before anything is written.
#include <sys/wait.h>
#include <unistd.h>

#include <map>
#include <set>
#include <sstream>

#include "fishcam/io/atomic_file.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

namespace fs = std::filesystem;
using test::quoted;
using test::run_fishcam;

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

class CliOutputs : public test::CliTest {
 protected:
  std::string augment_dataset(const fs::path& root, const fs::path& out, const std::string& presets = "train,small") {
    return "augment-dataset " + quoted(root) + " --preset " + presets + " --seed 1 --out " + quoted(out);
  }
};

TEST_F(CliOutputs, TheDatasetIsNeverWrittenWhereverOutLies) {
  const auto root = dataset("ds");
  expect_refused(augment_dataset(root, dir_), "contains the input", dir_ / "ds");  // ROOT inside OUT
  expect_refused(augment_dataset(root, root), "is also an input", root);
  expect_refused(augment_dataset(root, root / "rgb_images" / "out"), "lies inside the input", root);
  // Through symlinks: a sub-folder of OUT, a preset folder of OUT, OUT itself.
  fs::create_directories(dir_ / "outB");
  fs::create_directory_symlink(root / "rgb_images", dir_ / "outB" / "rgb_images");
  expect_refused(augment_dataset(root, dir_ / "outB", "small"), "lies inside the input", root);
  fs::create_directories(dir_ / "outC");
  fs::create_directory_symlink(root, dir_ / "outC" / "train");
  expect_refused(augment_dataset(root, dir_ / "outC"), "is also an input", root);
  fs::create_directory_symlink(root, dir_ / "outD");
  expect_refused(augment_dataset(root, dir_ / "outD"), "is also an input", root);
  EXPECT_FALSE(fs::exists(dir_ / "outC" / "small"));  // nothing created before the refusal
}

TEST_F(CliOutputs, InputsAreNeverReplacedThroughLinksOrFolders) {
  const auto camera = dir_ / "m" / "front.json";
  fs::create_directories(camera.parent_path());
  fs::copy_file(test::data_path("woodscape_front.json"), camera);
  // compare: files named by --models are inputs; --out may not contain an input.
  expect_refused("compare " + quoted(test::data_path("woodscape_front.json")) + " --samples 1 --models " +
                     quoted(camera) + " --out " + quoted(dir_ / "m") + " --force",
                 "contains the input", dir_ / "m");
  // A symlink or a hard link to an input as an output, even with --force.
  fs::create_symlink(camera, dir_ / "link.json");
  fs::create_hard_link(camera, dir_ / "hard.json");
  for (const char* out : {"link.json", "hard.json"}) {
    expect_refused("convert " + quoted(camera) + " --to equidistant --out " + quoted(dir_ / out) + " --force",
                   "is also an input", dir_);
    expect_refused("map " + quoted(camera) + " --rotate 1,0,0 --out " + quoted(dir_ / out) + " --force",
                   "is also an input", dir_);
  }
}

// Every subcommand that writes files, given a symlink and a hard link of one of
// its inputs as an output (with --force): refused before anything is read or written.
TEST_F(CliOutputs, EverySubcommandRefusesLinksToItsInputsAsOutputs) {
  const auto input = dir_ / "input";
  fs::create_directories(input);
  fs::copy_file(test::data_path("woodscape_front.json"), input / "camera.json");
  test::write_file(input / "data.csv", "theta,rho\n0.1,34\n");
  test::write_file(input / "corners.vnl", "# filename x y level\n");
  test::write_file(input / "image.png", "not read");
  // {command with OUT for the output, the input it aliases}
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"render CAM --out-image OUT --out-label " + quoted(dir_ / "l.png"), "camera.json"},
      {"augment CAM --image IMG --out-image OUT --rotate 1,0,0", "image.png"},
      {"map CAM --rotate 1,0,0 --out OUT", "camera.json"},
      {"convert CAM --to equidistant --out OUT", "camera.json"},
      {"fit CSV --to equidistant --imagersize 1280,966 --center 640,480 --out OUT", "data.csv"},
      {"calibrate --corners VNL --board 10x10 --spacing 0.1 --imagersize 1280x966 --model equidistant --out OUT",
       "corners.vnl"},
      {"synth-corners CAM --boards 3 --noise 0 --seed 1 --out OUT", "camera.json"},
      {"detect-corners IMG --board 10x10 --out OUT", "image.png"},
  };
  const auto substitute = [&](std::string command, const fs::path& out) {
    for (const auto& [token, path] : std::vector<std::pair<std::string, fs::path>>{{"CAM", input / "camera.json"},
                                                                                   {"IMG", input / "image.png"},
                                                                                   {"CSV", input / "data.csv"},
                                                                                   {"VNL", input / "corners.vnl"},
                                                                                   {"OUT", out}}) {
      if (const size_t at = command.find(token); at != std::string::npos)
        command.replace(at, token.size(), quoted(path));
    }
    return command;
  };
  int refused = 0;
  for (const auto& [command, aliased] : commands) {
    for (const char* kind : {"symlink", "hardlink"}) {
      const auto out = dir_ / (std::string(kind) + fs::path(aliased).extension().string());
      fs::remove(out);
      if (kind == std::string("symlink")) {
        fs::create_symlink(input / aliased, out);
      } else {
        fs::create_hard_link(input / aliased, out);
      }
      expect_refused(substitute(command, out) + " --force", "is also an input", input);
      ++refused;
    }
  }
  EXPECT_EQ(refused, 16);
}

// An output that is a symlink is replaced (with --force), never written through;
// a leftover temporary-looking symlink is never opened.
TEST_F(CliOutputs, SymlinksAtOutputsAreReplacedNotFollowed) {
  const auto victim = test::write_file(dir_ / "victim.json", "keep me");
  fs::create_symlink(victim, dir_ / "out.json");
  fs::create_symlink(victim, dir_ / "out.json.fishcam-tmp");
  const auto r = run_fishcam("convert " + quoted(test::data_path("woodscape_front.json")) + " --to equidistant --out " +
                             quoted(dir_ / "out.json") + " --force");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(test::read_file(victim), "keep me");
  EXPECT_FALSE(fs::is_symlink(dir_ / "out.json"));
  EXPECT_NE(test::read_file(dir_ / "out.json").find("equidistant"), std::string::npos);
  // Without --force an existing symlink, even a dangling one, is not replaced.
  fs::create_symlink(dir_ / "nowhere.json", dir_ / "dangling.json");
  const auto refused = run_fishcam("convert " + quoted(test::data_path("woodscape_front.json")) +
                                   " --to equidistant --out " + quoted(dir_ / "dangling.json"));
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.err.find("already exists"), std::string::npos) << refused.err;
  EXPECT_FALSE(fs::exists(dir_ / "nowhere.json"));
}

TEST_F(CliOutputs, AFailedRenameNamesItsRealCause) {
  fs::create_directories(dir_ / "existing.json" / "inside");
  const auto r = run_fishcam("convert " + quoted(test::data_path("woodscape_front.json")) + " --to equidistant --out " +
                             quoted(dir_ / "existing.json") + " --force");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(r.err.find("Success"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("existing.json"), std::string::npos) << r.err;
  // No temporary left behind.
  for (const auto& entry : fs::directory_iterator(dir_)) {
    EXPECT_FALSE(is_temporary_name(entry.path().filename().string())) << entry.path();
  }
}

// Four shards in parallel into one --out, three times: the union equals one
// unsharded run, file for file and manifest line for manifest line.
TEST_F(CliOutputs, ParallelShardsIntoOneOutEqualOneRun) {
  const auto root = dataset("ds", 8);
  ASSERT_EQ(run_fishcam(augment_dataset(root, dir_ / "single")).exit_code, 0);
  const auto single = test::files_below(dir_ / "single");
  std::multiset<std::string> single_lines;
  for (const char* preset : {"train", "small"}) {
    for (const auto& line : lines_of(single.at(std::string(preset) + "/manifest.jsonl"))) {
      if (!line.starts_with("{\"fishcam\":")) single_lines.insert(line);  // each manifest's settings record
    }
  }
  for (int repetition = 0; repetition < 3; ++repetition) {
    const auto out = dir_ / ("sharded" + std::to_string(repetition));
    std::string command;
    for (int shard = 0; shard < 4; ++shard) {
      command += "'" + test::fishcam_binary() + "' " + augment_dataset(root, out) + " -j 1 --shard " +
                 std::to_string(shard) + "/4 > /dev/null 2> " + quoted(dir_ / ("err" + std::to_string(shard))) + " & ";
    }
    const int status = std::system(("bash -c \"" + command + "wait\"").c_str());
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    std::map<std::string, std::string> files;
    std::multiset<std::string> lines;
    for (const auto& [name, bytes] : test::files_below(out)) {
      if (name.find("manifest") != std::string::npos) {
        for (const auto& line : lines_of(bytes)) {
          if (!line.starts_with("{\"fishcam\":")) lines.insert(line);
        }
      } else {
        files[name] = bytes;
      }
    }
    std::map<std::string, std::string> expected = single;
    std::erase_if(expected, [](const auto& f) { return f.first.find("manifest") != std::string::npos; });
    EXPECT_TRUE(files == expected) << "repetition " << repetition << ": " << files.size() << " files, expected "
                                   << expected.size();
    EXPECT_TRUE(lines == single_lines) << "repetition " << repetition;
  }
}

// Two identical runs at once: the manifest is locked, so the second either waits
// its turn (a resume) or is refused in one line; never duplicate or lost lines.
TEST_F(CliOutputs, ConcurrentIdenticalRunsNeverDuplicateManifestLines) {
  const auto root = dataset("ds", 6);
  const auto out = dir_ / "out";
  std::string command;
  for (int run = 0; run < 2; ++run) {
    command += "'" + test::fishcam_binary() + "' " + augment_dataset(root, out) + " -j 1 > /dev/null 2> " +
               quoted(dir_ / ("err" + std::to_string(run))) + "; echo $? > " +
               quoted(dir_ / ("rc" + std::to_string(run))) + " & ";
  }
  ASSERT_EQ(std::system(("bash -c \"" + command + "wait\"").c_str()), 0);
  int succeeded = 0;
  for (int run = 0; run < 2; ++run) {
    const std::string rc = test::read_file(dir_ / ("rc" + std::to_string(run)));
    if (rc == "0\n") {
      ++succeeded;
    } else {
      EXPECT_NE(test::read_file(dir_ / ("err" + std::to_string(run))).find("another run is writing this manifest"),
                std::string::npos);
    }
  }
  EXPECT_GE(succeeded, 1);
  for (const char* preset : {"train", "small"}) {
    const auto lines = lines_of(test::read_file(out / preset / "manifest.jsonl"));
    EXPECT_EQ(lines.size(), 7u) << preset;  // the settings record and 6 outputs
    EXPECT_EQ(std::set<std::string>(lines.begin(), lines.end()).size(), lines.size()) << preset;
  }
}

// A temporary of a killed run (its process gone) is removed by the next run; one
// of a running process (this test) stays, and so does a file whose name only looks
// like a temporary (its random part not the 16 hex digits fishcam writes).
TEST_F(CliOutputs, OnlyTemporariesOfFinishedProcessesAreRemoved) {
  const auto root = dataset("ds");
  const pid_t child = fork();
  if (child == 0) _exit(0);
  ASSERT_GT(child, 0);
  waitpid(child, nullptr, 0);
  const auto images = dir_ / "out" / "rgb_images";
  fs::create_directories(images);
  const auto stale = test::write_file(temporary_path(images / "00000_FV_train0.png", child, 1), "half");
  const auto live = test::write_file(temporary_path(images / "00000_FV_train0.png", getpid(), 2), "in flight");
  std::string notes = temporary_path(images / "b.png", child, 1).string();
  notes.replace(notes.find("0000000000000001"), 16, "my-notes");
  test::write_file(notes, "keep me");
  const auto r =
      run_fishcam("augment-dataset " + quoted(root) + " --preset train --seed 1 --out " + quoted(dir_ / "out"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_EQ(test::read_file(live), "in flight");
  EXPECT_EQ(test::read_file(notes), "keep me");
}

// A file name the manifest (JSON, UTF-8) cannot hold is refused before anything
// is written for it; the others are done; a resume says the same and orphans nothing.
TEST_F(CliOutputs, NamesThatAreNotUtf8AreRefusedBeforeWriting) {
  const auto root = dataset("ds");
  const std::string bad = "lat\xe9n";
  fs::copy_file(root / "rgb_images" / "00000_FV.png", root / "rgb_images" / (bad + ".png"));
  fs::copy_file(root / "semantic_annotations" / "gtLabels" / "00000_FV.png",
                root / "semantic_annotations" / "gtLabels" / (bad + ".png"));
  fs::copy_file(root / "calibration" / "00000_FV.json", root / "calibration" / (bad + ".json"));
  for (int run = 0; run < 2; ++run) {
    const auto r =
        run_fishcam("augment-dataset " + quoted(root) + " --preset train --seed 1 --out " + quoted(dir_ / "out"));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.err.find("not valid UTF-8"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("lat\\xe9n"), std::string::npos) << r.err;  // escaped in the message
    for (const auto& [name, bytes] : test::files_below(dir_ / "out"))
      EXPECT_EQ(name.find(bad), std::string::npos) << name;
    EXPECT_EQ(lines_of(test::read_file(dir_ / "out" / "manifest.jsonl")).size(), 3u);  // the record, 2 outputs
  }
}

// The output does not depend on the CPU: an AVX2 machine and one without it
// (FISHCAM_NO_AVX2=1 selects the SSE2 kernel) write the same dataset byte for
// byte, so shards or resumes on mixed machines equal one run. Before, the fused
// multiply-adds of the AVX2 kernel changed 362 of 480 images.
TEST_F(CliOutputs, DatasetsAreTheSameOnEveryInstructionSet) {
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) GTEST_SKIP() << "no AVX2 here";
  const auto root = dir_ / "ds";
  ASSERT_EQ(run_fishcam("sample-dataset " + quoted(root) + " --images 6 --seed 4 --size 320x242").exit_code, 0);
  for (const char* sampling : {"grid", "exact"}) {
    std::map<std::string, std::string> runs[2];
    for (int baseline = 0; baseline < 2; ++baseline) {
      const auto out = dir_ / (std::string(sampling) + std::to_string(baseline));
      if (baseline) setenv("FISHCAM_NO_AVX2", "1", 1);
      const auto r = run_fishcam("augment-dataset " + quoted(root) +
                                 " --preset train,large --copies 4 --seed 9 "
                                 "--depth target-sphere --sampling " +
                                 sampling + " --out " + quoted(out));
      unsetenv("FISHCAM_NO_AVX2");
      ASSERT_EQ(r.exit_code, 0) << r.err;
      runs[baseline] = test::files_below(out);
    }
    EXPECT_EQ(runs[0].size(), 2u * 6 * 4 * 3 + 3);  // image, label, camera per copy; two manifests, the settings
    long differing = 0;
    for (const auto& [name, bytes] : runs[0]) differing += runs[1].count(name) == 0 || runs[1].at(name) != bytes;
    EXPECT_EQ(differing, 0) << sampling << ": files differing between the AVX2 and the SSE2 kernel";
  }
}

}  // namespace
}  // namespace fishcam
