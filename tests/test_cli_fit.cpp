// fishcam convert and fishcam fit end to end.
#include <nlohmann/json.hpp>

#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

using test::run_fishcam;

using test::quoted;

TEST(CliFit, ConvertReportsAndWritesEveryFormat) {
  const auto dir = test::scratch_dir("cli_convert");
  const std::string source = quoted(test::data_path("woodscape_front.json"));
  auto r = run_fishcam("convert " + source + " --to kannala-brandt --out " + quoted(dir / "kb.yaml") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"rms_px", "p99_px", "max_px", "by_angle", "below_90_deg"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_LT(j["rms_px"].get<double>(), 0.2);
  EXPECT_NE(r.err.find("warning: OpenCV's fisheye functions"), std::string::npos) << r.err;
  EXPECT_EQ(read_camera(dir / "kb.yaml").parameters().model.index(), RadialModel(KannalaBrandt<double>()).index());

  r = run_fishcam("convert " + source + " --to stereographic --out " + quoted(dir / "st.cameramodel"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("rms"), std::string::npos);
  r = run_fishcam("convert " + source + " --to equidistant --method paper --out " + quoted(dir / "eq.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_fishcam("convert " + source + " --to polynomial:5 --out " + quoted(dir / "ws.json") + " --format woodscape");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Radial -> OpenCV's rational model (mrcal's OPENCV8 with p1 = p2 = 0) where it can hold the field of view.
  r = run_fishcam("convert " + source + " --to opencv --max-angle 75 --out " + quoted(dir / "cv8.cameramodel") +
                  " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LT(nlohmann::json::parse(r.out)["max_px"].get<double>(), 1.0);
  EXPECT_EQ(read_camera(dir / "cv8.cameramodel").parameters().model.index(), RadialModel(OpenCV<double>()).index());
  EXPECT_NE(test::read_file(dir / "cv8.cameramodel").find("LENSMODEL_OPENCV8"), std::string::npos);

  const struct {
    std::string args, expected;
  } bad[] = {
      {"--to polynomial --out " + quoted(dir / "p.cameramodel"),
       "the mrcal format holds pinhole, stereographic and opencv"},
      {"--to fisheye --out " + quoted(dir / "x.json"), "unknown model 'fisheye'"},
      {"--to pinhole --out " + quoted(dir / "x.json"), "--max-angle"},
      {"--to kannala-brandt --method paper --out " + quoted(dir / "x.json"), "eqs. 13-14"},
      {"--to equidistant --out " + quoted(dir / "x.dat"), "cannot tell the format"},
      {"--to kannala-brandt --out " + quoted(dir / "kb.yaml"), "refusing to overwrite"},
  };
  for (const auto& c : bad) {
    r = run_fishcam("convert " + source + " " + c.args);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << " -> " << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "p.cameramodel"));
}

TEST(CliFit, FitFromCsv) {
  const auto dir = test::scratch_dir("cli_fit");
  std::string theta_rho = "# the WoodScape front camera's radial curve\ntheta,rho\n";
  const Polynomial<double> truth({339.749, -31.988, 48.275, -7.201});
  for (int i = 1; i <= 60; ++i) {
    const double t = 0.03 * i;
    theta_rho += std::to_string(t) + ", " + std::to_string(truth.rho(t)) + "\n";
  }
  test::write_file(dir / "tr.csv", theta_rho);
  auto r = run_fishcam("fit " + quoted(dir / "tr.csv") +
                       " --to polynomial --imagersize 1280,966 --center 643.442,479.407 "
                       "--out " +
                       quoted(dir / "fit.json") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto params = model_params(read_camera(dir / "fit.json").model());
  EXPECT_NEAR(params[0], 339.749, 1e-3);  // the CSV holds 6 decimals
  EXPECT_LT(nlohmann::json::parse(r.out)["max_px"].get<double>(), 1e-5);

  // Rays and pixels, with an unknown principal point.
  std::string rays = "x,y,z,u,v\n";
  const Camera camera = read_camera(test::data_path("stereographic.cameramodel"));
  for (const auto& ray : test::random_rays(500, 2.5, 4)) {
    Eigen::Vector2d q;
    ASSERT_TRUE(camera.project(ray, &q));
    char line[256];
    std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g,%.17g,%.17g\n", ray.x(), ray.y(), ray.z(), q.x(), q.y());
    rays += line;
  }
  test::write_file(dir / "rays.csv", rays);
  r = run_fishcam("fit " + quoted(dir / "rays.csv") +
                  " --to stereographic --imagersize 1280,966 --center 640,480 "
                  "--fit-center --fit-aspect --out " +
                  quoted(dir / "st.cameramodel"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Camera fitted = read_camera(dir / "st.cameramodel");
  EXPECT_LT((fitted.principal_point() - camera.principal_point()).norm(), 1e-6);
  EXPECT_NEAR(model_params(fitted.model())[0], model_params(camera.model())[0], 1e-6);

  const struct {
    std::string content, expected;
  } bad[] = {
      {"theta;rho\n1;2\n", "expected a header"},
      {"theta,rho\n0.1,20\n0.2,x\n", ":3: expected 2 finite numbers"},
      {"theta,rho\n0.1,20,3\n", "expected 2 numbers, got 3"},
      {"theta,rho\n", "no data rows"},
      {"", "empty"},
      {"theta,rho\n4,20\n", "theta must be in [0, pi]"},
      {"theta,rho\n0.1,nan\n", "finite numbers"},
  };
  for (const auto& c : bad) {
    test::write_file(dir / "bad.csv", c.content);
    r = run_fishcam("fit " + quoted(dir / "bad.csv") +
                    " --to equidistant --imagersize 1280,966 --center 640,480 --out " + quoted(dir / "bad.json"));
    EXPECT_NE(r.exit_code, 0) << c.content;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.content << " -> " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

// What render_detect_calibrate leaves: the photos' paths (one string, each quoted) and
// the programs' standard outputs.
struct RenderedTarget {
  std::string photos, synth_out, detect_out;
  nlohmann::json calibration;
};

// Photos of `target` (a --target option) through the 190-degree lens, boards cut by
// the image's edges among them: rendered by synth-corners into dir/photos, found by
// detect-corners with their ids (dir/found.vnl), calibrated (dir/calibrated.json) to
// the truth with corners past 90 degrees, and --theta-limit data follows them there.
void render_detect_calibrate(const std::filesystem::path& dir, const std::string& target, int boards,
                             RenderedTarget* out) {
  std::filesystem::create_directories(dir / "photos");
  auto r = run_fishcam("synth-corners " + quoted(test::data_path("kannala_brandt.yaml")) + target + " --boards " +
                       std::to_string(boards) + " --noise 0 --seed 5 --out " + quoted(dir / "truth.vnl") +
                       " --images " + quoted(dir / "photos"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  out->synth_out = r.out;
  for (int b = 0; b < boards; ++b) {
    char name[32];
    std::snprintf(name, sizeof name, "synth-%03d.png", b);
    out->photos.append(" ").append(quoted(dir / "photos" / name));
  }
  r = run_fishcam("detect-corners" + out->photos + target + " --out " + quoted(dir / "found.vnl"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("of them partly"), std::string::npos) << r.out;
  out->detect_out = r.out;
  r = run_fishcam("calibrate --corners " + quoted(dir / "found.vnl") + target +
                  " --imagersize 1280x966 --model kannala-brandt --theta-limit data --json --out " +
                  quoted(dir / "calibrated.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_LT(j["rms_px"].get<double>(), 0.15);
  EXPECT_NEAR(j["parameters"]["f"]["value"].get<double>(), 331.5526, 1.0);
  EXPECT_NEAR(j["parameters"]["cx"]["value"].get<double>(), 643.442, 0.5);
  EXPECT_NEAR(j["parameters"]["cy"]["value"].get<double>(), 479.407, 0.5);
  out->calibration = j;
  r = run_fishcam("info " + quoted(dir / "calibrated.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto at = r.out.find("observed angles   theta up to ");
  ASSERT_NE(at, std::string::npos) << r.out;
  EXPECT_GT(std::stod(r.out.substr(at + 30)), 95.0) << r.out;
}

TEST(CliFit, ChArUcoPhotosCalibrateToTheRim) {
  const auto dir = test::scratch_dir("cli_charuco");
  const std::string target = " --target charuco:8x6:0.1:0.06";
  RenderedTarget rendered;
  ASSERT_NO_FATAL_FAILURE(render_detect_calibrate(dir, target, 24, &rendered));
  EXPECT_TRUE(std::filesystem::exists(dir / "photos" / "synth-023.png"));
  // A partial board's missing corners are mrcal's "- - -" rows, every image W*H rows.
  EXPECT_NE(test::read_file(dir / "found.vnl").find(" - - -\n"), std::string::npos);
  // As the chessboard of its inner corners, the same camera.
  auto r = run_fishcam("calibrate --corners " + quoted(dir / "found.vnl") +
                       " --board 7x5 --spacing 0.1 --imagersize 1280x966 --model kannala-brandt --json --out " +
                       quoted(dir / "as-chessboard.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["rms_px"], rendered.calibration["rms_px"]);
  // A chessboard and a ChArUco target at once are refused; so is neither.
  r = run_fishcam("detect-corners" + rendered.photos + target + " --board 7x5 --out " + quoted(dir / "both.vnl"));
  EXPECT_NE(r.exit_code, 0);
  r = run_fishcam("calibrate --corners " + quoted(dir / "found.vnl") +
                  " --imagersize 1280x966 --model kannala-brandt --out " + quoted(dir / "neither.json"));
  EXPECT_NE(r.err.find("give --board WxH and --spacing S (a chessboard), or --target charuco:"), std::string::npos)
      << r.err;
}

// Kalibr's AprilGrid the same way, detected by libapriltag, and its report drawn from
// the same target.
TEST(CliFit, AprilGridPhotosCalibrateToTheRim) {
  const auto dir = test::scratch_dir("cli_aprilgrid");
  const std::string target = " --target aprilgrid:6x5:0.1:0.3";
  RenderedTarget rendered;
  ASSERT_NO_FATAL_FAILURE(render_detect_calibrate(dir, target, 20, &rendered));
  EXPECT_NE(rendered.synth_out.find("AprilGrid boards of 12x10 corners"), std::string::npos) << rendered.synth_out;
  auto r = run_fishcam("report " + quoted(dir / "calibrated.json") + " --corners " + quoted(dir / "found.vnl") +
                       target + " --out " + quoted(dir / "report"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "report" / "index.html"));
  r = run_fishcam("calibrate --corners " + quoted(dir / "found.vnl") +
                  " --target grid:6x5:0.1:0.3 --imagersize 1280x966 --model kannala-brandt --out " +
                  quoted(dir / "bad.json"));
  EXPECT_NE(r.err.find("expected charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY] (OpenCV's ChArUco) or "
                       "aprilgrid:COLSxROWS:SIZE:SPACING"),
            std::string::npos)
      << r.err;
}

TEST(CliFit, SynthCornersCalibrateDiff) {
  const auto dir = test::scratch_dir("cli_calibrate");
  auto r = run_fishcam("synth-corners " + quoted(test::data_path("woodscape_front.json")) +
                       " --boards 20 --noise 0.2 --seed 3 --board 8x6 --spacing 0.05 --out " + quoted(dir / "c.vnl") +
                       " --truth " + quoted(dir / "truth.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_fishcam("calibrate --corners " + quoted(dir / "c.vnl") +
                  " --board 8x6 --spacing 0.05 --imagersize 1280x966 "
                  "--model polynomial --out " +
                  quoted(dir / "calibrated.json") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["rms_px"].get<double>(), 0.2 * std::sqrt(2.0), 0.05);        // the 2-D norm of noise 0.2 per coordinate
  EXPECT_NEAR(j["rms_per_coordinate_px"].get<double>(), 0.2, 0.035);         // what mrcal and OpenCV print
  EXPECT_LT(std::abs(j["board_warp"]["x2"]["value"].get<double>()), 0.005);  // flat boards: solved by default
  EXPECT_DOUBLE_EQ(j["rms_per_coordinate_px"].get<double>(), j["rms_px"].get<double>() / std::sqrt(2.0));
  for (const char* p : {"k1", "k2", "k3", "k4", "cx", "cy", "a_y"}) {
    EXPECT_TRUE(j["parameters"].contains(p)) << p;
    EXPECT_GT(j["parameters"][p]["sigma"].get<double>(), 0) << p;
  }
  EXPECT_EQ(j["per_image_rms_px"].size(), 20u);
  r = run_fishcam("calibrate --corners " + quoted(dir / "c.vnl") +
                  " --board 8x6 --spacing 0.05 --imagersize 1280x966 --model polynomial --board-warp off --out " +
                  quoted(dir / "flat.json") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(nlohmann::json::parse(r.out)["board_warp"].is_null());
  EXPECT_TRUE(j["outliers"].is_array() && j["outliers"].empty()) << j["outliers"];
  // Against the truth across the whole image: only the noise's effect remains.
  // (A Kannala-Brandt model calibrated from the same corners fits them as well but
  // extrapolates to 24 px in the image corners no board reached: diff shows that too.)
  r = run_fishcam("diff " + quoted(dir / "truth.json") + " " + quoted(dir / "calibrated.json") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LT(nlohmann::json::parse(r.out)["rms_px"].get<double>(), 0.5);

  const struct {
    std::string args, expected;
  } bad[] = {
      {"calibrate --corners " + quoted(dir / "c.vnl") +
           " --board 10x10 --spacing 0.05 --imagersize 1280x966 --model "
           "polynomial --out " +
           quoted(dir / "x.json"),
       "expected 100 corners (10x10), got 48"},
      {"calibrate --corners " + quoted(dir / "c.vnl") +
           " --board 8 --spacing 0.05 --imagersize 1280x966 --model "
           "polynomial --out " +
           quoted(dir / "x.json"),
       "--board: expected WxH"},
      {"calibrate --corners " + quoted(dir / "c.vnl") +
           " --board 8x6 --spacing 0.05 --imagersize 1280x966 --model "
           "fisheye --out " +
           quoted(dir / "x.json"),
       "unknown model 'fisheye'"},
      {"synth-corners " + quoted(test::data_path("woodscape_front.json")) + " --boards 0 --noise 0 --seed 1 --out " +
           quoted(dir / "y.vnl"),
       "--boards"},
      {"detect-corners /no/such.png --board 8x6 --out " + quoted(dir / "d.vnl"), "/no/such.png: no such file"},
  };
  for (const auto& c : bad) {
    r = run_fishcam(c.args);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << " -> " << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.json"));
}

// mrcal's splined model through the program: synthetic corners of the spline camera
// calibrated by its mrcal name, the report listing every value with its sigma, mrcal's
// file written and read back, its uncertainty reported; a rig refuses it.
TEST(CliFit, MrcalSplineCalibratesThroughTheProgram) {
  const auto dir = test::scratch_dir("cli_spline");
  const auto [label, truth] = test::spline_camera();
  write_camera(truth, dir / "truth.json", CameraFormat::fishcam, /*overwrite=*/true);
  auto r = run_fishcam("synth-corners " + quoted(dir / "truth.json") + " --boards 25 --noise 0.1 --seed 4 --out " +
                       quoted(dir / "c.vnl"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string lensmodel = truth.mrcal_lens()->lensmodel();
  const std::string calibrate = "calibrate --corners " + quoted(dir / "c.vnl") +
                                " --board 10x10 --spacing 0.1 --imagersize 1280x966 --model " + lensmodel;
  r = run_fishcam(calibrate + " --out " + quoted(dir / "spline.cameramodel") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["plane_distortion"], "mrcal_lens");
  EXPECT_NEAR(j["rms_per_coordinate_px"].get<double>(), 0.1, 0.02);
  const size_t values = truth.mrcal_lens()->values().size();
  EXPECT_EQ(j["parameters"].size(), 1 + values + 3);
  EXPECT_EQ(j["parameters"]["f"]["sigma"].get<double>(), 0);  // the core held, as mrcal holds it
  EXPECT_GT(j["parameters"]["values[40]"]["sigma"].get<double>(), 0);
  const Camera written = read_camera(dir / "spline.cameramodel");
  ASSERT_NE(written.parameters().mrcal_lens(), nullptr);
  EXPECT_EQ(written.parameters().mrcal_lens()->lensmodel(), lensmodel);
  r = run_fishcam(calibrate + " --out " + quoted(dir / "spline.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(std::to_string(values) + " spline values in ["), std::string::npos) << r.out;
  r = run_fishcam("uncertainty " + quoted(dir / "spline.json") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_fishcam("calibrate --corners " + quoted(dir / "c.vnl") + " --corners " + quoted(dir / "c.vnl") +
                  " --board 10x10 --spacing 0.1 --imagersize 1280x966 --model " + lensmodel + " --out " +
                  quoted(dir / "rig.json"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("a rig's joint solve takes radial models only"), std::string::npos) << r.err;
}

// calibrate --report and report write the page and its figures into a folder they
// create, refuse a folder that holds other files (or an input) without --force, and
// write nothing at all when they refuse.
TEST(CliFit, ReportsGoIntoTheirOwnFolder) {
  const auto dir = test::scratch_dir("cli_report");
  auto r = run_fishcam("synth-corners " + quoted(test::data_path("woodscape_front.json")) +
                       " --boards 8 --noise 0.2 --seed 4 --board 8x6 --spacing 0.05 --out " + quoted(dir / "c.vnl") +
                       " --truth " + quoted(dir / "truth.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string calibrate = "calibrate --corners " + quoted(dir / "c.vnl") +
                                " --board 8x6 --spacing 0.05 --imagersize 1280x966 --model kannala-brandt --out ";
  r = run_fishcam(calibrate + quoted(dir / "kb.json") + " --report " + quoted(dir / "report"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto count = [](const std::filesystem::path& folder) {
    return std::distance(std::filesystem::directory_iterator(folder), std::filesystem::directory_iterator());
  };
  EXPECT_EQ(count(dir / "report"), 1 + 6 + 8);  // the page, six figures, one per image
  EXPECT_TRUE(std::filesystem::exists(dir / "report" / "uncertainty.png"));
  // A second run into the same folder: refused before anything is written.
  r = run_fishcam(calibrate + quoted(dir / "kb2.json") + " --report " + quoted(dir / "report"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("report: exists and is not empty"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "kb2.json"));
  r = run_fishcam(calibrate + quoted(dir / "kb.json") + " --report " + quoted(dir / "report") + " --force");
  EXPECT_EQ(r.exit_code, 0) << r.err;

  // From a camera file and its corners; a camera without a covariance has no map.
  const std::string report = " --corners " + quoted(dir / "c.vnl") + " --board 8x6 --spacing 0.05 --out ";
  r = run_fishcam("report " + quoted(dir / "kb.json") + report + quoted(dir / "again"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("8 images"), std::string::npos) << r.out;
  EXPECT_EQ(count(dir / "again"), 1 + 6 + 8);
  r = run_fishcam("report " + quoted(dir / "truth.json") + report + quoted(dir / "truth") + "/");  // "truth/"
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(test::read_file(dir / "truth" / "index.html").find("no sigma is estimated here"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir / "truth" / "uncertainty.png"));
  EXPECT_TRUE(std::filesystem::exists(dir / "truth" / "index.html"));

  const struct {
    std::string args, expected;
  } bad[] = {
      {"report " + quoted(dir / "kb.json") + report + quoted(dir), "contains"},  // holds the inputs
      {"report " + quoted(dir / "kb.json") + report + quoted(dir / "c.vnl"), "c.vnl"},
      {"report " + quoted(dir / "kb.json") + report + quoted(dir / "no" / "such"), "its folder does not exist"},
      {calibrate + quoted(dir / "same") + " --report " + quoted(dir / "same"), "given as more than one output"},
      {"report " + quoted(dir / "kb.json") + " --corners " + quoted(dir / "c.vnl") +
           " --board 9x6 --spacing 0.05 --out " + quoted(dir / "wrong"),
       "expected 54 corners (9x6), got 48"},
  };
  for (const auto& c : bad) {
    r = run_fishcam(c.args);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << " -> " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "wrong"));
  EXPECT_FALSE(std::filesystem::exists(dir / "same"));
}

}  // namespace
}  // namespace fishcam
