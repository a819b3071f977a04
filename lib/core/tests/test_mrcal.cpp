// Agreement with libmrcal's C API (mrcal_project / mrcal_unproject) for the lens
// models both libraries have (pinhole, stereographic, OPENCV8 as `opencv` with its
// tangential terms), with fx != fy, behind the camera too for stereographic.
extern "C" {  // mrcal 2.2's headers have no extern "C" of their own
#include <mrcal/mrcal.h>
}

#include "fishcam/fit/fit.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

struct Case {
  const char* file;  // a camera of data/, or a label
  mrcal_lensmodel_type_t type;
  double theta_max;                             // where to draw test rays
  std::optional<Camera> camera = std::nullopt;  // instead of the file
  std::vector<double> distortion = {};          // mrcal's intrinsics after fx, fy, cx, cy
  std::string configured = {};                  // an mrcal lens's name (then it decides the type)
  double project_px = 1e-9;                     // ours against mrcal_project
  double mrcal_unproject_px = 1e-6;             // mrcal's own iterative unprojection, reprojected
  bool mrcal_unprojects = true;                 // mrcal_unproject takes the model (not CAHVORE)
};

void check_against_mrcal(const Case& c) {
  const Camera camera = c.camera ? *c.camera : read_camera(test::data_path(c.file));
  const double f = model_params(camera.model())[0];
  std::vector<double> intrinsics = {f * camera.pixel_scale().x(), f * camera.pixel_scale().y(),
                                    camera.principal_point().x(), camera.principal_point().y()};
  intrinsics.insert(intrinsics.end(), c.distortion.begin(), c.distortion.end());
  ASSERT_NE(intrinsics[0], intrinsics[1]) << "the test needs fx != fy";
  mrcal_lensmodel_t lensmodel{};
  lensmodel.type = c.type;
  if (!c.configured.empty()) {  // the name decides
    ASSERT_TRUE(mrcal_lensmodel_from_name(&lensmodel, c.configured.c_str()));
  }

  const auto rays = test::random_rays(20000, c.theta_max, 31);
  std::vector<mrcal_point3_t> points(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    const Eigen::Vector3d p = (0.5 + double(i % 7)) * rays[i];  // any distance
    points[i] = {{p.x(), p.y(), p.z()}};
  }
  std::vector<mrcal_point2_t> expected(points.size());
  ASSERT_TRUE(mrcal_project(expected.data(), nullptr, nullptr, points.data(), int(points.size()), &lensmodel,
                            intrinsics.data()));
  double worst_project = 0, worst_unproject = 0, worst_mrcal_unproject = 0, widest = 0;
  int mrcal_failed = 0;
  std::vector<mrcal_point3_t> mrcal_rays(points.size(), mrcal_point3_t{{NAN, NAN, NAN}});
  if (c.mrcal_unprojects) {
    ASSERT_TRUE(
        mrcal_unproject(mrcal_rays.data(), expected.data(), int(expected.size()), &lensmodel, intrinsics.data()));
  }
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p(points[i].x, points[i].y, points[i].z);
    const Eigen::Vector2d q(expected[i].x, expected[i].y);
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera.project(p, &pixel)) << p.transpose();
    worst_project = std::max(worst_project, (pixel - q).norm());
    // Unprojection: both rays, projected back through the same (mrcal's) model, land on the pixel.
    Eigen::Vector3d ray;
    ASSERT_TRUE(camera.unproject(q, &ray));
    const mrcal_point3_t ours = {{ray.x(), ray.y(), ray.z()}};
    mrcal_point2_t q_ours, q_theirs;
    ASSERT_TRUE(mrcal_project(&q_ours, nullptr, nullptr, &ours, 1, &lensmodel, intrinsics.data()));
    worst_unproject = std::max(worst_unproject, std::hypot(q_ours.x - q.x(), q_ours.y - q.y()));
    widest = std::max(widest, std::acos(ray.z()));
    const Eigen::Vector3d theirs(mrcal_rays[i].x, mrcal_rays[i].y, mrcal_rays[i].z);
    if (!c.mrcal_unprojects) continue;
    if (!theirs.allFinite()) {  // mrcal's iterative unprojection gave up (far out on a real OPENCV8)
      ++mrcal_failed;
      continue;
    }
    ASSERT_TRUE(mrcal_project(&q_theirs, nullptr, nullptr, &mrcal_rays[i], 1, &lensmodel, intrinsics.data()));
    worst_mrcal_unproject = std::max(worst_mrcal_unproject, std::hypot(q_theirs.x - q.x(), q_theirs.y - q.y()));
    // mrcal's iterative unprojection of OPENCV8 stops at ~1e-7 px (a few 1e-9 rad); its
    // closed forms are exact. Ours reprojects onto the pixel in every case.
    EXPECT_LT(test::angle_between(ray, theirs.normalized()), c.distortion.empty() ? 1e-12 : 1e-8);
  }
  // Only where mrcal's own solver stops: never on the closed-form models (photonvision's OPENCV8: 3.4 % of the
  // rays up to 63 deg, all of which ours unprojects).
  EXPECT_LE(mrcal_failed, c.distortion.empty() ? 0 : int(points.size() / 20)) << c.file;
  EXPECT_LE(worst_project, c.project_px) << c.file;
  EXPECT_LE(worst_unproject, c.project_px) << c.file;
  EXPECT_LE(worst_mrcal_unproject, c.distortion.empty() ? 1e-9 : c.mrcal_unproject_px) << c.file;
  std::printf(
      "  %s: %zu points up to %.1f deg, worst project %.2e px, unproject %.2e px (mrcal's own: %.2e px, "
      "no ray for %d)\n",
      c.file, points.size(), widest * 180 / M_PI, worst_project, worst_unproject, worst_mrcal_unproject, mrcal_failed);
}

TEST(Mrcal, StereographicAgreesWithLibmrcalBehindTheCameraToo) {
  check_against_mrcal({"stereographic.cameramodel", MRCAL_LENSMODEL_STEREOGRAPHIC, 170 * M_PI / 180});
}

TEST(Mrcal, PinholeAgreesWithLibmrcal) {
  check_against_mrcal({"pinhole.cameramodel", MRCAL_LENSMODEL_PINHOLE, 80 * M_PI / 180});
}

// mrcal_cam0.opencv8.cameramodel's k1..k6 (../shared/data/external) with its tangential terms zero.
CameraParameters opencv8_camera() {
  CameraParameters p;
  p.width = 3840, p.height = 2160, p.grid.principal_point = {1965.706996, 1087.518797};
  p.grid.pixel_scale = {1.0, 1761.250444 / 1761.181055};
  p.model = OpenCV<double>(1761.181055, -0.01266096516, 0.03590794372, 0.01968883397, 0.01482863541, -0.0562239888,
                           0.0500223357);
  return p;
}

TEST(Mrcal, OpenCV8WithoutTangentialTermsAgreesWithLibmrcal) {
  const Camera camera(opencv8_camera());
  const auto k = model_params(camera.model());
  check_against_mrcal({"opencv8",
                       MRCAL_LENSMODEL_OPENCV8,
                       std::min(camera.domain().theta_max * 0.999, 80 * M_PI / 180),
                       camera,
                       {k[1], k[2], 0, 0, k[3], k[4], k[5], k[6]}});
}

// A stereographic camera with mrcal's spline (fishcam/core/mrcal_lens.hpp), projected and
// unprojected against libmrcal's own LENSMODEL_SPLINED_STEREOGRAPHIC: the synthetic
// one of the tests, and the real cam0.splined of ../shared (read by our reader and by
// libmrcal's).
TEST(Mrcal, SplinedStereographicAgreesWithLibmrcal) {
  const Camera synthetic(test::spline_camera().second);
  const MrcalLens& spline = *synthetic.parameters().mrcal_lens();
  ASSERT_GT(synthetic.domain().theta_max, 60 * M_PI / 180);
  check_against_mrcal({"spline (synthetic)", MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC, 60 * M_PI / 180, synthetic,
                       spline.values(), spline.lensmodel()});
  const std::filesystem::path file = test::shared_path("data/external/mrcal_cam0.splined.cameramodel");
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "no ../shared checkout";
  const Camera camera = read_camera(file.string());
  mrcal_cameramodel_t* model = mrcal_read_cameramodel_file(file.c_str());
  ASSERT_NE(model, nullptr);
  ASSERT_EQ(model->lensmodel.type, MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC);
  const int n = mrcal_lensmodel_num_params(&model->lensmodel);
  const std::vector<double> values(model->intrinsics + 4, model->intrinsics + n);
  EXPECT_EQ(model->intrinsics[0], model_params(camera.model())[0]);
  EXPECT_EQ(values, camera.parameters().mrcal_lens()->values());
  mrcal_free_cameramodel(&model);
  check_against_mrcal({"mrcal_cam0.splined.cameramodel", MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC,
                       camera.domain().theta_max, camera, values, camera.parameters().mrcal_lens()->lensmodel()});
}

// Every mrcal lens model fishcam evaluates (MrcalLens::kinds()), on its base model's
// example, projected and unprojected against libmrcal's own model of that name.
class EveryMrcalLens : public ::testing::TestWithParam<test::ModelCase> {};

TEST_P(EveryMrcalLens, AgreesWithLibmrcal) {
  const Camera camera(GetParam().second);
  const MrcalLens& lens = *camera.parameters().mrcal_lens();
  const double theta_max = camera.domain().theta_max;
  if (lens.kind() == MrcalLens::Kind::lonlat || lens.kind() == MrcalLens::Kind::latlon) {
    // The domain is a disk about the axis; these charts are singular at their poles (theta = 90 deg).
    EXPECT_GT(theta_max, 89.9 * M_PI / 180);
    EXPECT_LE(theta_max, M_PI / 2);
    EXPECT_EQ(camera.domain().limited_by, ValidDomain::Limit::distortion_fold);
  } else {
    EXPECT_GT(theta_max, 60 * M_PI / 180);
  }
  mrcal_lensmodel_t model{};
  ASSERT_TRUE(mrcal_lensmodel_from_name(&model, lens.lensmodel().c_str()));
  if (!mrcal_lensmodel_metadata(&model).can_project_behind_camera) {  // CAHVOR(E): none behind the camera
    EXPECT_LE(theta_max, M_PI / 2);
  }
  Case c{GetParam().first.c_str(),
         MRCAL_LENSMODEL_PINHOLE,
         std::min(theta_max * 0.999, 85 * M_PI / 180),
         camera,
         lens.values(),
         lens.lensmodel()};
  if (lens.kind() == MrcalLens::Kind::cahvor || lens.kind() == MrcalLens::Kind::cahvore) {
    // libmrcal's CAHVOR is not scale-invariant to rounding: the same ray at 0.5 and 6.5
    // times its length projects 1.3e-8 px apart at 80 deg (f = 640). Its iterative
    // unprojection stops 2.7e-4 px short there (3 of 20000 rays: none).
    c.project_px = 5e-8, c.mrcal_unproject_px = 1e-3;
    c.mrcal_unprojects = lens.kind() == MrcalLens::Kind::cahvor;  // mrcal_unproject refuses CAHVORE
  }
  check_against_mrcal(c);
}

INSTANTIATE_TEST_SUITE_P(Mrcal, EveryMrcalLens, ::testing::ValuesIn(test::mrcal_lens_cameras()), test::model_case_name);

TEST(Mrcal, EveryLensKindHasAnExample) {
  EXPECT_EQ(test::mrcal_lens_cameras().size(), MrcalLens::kinds().size());
  EXPECT_EQ(MrcalLens::kinds().size(), 5u);
}

// CAHVORE is noncentral by definition, but libmrcal's projection of it depends on the
// direction only (what fishcam evaluates, fishcam/core/mrcal_lens.hpp): the same ray from
// 1e-2 to 1e6 units away projects to the same pixel.
TEST(Mrcal, LibmrcalProjectsCahvoreByDirectionOnly) {
  mrcal_lensmodel_t cahvore{};
  ASSERT_TRUE(mrcal_lensmodel_from_name(&cahvore, "LENSMODEL_CAHVORE_linearity=0.50"));
  std::vector<double> intrinsics = {420, 421.7, 636.5, 485, 0.03, -0.02, 0.01, -0.05, 0.01, 1.2, 0.5, -0.3};
  int checked = 0;
  for (const Eigen::Vector3d& ray : test::random_rays(200, 70 * M_PI / 180, 5)) {
    std::vector<mrcal_point2_t> q;
    for (double d : {1e-2, 1.0, 1e6}) {
      const mrcal_point3_t p = {{d * ray.x(), d * ray.y(), d * ray.z()}};
      q.emplace_back();
      ASSERT_TRUE(mrcal_project(&q.back(), nullptr, nullptr, &p, 1, &cahvore, intrinsics.data()));
    }
    for (const auto& other : q) EXPECT_LE(std::hypot(other.x - q[1].x, other.y - q[1].y), 1e-9);
    ++checked;
  }
  EXPECT_EQ(checked, 200);
}

// MrcalLens::polynomial_cells says where mrcal's spline is one polynomial (the float
// warp kernel evaluates it per cell): along x and y inside a cell, and from inside an
// outer cell out past the grid (mrcal extrapolates it), the (order + 1)-th finite
// difference of delta_u vanishes; across a cell boundary it does not (so a grid off
// by any fraction of a cell fails). Cubic and quadratic splines of the same values.
TEST(Mrcal, SplineIsOnePolynomialOnEachOfItsCells) {
  const CameraParameters example = test::spline_camera().second;  // keeps the spline alive
  const MrcalLens& cubic = *example.mrcal_lens();
  int cases = 0;
  for (const char* lensmodel : {"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=150",
                                "LENSMODEL_SPLINED_STEREOGRAPHIC_order=2_Nx=8_Ny=6_fov_x_deg=150"}) {
    const MrcalLens spline(lensmodel, cubic.values());
    ASSERT_TRUE(spline.polynomial_cells());
    const MrcalLens::PolynomialCells cells = *spline.polynomial_cells();
    ASSERT_EQ(cells.order, spline.lensmodel().find("order=3") != std::string::npos ? 3 : 2);
    EXPECT_EQ(cells.nx, cells.order == 3 ? 5 : 6) << lensmodel;
    EXPECT_EQ(cells.ny, cells.order == 3 ? 3 : 4) << lensmodel;
    // The (order + 1)-th difference of delta_u at order + 2 points g + k step, k = 0 ..
    const auto difference = [&](Eigen::Vector2d g, const Eigen::Vector2d& step) {
      Eigen::Vector2d sum = Eigen::Vector2d::Zero();
      const int n = cells.order + 1;
      double binomial = 1;
      for (int k = 0; k <= n; ++k) {
        sum += ((n - k) % 2 ? -1.0 : 1.0) * binomial * spline.offset((g + k * step - cells.origin) / cells.cells_per_u);
        binomial = binomial * (n - k) / (k + 1);
      }
      return sum.cwiseAbs().maxCoeff();
    };
    double inside = 0, outside = 0, across = 0;
    for (int j = 0; j < cells.ny; ++j) {
      for (int i = 0; i < cells.nx; ++i) {
        const double h = 0.9 / (cells.order + 1);
        const Eigen::Vector2d g(i + 0.05, j + 0.37);
        inside = std::max({inside, difference(g, {h, 0}), difference({i + 0.61, j + 0.05}, {0, h})});
        // Across the boundary to the next cell, whose polynomial differs.
        if (i + 1 < cells.nx) across = std::max(across, difference({i + 0.5, j + 0.5}, {0.5, 0}));
      }
    }
    // Past the grid on every side, from inside the outer cells.
    for (double y : {0.3, cells.ny - 0.6}) outside = std::max(outside, difference({cells.nx - 0.5, y}, {0.8, 0}));
    for (double y : {0.3, cells.ny - 0.6}) outside = std::max(outside, difference({0.5, y}, {-0.8, 0}));
    for (double x : {0.4, cells.nx - 0.7}) outside = std::max(outside, difference({x, cells.ny - 0.5}, {0, 0.8}));
    for (double x : {0.4, cells.nx - 0.7}) outside = std::max(outside, difference({x, 0.5}, {0, -0.8}));
    EXPECT_LE(inside, 1e-14) << lensmodel;
    EXPECT_LE(outside, 1e-13) << lensmodel;
    EXPECT_GT(across, 1e-6) << lensmodel;
    ++cases;
  }
  EXPECT_EQ(cases, 2);
}

// Converting a splined camera to a radial model (the case: mrcal's splined
// calibration to a WoodScape polynomial): the report is reproduced by libmrcal's
// projection of the source and the polynomial's formula for the result.
TEST(Mrcal, ConvertingASplinedCameraReportsWhatLibmrcalAndThePolynomialFind) {
  const Camera source(resized(test::spline_camera().second, 320, 242));
  const Conversion conversion = convert_camera(source, parse_model_spec("polynomial:4"));
  EXPECT_TRUE(conversion.center_and_aspect_fitted);
  EXPECT_FALSE(conversion.camera.mrcal_lens());
  const auto samples = sample_image(source, 2, 0);
  ASSERT_EQ(conversion.report.samples, long(samples.size()));
  const MrcalLens& spline = *source.parameters().mrcal_lens();
  mrcal_lensmodel_t lensmodel{};
  ASSERT_TRUE(mrcal_lensmodel_from_name(&lensmodel, spline.lensmodel().c_str()));
  const double f = model_params(source.model())[0];
  std::vector<double> intrinsics = {f * source.pixel_scale().x(), f * source.pixel_scale().y(),
                                    source.principal_point().x(), source.principal_point().y()};
  intrinsics.insert(intrinsics.end(), spline.values().begin(), spline.values().end());
  const auto k = model_params(conversion.camera.model);
  const Eigen::Vector2d c = conversion.camera.grid.principal_point, a = conversion.camera.grid.pixel_scale;
  double sum2 = 0, worst = 0;
  for (const auto& s : samples) {
    const mrcal_point3_t p = {{s.ray.x(), s.ray.y(), s.ray.z()}};
    mrcal_point2_t q;
    ASSERT_TRUE(mrcal_project(&q, nullptr, nullptr, &p, 1, &lensmodel, intrinsics.data()));
    // WoodScape's polynomial: rho = k1 theta + ... + k4 theta^4 along the ray's azimuth.
    const double chi = s.ray.head<2>().norm(), theta = std::atan2(chi, s.ray.z());
    const double rho = theta * (k[0] + theta * (k[1] + theta * (k[2] + theta * k[3])));
    const Eigen::Vector2d ours = chi > 0 ? Eigen::Vector2d(c + a.cwiseProduct(s.ray.head<2>()) * (rho / chi)) : c;
    const double e = (ours - Eigen::Vector2d(q.x, q.y)).norm();
    sum2 += e * e, worst = std::max(worst, e);
  }
  EXPECT_NEAR(std::sqrt(sum2 / double(samples.size())), conversion.report.rms_px, 1e-6);
  EXPECT_NEAR(worst, conversion.report.max_px, 1e-6);
  EXPECT_GT(conversion.non_radial.rms_px, 0.1);
  EXPECT_LE(conversion.non_radial.rms_px, conversion.report.rms_px);
  std::printf(
      "  spline -> polynomial:4: rms %.4f px, max %.4f px (libmrcal and the formula: the same); floor %.4f px\n",
      conversion.report.rms_px, conversion.report.max_px, conversion.non_radial.rms_px);
}

// The real OPENCV8 calibrations of ../shared (tangential terms and all), read by our
// reader and by libmrcal's own, against mrcal_project / mrcal_unproject.
TEST(Mrcal, RealOpenCV8FilesAgreeWithLibmrcal) {
  const std::filesystem::path external = test::shared_path("data/external");
  if (!std::filesystem::exists(external / "README.md")) GTEST_SKIP() << "no ../shared checkout";
  struct File {
    const char* name;
    double theta_max_deg;  // inside the valid domain, where pixels stay within ~1e4 px (1e-9 px is a double's reach)
  };
  int checked = 0;
  for (const File& file : {File{"mrcal_cam0.opencv8.cameramodel", 61}, File{"mrcal_figueroa_opencv8-0.cameramodel", 70},
                           File{"photonvision_camera-0.cameramodel", 63}}) {
    const std::string path = (external / file.name).string();
    const Camera camera = read_camera(path);
    ASSERT_FALSE(camera.radial()) << file.name;
    mrcal_cameramodel_t* model = mrcal_read_cameramodel_file(path.c_str());
    ASSERT_NE(model, nullptr) << path;
    ASSERT_EQ(model->lensmodel.type, MRCAL_LENSMODEL_OPENCV8);
    EXPECT_EQ(model->intrinsics[0], model_params(camera.model())[0]);
    EXPECT_EQ(model->intrinsics[2], camera.principal_point().x());
    const std::vector<double> distortion(model->intrinsics + 4, model->intrinsics + 12);
    mrcal_free_cameramodel(&model);
    ASSERT_GE(camera.domain().theta_max, file.theta_max_deg * M_PI / 180) << file.name;
    check_against_mrcal({file.name, MRCAL_LENSMODEL_OPENCV8, file.theta_max_deg * M_PI / 180, camera, distortion});
    ++checked;
  }
  EXPECT_EQ(checked, 3);
}

TEST(Mrcal, LibmrcalReadsOurCameramodelFiles) {
  for (const char* name : {"stereographic.cameramodel", "pinhole.cameramodel", "opencv8"}) {
    CameraParameters p =
        name == std::string("opencv8") ? opencv8_camera() : read_camera(test::data_path(name)).parameters();
    p.pose = Pose{Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                  Eigen::Vector3d(0.1, -0.2, 1.5)};
    const std::string text = format_camera(p, CameraFormat::mrcal);
    mrcal_cameramodel_t* model = mrcal_read_cameramodel_string(text.c_str(), int(text.size()));
    ASSERT_NE(model, nullptr) << text;
    const double f = model_params(p.model)[0];
    EXPECT_EQ(model->intrinsics[0], f * p.grid.pixel_scale.x());
    EXPECT_EQ(model->intrinsics[1], f * p.grid.pixel_scale.y());
    EXPECT_EQ(model->intrinsics[2], p.grid.principal_point.x());
    EXPECT_EQ(model->imagersize[0], unsigned(p.width));
    if (const auto* m = std::get_if<OpenCV<double>>(&p.model)) {
      EXPECT_EQ(model->lensmodel.type, MRCAL_LENSMODEL_OPENCV8);
      const auto k = m->params();
      const double expected[8] = {k[1], k[2], 0, 0, k[3], k[4], k[5], k[6]};
      for (int i = 0; i < 8; ++i) EXPECT_EQ(model->intrinsics[4 + i], expected[i]) << i;
    }
    // rt_cam_ref maps reference points into the camera: p_cam = R p_ref + t.
    const Eigen::Vector3d r(model->rt_cam_ref[0], model->rt_cam_ref[1], model->rt_cam_ref[2]);
    const Eigen::Vector3d t(model->rt_cam_ref[3], model->rt_cam_ref[4], model->rt_cam_ref[5]);
    const Eigen::Vector3d p_ref(2, -1, 7);
    const Eigen::Vector3d p_cam = Eigen::AngleAxisd(r.norm(), r.normalized()) * p_ref + t;
    EXPECT_LT((p.pose->rotation * p_cam + p.pose->translation - p_ref).norm(), 1e-14);
    mrcal_free_cameramodel(&model);
  }
}

}  // namespace
}  // namespace fishcam
