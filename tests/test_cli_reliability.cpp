// What the reliability probe (issue 40) found, one regression test per failure:
// files in an output folder fishcam did not write are never replaced, resumes only
// into the same settings, lists without empty or repeated names, seeds within
// [0, 2^64), board sizes that explain the corners, and every input bounded (FIFOs,
// /dev/zero and oversized sparse files refused at once).
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <map>
#include <numbers>
#include <tuple>

#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/camera_io.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

namespace fs = std::filesystem;
using test::quoted;
using test::run_fishcam;

// test::write_file with its folders made first.
fs::path put(const fs::path& path, const std::string& content) {
  fs::create_directories(path.parent_path());
  return test::write_file(path, content);
}

class CliReliability : public test::CliTest {
 protected:
  CliReliability() : CliTest("reliability_") {}
};

// Probe 1: files already in --out that augment-dataset did not write stay as they
// are (refused before anything is written); --force replaces them.
TEST_F(CliReliability, AugmentDatasetNeverReplacesFilesItDidNotWrite) {
  const auto root = dataset("ds");
  const auto out = dir_ / "o";
  const auto mine = put(out / "rgb_images" / "00000_FV_small0.png", "mine\n");
  const auto theirs = put(out / "calibration" / "00001_FV_small0.json", "{}");
  const std::string command = "augment-dataset " + quoted(root) + " --preset small --seed 1 --out " + quoted(out);
  expect_refused(command, "no manifest of this run lists it (2 such file(s)", out);
  EXPECT_EQ(test::read_file(mine), "mine\n");
  EXPECT_EQ(test::read_file(theirs), "{}");
  const auto r = run_fishcam(command + " --force");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(test::read_file(mine), "mine\n");
  // Now they are its own: a resume writes nothing and refuses nothing.
  const auto again = run_fishcam(command);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.out.find("0 written, 2 already there"), std::string::npos) << again.out;
}

// Probe 2: a manifest fishcam did not write (one line, no final newline) is not taken
// for an interrupted run's: refused, byte for byte as it was.
TEST_F(CliReliability, AForeignManifestIsNeverTruncated) {
  const auto root = dataset("ds");
  const auto out = dir_ / "o";
  const auto manifest = put(out / "manifest.jsonl", "{\"output\": \"my notes\"}");
  expect_refused("augment-dataset " + quoted(root) + " --preset small --seed 1 --out " + quoted(out),
                 "not a manifest of fishcam augment-dataset", out);
  EXPECT_EQ(test::read_file(manifest), "{\"output\": \"my notes\"}");
  // An earlier fishcam's manifest (entries from the first line, no settings record) is
  // named as such, and kept as well.
  const std::string earlier =
      "{\"image\":\"a.png\",\"output\":\"a_small0\",\"copy\":0,\"preset\":\"small\",\"seed\":1}\n";
  put(manifest, earlier);
  expect_refused("augment-dataset " + quoted(root) + " --preset small --seed 1 --out " + quoted(out),
                 "written by an earlier fishcam, whose manifests have no settings record", out);
  EXPECT_EQ(test::read_file(manifest), earlier);
}

// Probes 3 and 5: every setting the outputs depend on, changed on a resume (with and
// without --shard), is refused naming it; the folder is untouched.
TEST_F(CliReliability, AugmentDatasetResumesOnlyWithTheSameSettings) {
  const auto root = dataset("ds");
  const auto out = dir_ / "o";
  const std::string base = "augment-dataset " + quoted(root) + " --out " + quoted(out);
  auto r = run_fishcam(base + " --preset small --seed 5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<std::pair<std::string, std::string>> changes{
      {" --preset small --seed 6", "--seed: this folder was written with '5', this run has '6'"},
      {" --preset small --seed 5 --depth target-sphere", "--depth: this folder was written with 'source-sphere'"},
      {" --preset small --seed 5 --sampling exact", "--sampling: this folder was written with 'grid'"},
      {" --preset small --seed 5 --label-fill 255", "--label-fill: this folder was written with '0'"},
      {" --preset small --seed 5 --copies 2", "--copies: this folder was written with '1'"},
      {" --preset medium --seed 5", "--preset: this folder was written with 'small'"},
      {" --preset small --seed 5 --method affine", "--method: this folder was written with 'viewpoint'"}};
  int refused = 0;
  for (const auto& [change, expected] : changes) {
    for (const char* shard : {"", " --shard 0/1", " --shard 1/2"}) {
      expect_refused(base + change + shard, expected, out);
      ++refused;
    }
  }
  EXPECT_EQ(refused, 21);
  r = run_fishcam(base + " --preset small --seed 5 --shard 1/2");
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

// A dataset under a path that is not UTF-8 (Latin-1 bytes) still augments and
// resumes: its settings record holds the path's other bytes as \xNN.
TEST_F(CliReliability, SettingsRecordsHoldPathsThatAreNotUtf8) {
  const auto root = dir_ / "lat\xe9n";
  ASSERT_EQ(run_fishcam("sample-dataset " + quoted(root) + " --images 2 --seed 1 --size 64x48").exit_code, 0);
  const std::string command =
      "augment-dataset " + quoted(root) + " --preset small --seed 1 --out " + quoted(dir_ / "o");
  auto r = run_fishcam(command);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(test::read_file(dir_ / "o" / "augment-dataset.json").find("lat\\\\xe9n"), std::string::npos);
  r = run_fishcam(command);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("0 written, 2 already there"), std::string::npos) << r.out;
}

// Probe 15 and Deliver 2: empty or repeated names in a list option, and an empty
// output folder, are refused before anything is written.
TEST_F(CliReliability, EmptyOrRepeatedNamesAndEmptyOutputsAreRefused) {
  const auto root = dataset("ds");
  const auto out = dir_ / "o";
  const std::string base = "augment-dataset " + quoted(root) + " --seed 1 ";
  expect_refused(base + "--preset small,small --out " + quoted(out), "--preset: 'small' is given twice", dir_ / "o");
  expect_refused(base + "--preset small, --out " + quoted(out), "--preset: an empty name", dir_ / "o");
  expect_refused(base + "--preset small --out ''", "--out: expected a folder", dir_);
  expect_refused("sample-dataset " + quoted(dir_ / "sv") + " --scenes 2 --cameras FV,FV --seed 1",
                 "--cameras: 'FV' is given twice", dir_ / "sv");
  expect_refused("sample-dataset " + quoted(dir_ / "sv") + " --scenes 2 --test-sets small,,large --seed 1",
                 "--test-sets: an empty name", dir_ / "sv");
  expect_refused("sample-dataset '' --images 2 --seed 1", "OUT: expected a folder", dir_);
}

// sample-dataset records its settings: the same settings resume (nothing rewritten),
// other settings are refused naming the difference, and a folder of someone
// else's files is refused before anything is written.
TEST_F(CliReliability, SampleDatasetResumesOnlyWithTheSameSettings) {
  const auto out = dir_ / "s";
  const std::string base = "sample-dataset " + quoted(out) + " --images 2 --size 64x48";
  auto r = run_fishcam(base + " --seed 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto first = test::files_below(out);
  r = run_fishcam(base + " --seed 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("(2 already there)"), std::string::npos) << r.out;
  EXPECT_TRUE(test::files_below(out) == first);
  expect_refused(base + " --seed 2", "--seed: this folder was written with '1', this run has '2'", out);
  // A sample cut by a kill between the renames of its files is written again.
  fs::remove(out / "calibration" / "00001_FV.json");
  r = run_fishcam(base + " --seed 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(test::files_below(out) == first);
  expect_refused(base + " --seed 1 --depth", "--depth: this folder was written with 'no'", out);
  const auto foreign = dir_ / "f";
  put(foreign / "rgb_images" / "00001_FV.png", "mine");
  expect_refused("sample-dataset " + quoted(foreign) + " --images 2 --seed 1 --size 64x48",
                 "exists and is not a sample of a run with these settings", foreign);
  // A surround-view set the same way (its manifests included).
  const std::string sv =
      "sample-dataset " + quoted(dir_ / "sv") + " --scenes 2 --cameras FV --size 64x48 --test-sets small";
  ASSERT_EQ(run_fishcam(sv + " --seed 3").exit_code, 0);
  const auto whole = test::files_below(dir_ / "sv");
  r = run_fishcam(sv + " --seed 3");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(test::files_below(dir_ / "sv") == whole);
  expect_refused(sv + " --seed 4", "--seed: this folder was written with '3'", dir_ / "sv");
}

// Probe 10: seeds are integers in [0, 2^64) everywhere (CLI11 clamped 2^64 to 2^64 - 1).
TEST_F(CliReliability, SeedsOutsideUint64AreRefused) {
  const std::string camera = quoted(test::data_path("woodscape_front.json"));
  for (const char* seed : {"18446744073709551616", "1.5", "99999999999999999999999", "0x10"}) {
    expect_refused(
        "synth-corners " + camera + " --boards 3 --noise 0 --seed " + seed + " --out " + quoted(dir_ / "c.vnl"),
        "--seed: must be an integer in [0, 2^64)", dir_);
  }
  expect_refused("synth-corners " + camera + " --boards 3 --noise 0 --seed -1 --out " + quoted(dir_ / "c.vnl"),
                 "--seed: must not be negative", dir_);
  EXPECT_EQ(run_fishcam("synth-corners " + camera + " --boards 3 --noise 0 --seed 18446744073709551615 --out " +
                        quoted(dir_ / "c.vnl"))
                .exit_code,
            0);
}

// Probe 7: 9x6 corners read as 2x27 (the same count) wrote a camera with RMS 49 px.
TEST_F(CliReliability, ABoardSizeThatDoesNotExplainTheCornersWritesNothing) {
  auto r = run_fishcam("synth-corners " + quoted(test::data_path("woodscape_front.json")) +
                       " --boards 20 --noise 0.2 --seed 3 --board 9x6 --out " + quoted(dir_ / "c.vnl"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_refused("calibrate --corners " + quoted(dir_ / "c.vnl") +
                     " --board 2x27 --spacing 0.1 --imagersize 1280x966 --model polynomial --out " +
                     quoted(dir_ / "cal.json"),
                 "pass --board 9x6", dir_ / "cal.json");
  expect_refused("calibrate --corners " + quoted(dir_ / "c.vnl") +
                     " --board 9x6 --spacing 0.1 --imagersize 640x483 --model polynomial --out " +
                     quoted(dir_ / "cal.json"),
                 "corners lie outside the 640x483 image", dir_ / "cal.json");
}

// detect-corners given one photo twice, in any spelling, refuses (its corners file
// would hold the board twice).
TEST_F(CliReliability, DetectCornersRefusesOnePhotoTwice) {
  const auto photo = put(dir_ / "x.png", "not read");
  expect_refused("detect-corners " + quoted(photo) + " " + quoted(dir_ / "." / "x.png") + " --board 9x6 --out " +
                     quoted(dir_ / "c.vnl"),
                 "the same image as", dir_ / "c.vnl");
}

// fidelity refuses a test set without its changes (it was skipped in silence) and
// changes no preset makes (a 1e308-degree rotation).
TEST_F(CliReliability, FidelityRefusesIncompleteOrAbsurdTestSets) {
  const auto root = dir_ / "sv";
  ASSERT_EQ(run_fishcam("sample-dataset " + quoted(root) +
                        " --scenes 2 --cameras FV --size 64x48 --test-sets small "
                        "--splits 0,0,1 --seed 1")
                .exit_code,
            0);
  EXPECT_EQ(run_fishcam("fidelity " + quoted(root)).exit_code, 0);
  const auto changes = root / "test-small" / "changes.jsonl";
  std::string text = test::read_file(changes);
  const std::string original = text;
  const auto at = text.find("\"rotation_deg\":[") + 16;
  text.replace(at, text.find(',', at) - at, "1e308");
  put(changes, text);
  expect_refused("fidelity " + quoted(root), "rotation_deg: expected angles within [-360, 360], got 1e+308", root);
  put(changes, original);
  fs::rename(root / "test-small-rotation" / "changes.jsonl", dir_ / "moved.jsonl");
  expect_refused("fidelity " + quoted(root), "a test set without changes.jsonl", root);
}

// Probe 12: every input that is not a camera or an image file is bounded too: a FIFO
// (no writer), /dev/zero and a sparse file far past the reader's limit are refused
// at once, with one line naming the file (standard input: the line).
TEST_F(CliReliability, EveryInputIsBounded) {
  const auto fifo = dir_ / "fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const auto sparse = dir_ / "sparse";
  {
    const int fd = open(sparse.c_str(), O_WRONLY | O_CREAT, 0600);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(ftruncate(fd, off_t(3) << 30), 0);  // 3 GiB, no blocks
    close(fd);
  }
  const std::string camera = quoted(test::data_path("woodscape_front.json"));
  const std::map<std::string, std::string> commands{
      {"corners", "calibrate --corners FILE --board 9x6 --spacing 0.1 --imagersize 1280x966 --model polynomial --out " +
                      quoted(dir_ / "cal.json")},
      {"csv", "fit FILE --to polynomial:4 --imagersize 1280,966 --center 640,483 --out " + quoted(dir_ / "fit.json")},
      {"npy",
       "augment " + camera + " --image FILE --out-image " + quoted(dir_ / "a.png") + " --depth map --depth-file FILE"},
  };
  int checked = 0;
  for (const auto& [what, command] : commands) {
    for (const fs::path& input : {fifo, fs::path("/dev/zero"), sparse}) {
      std::string args = command;
      for (size_t at; (at = args.find("FILE")) != std::string::npos;) args.replace(at, 4, quoted(input));
      const auto start = std::chrono::steady_clock::now();
      const auto r = run_fishcam(args);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      EXPECT_NE(r.exit_code, 0) << what << " " << input;
      const bool named =
          r.err.find("not a regular file") != std::string::npos || r.err.find("larger than") != std::string::npos;
      EXPECT_TRUE(named) << what << " " << input << ": " << r.err;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      EXPECT_LT(seconds, 10) << what << " " << input;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 9);
  // Standard input: a record longer than any is refused (it read /dev/zero until memory ran out).
  const std::string command = "timeout 20 '" + test::fishcam_binary() + "' project " + camera +
                              " < /dev/zero > /dev/null 2> " + quoted(dir_ / "err");
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1) << "124: timed out";
  EXPECT_NE(test::read_file(dir_ / "err").find("stdin line 1: longer than 4096 characters"), std::string::npos)
      << test::read_file(dir_ / "err");
}

// demo writes into a folder too: a file of the user's under one of its names stays
// (refused before anything is computed); --force replaces it.
TEST_F(CliReliability, DemoNeverReplacesFilesUnlessForced) {
  const auto mine = put(dir_ / "out" / "demo-fig5.png", "mine");
  expect_refused("demo --out " + quoted(dir_ / "out"), "demo-fig5.png: already exists", dir_ / "out");
  EXPECT_EQ(test::read_file(mine), "mine");
  const auto r = run_fishcam("demo --out " + quoted(dir_ / "out") + " --force");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(test::read_file(mine), "mine");
  expect_refused("demo --out ''", "--out: expected a folder", dir_);
}

// Probe 8: readers refuse magnitudes no camera has (principal point and focal
// length within 1e6 px), cameras of which no pixel has a ray, mrcal lenses with NaN
// constants or absurd values; info's field of view is what the image sees.
TEST_F(CliReliability, ReadersRefuseMagnitudesNoCameraHas) {
  const std::string woodscape = test::read_file(test::data_path("woodscape_front.json"));
  const auto with = [&](const std::string& field, const std::string& value) {
    std::string text = woodscape;
    const size_t at = text.find("\"" + field + "\": ") + field.size() + 4;
    text.replace(at, text.find_first_of(",\n", at) - at, value);
    return text;
  };
  const std::vector<std::tuple<std::string, std::string, std::string>> cases{
      {"cx_offset", "1e9", "principal_point: expected within +-1e+06 px"},
      {"cx_offset", "2147483648", "principal_point: expected within +-1e+06 px"},
      {"k1", "1e12", "the focal length (rho'(0) a) must be at most 1e+06 px"},
      {"aspect_ratio", "1e300", "pixel_scale: expected within"},
      {"cx_offset", "1e5", "no pixel of the image has a ray"},
  };
  int refused = 0;
  for (const auto& [field, value, expected] : cases) {
    try {
      parse_camera(with(field, value), "front.json");
      ADD_FAILURE() << field << " = " << value << " was read";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << field << " = " << value << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find("front.json"), std::string::npos) << e.what();
      ++refused;
    }
  }
  EXPECT_EQ(refused, int(cases.size()));
  EXPECT_NO_THROW(parse_camera(with("cx_offset", "100"), "front.json"));  // off-centre, but it sees
  // mrcal lenses: a NaN linearity, a value no lens has.
  for (const auto& [lensmodel, values, expected] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"LENSMODEL_CAHVORE_linearity=nan", "0.01, 0.02, 0.1, 0.02, 0.0, 0.0, 0.5, 0.0, 0.0",
            "linearity must be a finite"},
           {"LENSMODEL_CAHVOR", "0.01, 0.02, 0.1, 0.02, 1e20", "values must lie within [-1000, 1000], got 1e+20"}}) {
    const std::string text = "{ 'lensmodel': '" + lensmodel + "', 'intrinsics': [ 640, 640, 639.5, 482.5, " + values +
                             " ], 'imagersize': [1280, 966] }";
    try {
      parse_camera(text, "lens.cameramodel", CameraFormat::mrcal);
      ADD_FAILURE() << lensmodel << " was read";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    // Through the program: one line on standard error, libmrcal's own lines not among them.
    const auto file = put(dir_ / "lens.cameramodel", text);
    expect_refused("info " + quoted(file), expected.substr(0, 40), dir_);
  }
}

// Probe 13: a CAHVORE lens whose own iteration fails at the fold of its distortion
// (libmrcal prints "too many iterations" for each such point: ~94k lines in info and
// ~380k per map before). Its domain ends where libmrcal evaluates, just inside the
// fold; no command that evaluates the camera lets libmrcal reach the terminal.
TEST_F(CliReliability, LibmrcalSaysNothingAtRunTime) {
  const auto file =
      put(dir_ / "cahvore.cameramodel",
          "{ 'lensmodel': 'LENSMODEL_CAHVORE_linearity=0.25', 'intrinsics': [ 160, 160, 159.5, 120.5, "
          "0.0263, 0.1000, 0.0172, -0.1905, -0.0110, 0.1722, 0.9753, 0.0697 ], 'imagersize': [320, 242] }");
  const Camera camera = read_camera(file.string());
  const double fold_deg = 40.2825;  // where the fold scan ends the domain (measured)
  EXPECT_LT(camera.domain().theta_max * 180 / std::numbers::pi, fold_deg);
  EXPECT_GT(camera.domain().theta_max * 180 / std::numbers::pi, fold_deg * 0.99);
  const std::string front = quoted(test::data_path("woodscape_front.json"));
  int ran = 0;
  for (const std::string& args :
       {"info " + quoted(file), "map " + quoted(file) + " --rotate 30,-20,10 --out " + quoted(dir_ / "a.npy"),
        "map " + front + " --target " + quoted(file) + " --rotate 10,0,0 --out " + quoted(dir_ / "b.npy")}) {
    const auto r = run_fishcam(args);
    EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err.substr(0, 400);
    EXPECT_EQ(r.err.find("too many iterations"), std::string::npos) << args << ": " << r.err.substr(0, 200);
    EXPECT_EQ(r.err, "") << args;
    ++ran;
  }
  const auto r = run_fishcam("unproject " + quoted(file), "0 0\n-5000 -5000\n159.5 120.5\n319 241\n");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(ran, 3);
}

// Probe 9: diff refuses cameras of different sizes unless told to resize; a map is
// .npy only and a validity mask lossless only.
TEST_F(CliReliability, OutputsAndComparisonsThatCannotBeRight) {
  const std::string front = quoted(test::data_path("woodscape_front.json"));
  const auto small = put(dir_ / "small.json", test::read_file(test::data_path("woodscape_front.json")));
  std::string text = test::read_file(small);
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"\"height\": 966", "\"height\": 483"},
                                 {"\"width\": 1280", "\"width\": 640"}}) {
    text.replace(text.find(from), from.size(), to);
  }
  put(small, text);
  expect_refused("diff " + front + " " + quoted(small), "cameras of different image sizes are not compared", dir_);
  const auto r = run_fishcam("diff " + front + " " + quoted(small) + " --resize --region all");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  expect_refused("map " + front + " --rotate 1,0,0 --out " + quoted(dir_ / "m.png"), "a map is written as .npy", dir_);
  ASSERT_EQ(run_fishcam("render " + front + " --out-image " + quoted(dir_ / "s.png") + " --out-label " +
                        quoted(dir_ / "l.png"))
                .exit_code,
            0);
  expect_refused("augment " + front + " --image " + quoted(dir_ / "s.png") + " --out-image " + quoted(dir_ / "a.png") +
                     " --out-mask " + quoted(dir_ / "m.jpg") + " --rotate 1,0,0",
                 "labels need a lossless format", dir_);
}

}  // namespace
}  // namespace fishcam
