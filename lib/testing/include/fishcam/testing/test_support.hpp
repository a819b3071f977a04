// Shared test helpers: bundled data, the test cameras, scratch files, running the CLI.
#pragma once

#include <gtest/gtest.h>

#include <unistd.h>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>

#include "fishcam/core/camera.hpp"
#include "fishcam/io/camera_io.hpp"

namespace fishcam::test {

// The paths the tests use (data, shared, tmp, binary, mrcal_map_script), from
// fishcam_test_paths.txt that CMake writes beside the test programs (KEY=PATH per
// line). Read at run time, not compiled in, so that the tests' objects do not depend
// on where the tree lies (a clone elsewhere hits the compiler cache).
inline std::filesystem::path test_path(const std::string& key) {
  static const std::map<std::string, std::string> paths = [] {
    std::map<std::string, std::string> found;
    std::error_code ec;
    const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    std::ifstream in(exe.parent_path() / "fishcam_test_paths.txt");
    for (std::string line; std::getline(in, line);) {
      if (const size_t eq = line.find('='); eq != std::string::npos) found[line.substr(0, eq)] = line.substr(eq + 1);
    }
    return found;
  }();
  const auto it = paths.find(key);
  if (it == paths.end() || it->second.empty()) {
    throw std::runtime_error("test path '" + key + "' missing from fishcam_test_paths.txt beside the test program");
  }
  return it->second;
}

inline std::filesystem::path data_path(const std::string& name) { return test_path("data") / name; }
// ../shared beside the source tree (real files; tests skip without it).
inline std::filesystem::path shared_path(const std::string& name) { return test_path("shared") / name; }

// A fresh scratch folder for one test.
inline std::filesystem::path scratch_dir(const std::string& name) {
  const auto dir = test_path("tmp") / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// A path in single quotes, for shell commands (built by appending: GCC 12 warns
// falsely on "'" + string).
inline std::string quoted(const std::filesystem::path& p) {
  std::string q = "'";
  q += p.string();
  q += "'";
  return q;
}

inline std::filesystem::path write_file(const std::filesystem::path& path, const std::string& content) {
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The files below dir, relative path -> content; a symlink as "-> TARGET" (not
// followed), so a test sees a link that was written through or replaced.
inline std::map<std::string, std::string> files_below(const std::filesystem::path& dir) {
  std::map<std::string, std::string> files;
  for (auto it = std::filesystem::recursive_directory_iterator(dir);
       it != std::filesystem::recursive_directory_iterator(); ++it) {
    const std::string name = std::filesystem::relative(it->path(), dir).string();
    if (it->is_symlink()) {
      files[name] = "-> " + std::filesystem::read_symlink(it->path()).string();
    } else if (it->is_regular_file()) {
      files[name] = read_file(it->path());
    }
  }
  return files;
}

// The WoodScape front camera's public intrinsics, without pose.
inline CameraParameters woodscape_front() {
  CameraParameters p;
  p.width = 1280, p.height = 966;
  p.grid.principal_point = {1280 / 2.0 + 3.942 - 0.5, 966 / 2.0 - 3.093 - 0.5};
  p.model = Polynomial<double>({339.749, -31.988, 48.275, -7.201});
  return p;
}

inline CameraParameters with_model(CameraParameters p, RadialModel model, Eigen::Vector2d scale = {1, 1}) {
  p.model = std::move(model);
  p.grid.pixel_scale = scale;
  return p;
}

struct ModelExample {
  std::string label;
  RadialModel model;
  Eigen::Vector2d pixel_scale;
};

// Example lenses of each registry model, all about the WoodScape front camera's
// field of view on its 1280x966 image (a_x != a_y where the model allows); models
// whose valid domain ends at a pole or at a fold depending on their parameters
// have one of each. Step 3 of adding a model (lib/core/include/fishcam/core/model_registry.hpp).
inline std::vector<ModelExample> model_examples() {
  return {
      {"woodscape_polynomial", Polynomial<double>({339.749, -31.988, 48.275, -7.201}), {1.0, 1.0}},
      {"polynomial_aspect", Polynomial<double>({339.749, -31.988, 48.275, -7.201}), {1.0, 1.02}},
      {"equidistant", Equidistant<double>(340.0), {1.0, 0.99}},
      {"stereographic", Stereographic<double>(330.0), {1.0, 1.0045}},
      {"pinhole", Pinhole<double>(640.0), {1.0, 1.003}},
      {"kannala_brandt", KannalaBrandt<double>(331.5526, 0.0346514, 0.0241055, -0.0074981, 0.0007767), {1.0, 1.001}},
      {"unified_pole", Unified<double>(640.0, 0.9), {1.0, 1.002}},
      {"unified_fold", Unified<double>(1100.0, 1.6), {1.0, 0.998}},
      {"extended_unified_fold", ExtendedUnified<double>(400.0, 0.6, 1.1), {1.0, 1.001}},
      {"extended_unified_pole", ExtendedUnified<double>(340.0, 0.45, 0.9), {1.0, 1.0}},
      {"double_sphere_fold", DoubleSphere<double>(370.0, -0.18, 0.6), {1.0, 1.002}},
      {"double_sphere_pole", DoubleSphere<double>(370.0, 0.1, 0.4), {1.0, 0.999}},
      {"mei", Mei<double>(640.0, 0.9, -0.05, 0.01), {1.0, 1.001}},
      // mrcal_cam0.opencv8.cameramodel's k1..k6 (../shared/data/external), f for this image
      // as that camera's (its image reaches 3/4 of the radius of the distortion's fold).
      {"opencv_rational",
       OpenCV<double>(700.0, -0.01266096516, 0.03590794372, 0.01968883397, 0.01482863541, -0.0562239888, 0.0500223357),
       {1.0, 1.00004}},
      // ocamcalib_calib_results.txt's pol (../shared/data/external), scaled to f = 340 px
      // (its domain is open up to 180 degrees), and one whose theta(rho) turns back (a fold
      // at rho = 1208, past the image's corners).
      {"ocam",
       OCam<double>({-746.3674, 0, 8.872435e-04, -1.024379e-06, 9.406640e-10}).scaled(340 / 746.3674),
       {1.0, 1.003}},
      {"ocam_fold", OCam<double>({-340.0, 0, 1 / 1020.0, -5.0e-7, 0}), {1.0, 0.999}},
  };
}

// One camera per example, for every model of the registry: a model without an
// example fails the test that asks (so a new model cannot skip the every-model tests).
inline std::vector<std::pair<std::string, CameraParameters>> every_model() {
  const CameraParameters ws = woodscape_front();
  const auto examples = model_examples();
  std::vector<std::pair<std::string, CameraParameters>> out;
  for (std::string_view name : model_names()) {
    bool found = false;
    for (const auto& e : examples) {
      if (model_name(e.model) != name) continue;
      out.emplace_back(e.label, with_model(ws, e.model, e.pixel_scale));
      found = true;
    }
    if (!found)
      ADD_FAILURE() << "model " << name
                    << " has no example in lib/testing/include/fishcam/testing/test_support.hpp (model_examples)";
  }
  return out;
}

// Cameras that are not radially symmetric: tangential (and, on opencv, thin-prism)
// terms on the examples of every registry model with an undistorted plane (the
// models the tangential part takes), labelled EXAMPLE_tangential; a plane
// model without one fails the test that asks.
inline std::vector<std::pair<std::string, CameraParameters>> every_tangential_camera() {
  std::vector<std::pair<std::string, CameraParameters>> out;
  for (const auto& [label, p] : every_model()) {
    const bool has_plane =
        std::visit([](const auto& m) { return TakesTangentialTerms<std::decay_t<decltype(m)>>; }, p.model);
    if (!has_plane) continue;
    CameraParameters q = p;
    const std::string_view name = model_name(p.model);
    if (name == "pinhole") {
      q.distortion = TangentialDistortion{{0.001, 0.0005, {}}};
    } else if (name == "mei") {  // vinsfusion_t265_fisheye1_MEI.yaml's p1, p2
      q.distortion = TangentialDistortion{{0.00501238, 0.00039633, {}}};
    } else if (name == "opencv") {  // mrcal_cam0's p1, p2 ten times over, and thin-prism terms
      q.distortion = TangentialDistortion{{-0.002547, 0.005276, {0.001, -0.0005, -0.0008, 0.0003}}};
    } else {
      ADD_FAILURE() << "model " << name << " takes tangential terms but has no example in every_tangential_camera()";
      continue;
    }
    out.emplace_back(label + "_tangential", q);
  }
  return out;
}

// mrcal's spline on the stereographic example's plane (fishcam/core/mrcal_lens.hpp): a
// smooth displacement of up to ~0.01 (a few pixels), labelled stereographic_spline.
inline std::pair<std::string, CameraParameters> spline_camera() {
  for (auto [label, p] : every_model()) {
    if (model_name(p.model) != "stereographic") continue;
    constexpr int nx = 8, ny = 6;
    std::vector<double> values;
    for (int y = 0; y < ny; ++y) {
      for (int x = 0; x < nx; ++x) {
        values.push_back(0.004 * std::cos(0.7 * x + 0.3 * y) + 0.001 * x);
        values.push_back(0.003 * std::sin(0.5 * x - 0.9 * y) - 0.0015 * y);
      }
    }
    p.distortion =
        MrcalLensDistortion::from_numbers("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=150", values);
    return {label + "_spline", p};
  }
  ADD_FAILURE() << "no stereographic example for the spline camera";
  return {};
}

// One camera per mrcal lens model (MrcalLens::kinds(): fishcam/core/mrcal_lens.hpp) on its
// base model's example, labelled base_lensmodel: the spline camera, CAHVOR with a tilted
// axis and radial terms on the pinhole example, CAHVORE with E terms too, LONLAT and
// LATLON on a stereographic one with f = 560.
inline std::vector<std::pair<std::string, CameraParameters>> mrcal_lens_cameras() {
  std::vector<std::pair<std::string, CameraParameters>> out;
  for (const MrcalLens::KindInfo& kind : MrcalLens::kinds()) {
    if (kind.kind == MrcalLens::Kind::splined_stereographic) {
      out.push_back(spline_camera());
      continue;
    }
    std::vector<double> values;
    std::string name = kind.lensmodel;
    if (kind.kind == MrcalLens::Kind::cahvor) values = {0.03, -0.02, 0.01, -0.05, 0.01};
    if (kind.kind == MrcalLens::Kind::cahvore) values = {0.03, -0.02, 0.01, -0.05, 0.01, 0.2, 0.05, -0.03};
    const std::string label_name = name.substr(std::string("LENSMODEL_").size());
    if (kind.kind == MrcalLens::Kind::cahvore) name += "_linearity=0.50";
    bool found = false;
    for (auto [label, p] : every_model()) {
      if (model_name(p.model) != kind.base_model || found) continue;
      // LONLAT's and LATLON's domains end at their poles (theta = 90 deg): the image well
      // inside them (65 and 49 deg from the axis at the sides): the kernel's table holds there.
      if (kind.base_model == std::string_view("stereographic")) p.model = Stereographic<double>(560.0);
      p.distortion = MrcalLensDistortion{std::make_shared<const MrcalLens>(name, values)};
      out.emplace_back(label + "_" + label_name, p);
      found = true;
    }
    if (!found) ADD_FAILURE() << kind.lensmodel << " has no example of its base model " << kind.base_model;
  }
  return out;
}

// Whether the float warp kernel can evaluate the camera: a model with the unified
// form, polynomial in theta or with a ray polynomial (an mrcal lens rides on a
// stereographic or pinhole model: its cells or its table, augmentation.cpp).
inline bool float_kernel_form(const CameraParameters& p) {
  const bool form = std::visit(
      [](const auto& m) {
        using M = std::decay_t<decltype(m)>;
        return HasUnifiedForm<M> || PolynomialInTheta<M> || HasRayPolynomial<M>;
      },
      p.model);
  return form;  // mrcal's lenses too: the spline's cells, the others' tables
}

// The ocam example with ocamcalib_calib_results.txt's affine as its pixel skew
// (CameraParameters::skew: a = (1, c), xy = e, yx = d / c), labelled ocam_skew.
inline std::pair<std::string, CameraParameters> skewed_camera() {
  for (auto [label, p] : every_model()) {
    if (label != "ocam") continue;
    p.grid.pixel_scale.y() = 0.996974;
    p.grid.skew = {0.013102, -0.014257 / 0.996974};
    return {label + "_skew", p};
  }
  ADD_FAILURE() << "no ocam example for the skewed camera";
  return {};
}

// Every camera kind: every_model(), every_tangential_camera(), mrcal_lens_cameras() and
// skewed_camera(), for the tests of what any camera does (project, unproject, formats,
// the float kernel and the grid path).
inline std::vector<std::pair<std::string, CameraParameters>> every_camera() {
  auto out = every_model();
  for (auto& c : every_tangential_camera()) out.push_back(std::move(c));
  for (auto& c : mrcal_lens_cameras()) out.push_back(std::move(c));
  out.push_back(skewed_camera());
  return out;
}

// Parameterised every-model tests: INSTANTIATE_TEST_SUITE_P(..., ValuesIn(every_model()),
// model_case_name) gives each example its own test, named by its label.
using ModelCase = std::pair<std::string, CameraParameters>;
inline std::string model_case_name(const ::testing::TestParamInfo<ModelCase>& info) { return info.param.first; }

// The cameras of every_camera() whose plane distortion (fishcam/core/plane_distortion.hpp)
// is the registered part `name` and displaces something (for "none": the radial ones).
// A registered part without an example fails the test that asks: add one to every_camera().
inline std::vector<ModelCase> distortion_examples(std::string_view name) {
  std::vector<ModelCase> out;
  for (auto& [label, p] : every_camera()) {
    if (numbers_of(p.distortion).name == name) out.emplace_back(label, p);
  }
  if (out.empty()) ADD_FAILURE() << "plane distortion " << name << " has no example in every_camera()";
  return out;
}

// Uniformly distributed unit vectors with theta in [0, theta_max].
inline std::vector<Eigen::Vector3d> random_rays(size_t n, double theta_max, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Eigen::Vector3d> rays;
  const double z_min = std::cos(theta_max);
  while (rays.size() < n) {
    const double z = 1 - uniform(rng) * (1 - z_min), phi = 2 * M_PI * uniform(rng);
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    rays.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return rays;
}

// Angle between two directions, accurate for tiny angles.
inline double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

#ifdef FISHCAM_HAS_CLI
// The fishcam program under test.
inline std::string fishcam_binary() { return test_path("binary").string(); }

struct CommandResult {
  int exit_code;
  std::string out, err;
};

// Runs `fishcam ARGS` with STDIN as its standard input.
inline CommandResult run_fishcam(const std::string& args, const std::string& stdin_text = "") {
  // One folder per process and call: CTest runs the tests in parallel.
  static int calls = 0;
  const auto dir = test_path("tmp") / ("cli-" + std::to_string(::getpid()) + "-" + std::to_string(calls++));
  std::filesystem::create_directories(dir);
  const auto in = write_file(dir / "stdin.txt", stdin_text), out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string command = "'" + fishcam_binary() + "' " + args + " < '" + in.string() + "' > '" + out.string() +
                              "' 2> '" + err.string() + "'";
  const int status = std::system(command.c_str());
  CommandResult result{WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_file(out), read_file(err)};
  std::filesystem::remove_all(dir);
  return result;
}

// A test of the fishcam program with a scratch folder of its own (dir_: PREFIX and
// the test's name) and the checks the file-safety tests share.
class CliTest : public ::testing::Test {
 protected:
  explicit CliTest(std::string prefix = "") : prefix_(std::move(prefix)) {}
  void SetUp() override {
    dir_ = scratch_dir(prefix_ + ::testing::UnitTest::GetInstance()->current_test_info()->name());
  }
  // A small WoodScape-layout dataset at dir_/NAME (fishcam sample-dataset).
  std::filesystem::path dataset(const std::string& name, int images = 2) {
    const auto root = dir_ / name;
    const auto r = run_fishcam("sample-dataset " + quoted(root) + " --images " + std::to_string(images) +
                               " --seed 1 --size 64x48");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return root;
  }
  // Refused in one line containing `expected`; `watched` (a folder or file) unchanged.
  void expect_refused(const std::string& args, const std::string& expected, const std::filesystem::path& watched) {
    const bool is_folder = std::filesystem::is_directory(watched);
    const auto before = is_folder ? files_below(watched) : std::map<std::string, std::string>{};
    const bool existed = std::filesystem::exists(watched);
    const auto r = run_fishcam(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_NE(r.err.find(expected), std::string::npos) << args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(std::filesystem::exists(watched), existed) << watched;
    if (is_folder) {
      EXPECT_TRUE(files_below(watched) == before) << args << ": " << watched << " changed";
    }
  }
  std::string prefix_;
  std::filesystem::path dir_;
};
#endif

}  // namespace fishcam::test

namespace fishcam {
// How GoogleTest shows a camera in a failing parameterised test.
inline void PrintTo(const CameraParameters& p, std::ostream* out) {
  *out << model_name(p.model) << " " << p.width << "x" << p.height;
}
}  // namespace fishcam
