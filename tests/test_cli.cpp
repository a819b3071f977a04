// The fishcam program: its stable interface and its errors.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <sstream>
#include <vector>

#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

using test::run_fishcam;

std::string data(const char* name) { return test::quoted(test::data_path(name)); }

TEST(Cli, InfoJsonHasTheDocumentedKeys) {
  const auto r = run_fishcam("info " + data("woodscape_front.json") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"model", "width", "height", "cx", "cy", "theta_max_deg", "rho_max_px", "fov_deg"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["model"], "polynomial");
  EXPECT_EQ(j["width"], 1280);
  EXPECT_NEAR(j["cx"].get<double>(), 643.442, 1e-12);
  EXPECT_NEAR(j["theta_max_deg"].get<double>(), 180.0, 1e-12);
  EXPECT_NEAR(j["fov_deg"]["horizontal"].get<double>(), 190, 1);
  for (const char* key : {"horizontal", "vertical", "diagonal"}) EXPECT_TRUE(j["fov_deg"].contains(key));
}

TEST(Cli, InfoTextForEveryBundledCamera) {
  for (const char* name : {"woodscape_front.json", "stereographic.cameramodel", "pinhole.cameramodel",
                           "kannala_brandt.yaml", "equidistant.json"}) {
    const auto r = run_fishcam(std::string("info ") + data(name));
    EXPECT_EQ(r.exit_code, 0) << name << r.err;
    EXPECT_NE(r.out.find("theta_max"), std::string::npos);
  }
}

// How unprojection inverts rho: a table (closed domains), a closed form, or for an
// open domain without one (opencv) the robust solver -- info says which.
TEST(Cli, InfoSaysHowUnprojectionInverts) {
  const auto dir = test::scratch_dir("cli_info_inverse");
  CameraParameters p = test::woodscape_front();
  p.model = OpenCV<double>(700.0, 0.1, 0.01, 0, 0, 0, 0);  // rho grows without a fold: an open domain
  write_camera(p, dir / "cv.json", CameraFormat::fishcam);
  const struct {
    std::string file;
    bool closed_form;
    const char* text;
  } cases[] = {{data("stereographic.cameramodel"), true, "none (closed-form inverse)"},
               {test::quoted(dir / "cv.json"), false, "none (open domain: the robust solver per point)"},
               {data("woodscape_front.json"), false, "2048 cells"}};
  for (const auto& c : cases) {
    auto r = run_fishcam("info --json " + c.file);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["inverse_table"]["closed_form"].get<bool>(), c.closed_form) << c.file;
    r = run_fishcam("info " + c.file);
    EXPECT_NE(r.out.find(c.text), std::string::npos) << c.file << "\n" << r.out;
  }
}

// A camera that is not radially symmetric says what its non-radial part is, in text
// and JSON; a radial one has null there.
TEST(Cli, InfoSaysWhatIsNotRadiallySymmetric) {
  const auto dir = test::scratch_dir("cli_info_non_radial");
  const CameraParameters tangential = test::every_tangential_camera().front().second;  // pinhole + p1, p2
  write_camera(tangential, dir / "tangential.json", CameraFormat::fishcam);
  auto r = run_fishcam("info --json " + test::quoted(dir / "tangential.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["tangential"]["p1"].get<double>(), tangential.tangential_terms().p1);
  EXPECT_TRUE(j["mrcal_lens"].is_null());
  std::vector<std::string> files = {"tangential.json"};
  for (const auto& [label, p] : test::mrcal_lens_cameras()) {  // every mrcal lens kind
    files.push_back(label + ".json");
    write_camera(p, dir / files.back(), CameraFormat::fishcam);
    r = run_fishcam("info --json " + test::quoted(dir / files.back()));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["mrcal_lens"]["lensmodel"], p.mrcal_lens()->lensmodel());
    EXPECT_EQ(j["mrcal_lens"]["base_model"], p.mrcal_lens()->base_model());
    EXPECT_EQ(j["mrcal_lens"]["values"].get<size_t>(), p.mrcal_lens()->values().size());
    EXPECT_TRUE(j["tangential"].is_null());
  }
  EXPECT_EQ(files.size(), 1 + MrcalLens::kinds().size());
  r = run_fishcam("info --json " + data("woodscape_front.json"));
  j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["tangential"].is_null() && j["mrcal_lens"].is_null());
  for (const std::string& file : files) {
    r = run_fishcam("info " + test::quoted(dir / file));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("not radially symmetric"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("unprojection      2-D Newton"), std::string::npos) << r.out;
    if (file != "tangential.json") {
      EXPECT_NE(r.out.find("mrcal lens        LENSMODEL_"), std::string::npos) << r.out;
    }
  }
}

TEST(Cli, ProjectThenUnprojectRoundTrips) {
  const auto projected = run_fishcam("project " + data("woodscape_front.json"),
                                     "1 0.5 2\n# a comment\n\n1 -1 -0.5\n0 0 -1\n0 0 0\nnan 1 1\n");
  ASSERT_EQ(projected.exit_code, 0) << projected.err;
  std::istringstream lines(projected.out);
  std::string line;
  std::vector<std::string> rows;
  while (std::getline(lines, line)) rows.push_back(line);
  ASSERT_EQ(rows.size(), 5u);
  EXPECT_EQ(rows[0], "796.19202223284162 555.78201111642079");  // the worked value of test_woodscape
  EXPECT_EQ(rows[2], "nan nan");
  EXPECT_EQ(rows[3], "nan nan");
  EXPECT_EQ(rows[4], "nan nan");
  const auto unprojected =
      run_fishcam("unproject " + data("woodscape_front.json"), rows[0] + "\n" + rows[1] + "\n99999 0\n");
  ASSERT_EQ(unprojected.exit_code, 0) << unprojected.err;
  std::istringstream rays(unprojected.out);
  Eigen::Vector3d a, b;
  rays >> a.x() >> a.y() >> a.z() >> b.x() >> b.y() >> b.z();
  EXPECT_LT(test::angle_between(a, Eigen::Vector3d(1, 0.5, 2).normalized()), 1e-12);
  EXPECT_LT(test::angle_between(b, Eigen::Vector3d(1, -1, -0.5).normalized()), 1e-12);
  EXPECT_NE(unprojected.out.find("nan nan nan"), std::string::npos);
}

TEST(Cli, BadInputExitsNonZeroWithOneLine) {
  const struct {
    std::string args, stdin_text, expected;
  } cases[] = {
      {"project " + data("woodscape_front.json"), "1 2\n", "stdin line 1: expected three numbers"},
      {"project " + data("woodscape_front.json"), "1 2 3\n1 2 x\n", "stdin line 2"},
      {"project " + data("woodscape_front.json"), "1 2 3 4\n", "too many values"},
      {"unproject " + data("woodscape_front.json"), "1,2\n", "stdin line 1: expected two numbers"},
      {"info /no/such/camera.json", "", "/no/such/camera.json: cannot open"},
      {"info", "", "CAMERA is required"},
      {"frobnicate", "", "fishcam: error"},
      {"", "", "fishcam: error"},
      {"info " + data("woodscape_front.json") + " --jsn", "", "--jsn"},
      {"bench roots " + data("woodscape_front.json") + " --repeats 0", "", "--repeats"},
  };
  for (const auto& c : cases) {
    const auto r = run_fishcam(c.args, c.stdin_text);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << " -> " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << " -> " << r.err;
  }
}

// The subcommands the program lists under "Subcommands:" in its --help.
std::vector<std::string> listed_subcommands(const std::string& prefix) {
  const auto r = run_fishcam(prefix + " --help");
  EXPECT_EQ(r.exit_code, 0) << prefix;
  std::vector<std::string> names;
  std::istringstream in(r.out.substr(std::min(r.out.size(), r.out.find("Subcommands:"))));
  std::string line;
  std::getline(in, line);  // "Subcommands:"
  while (std::getline(in, line) && line.rfind("  ", 0) == 0) {
    std::istringstream words(line);
    std::string name;
    words >> name;
    names.push_back(prefix.empty() ? name : prefix + " " + name);
  }
  return names;
}

TEST(Cli, EverySubcommandHasHelp) {
  // The program's own list, not a copy: a new subcommand is checked without a line here.
  std::vector<std::string> subcommands = listed_subcommands("");
  const auto bench = listed_subcommands("bench");
  EXPECT_GE(subcommands.size(), 22u);  // as many as tools/commands.hpp registers today
  EXPECT_GE(bench.size(), 3u);
  subcommands.insert(subcommands.end(), bench.begin(), bench.end());
  subcommands.push_back("");
  for (const auto& sub : subcommands) {
    const auto r = run_fishcam(sub + " --help");
    EXPECT_EQ(r.exit_code, 0) << sub;
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << sub << r.out;
  }
}

}  // namespace
}  // namespace fishcam
