// Model fitting and conversion: exact recovery, honest error reports, OpenCV
// round trips, the paper's formulas, bad input.
#include <opencv2/calib3d.hpp>

#include <random>

#include "fishcam/fit/fit.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

Camera woodscape() { return read_camera(test::data_path("woodscape_front.json")); }

ModelSpec spec_of(const RadialModel& m) {
  ModelSpec s{std::string(model_name(m))};
  if (const auto* p = std::get_if<Polynomial<double>>(&m)) s.order = p->order();
  return s;
}

// Noise-free data recovers every model exactly, one test per model: the model
// alone, then with the principal point and aspect freed from a wrong start.
class EveryModel : public ::testing::TestWithParam<test::ModelCase> {};

TEST_P(EveryModel, NoiseFreeDataRecoversTheModelExactly) {
  const CameraParameters& truth = GetParam().second;
  const Camera camera(truth);
  const bool pinhole = model_name(truth.model) == "pinhole";
  const auto samples = sample_image(camera, 7, 3, pinhole ? std::optional(1.2) : std::nullopt);
  ASSERT_GT(samples.size(), 10000u);
  // Start from a wrong principal point and aspect when those are fitted.
  CameraParameters start = truth;
  start.model = Equidistant<double>(100.0);
  const CameraParameters fixed = fit_camera(samples, spec_of(truth.model), start);
  const auto expected = model_params(truth.model), got = model_params(fixed.model);
  ASSERT_EQ(expected.size(), got.size());
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_NEAR(got[i], expected[i], 1e-6 * std::abs(expected[i]) + 1e-9) << "parameter " << i;
  }
  start.grid.principal_point += Eigen::Vector2d(2.5, -1.5);
  start.grid.pixel_scale.y() *= 1.01;
  const CameraParameters freed = fit_camera(samples, spec_of(truth.model), start, {true, true});
  EXPECT_LT((freed.grid.principal_point - truth.grid.principal_point).norm(), 1e-6);
  EXPECT_NEAR(freed.grid.pixel_scale.y(), truth.grid.pixel_scale.y(), 1e-9);
  const auto refit = model_params(freed.model);
  for (size_t i = 0; i < refit.size(); ++i) {
    EXPECT_NEAR(refit[i], expected[i], 1e-6 * std::abs(expected[i]) + 1e-8) << "parameter " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Fit, EveryModel, ::testing::ValuesIn(test::every_model()), test::model_case_name);

TEST(Fit, WoodScapeConversionsReportWhatTheyCostOnFreshPixels) {
  const Camera source = woodscape();
  const auto fit_samples = sample_image(source, 4, 1);
  // A fresh set: random sub-pixel positions the fit never saw.
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-0.5, source.width() - 0.5), v(-0.5, source.height() - 0.5);
  std::vector<Correspondence> fresh;
  while (fresh.size() < 200000) {
    const Eigen::Vector2d pixel(u(rng), v(rng));
    Eigen::Vector3d ray;
    if (source.unproject(pixel, &ray)) fresh.push_back({ray, pixel});
  }
  const struct {
    const char* model;
    double rms_below, rms_above;  // the expected error range, px
  } cases[] = {{"kannala-brandt", 0.10, 0.20},
               {"equidistant", 15, 25},
               {"stereographic", 15, 25},
               {"polynomial:4", 0, 1e-9},
               {"polynomial:3", 0.1, 5}};
  for (const auto& c : cases) {
    const Camera fitted(fit_camera(fit_samples, parse_model_spec(c.model), source.parameters()));
    const ErrorReport reported = reprojection_errors(fitted, sample_image(source, 2, 0));
    const ErrorReport again = reprojection_errors(fitted, fresh);
    EXPECT_GE(reported.rms_px, c.rms_below) << c.model;
    EXPECT_LE(reported.rms_px, c.rms_above) << c.model;
    EXPECT_NEAR(again.rms_px, reported.rms_px, 0.02 * reported.rms_px + 1e-9) << c.model;
    EXPECT_NEAR(again.p99_px, reported.p99_px, 0.05 * reported.p99_px + 1e-9) << c.model;
    EXPECT_LE(again.max_px, 1.05 * reported.max_px + 1e-9) << c.model;
    EXPECT_EQ(reported.unprojectable, 0) << c.model;
    long binned = 0;
    for (const auto& b : reported.by_angle) binned += b.samples;
    EXPECT_EQ(binned, reported.samples);
  }
}

TEST(Fit, KannalaBrandtAsOpenCVYamlWorksWithCvFisheye) {
  const Camera source = woodscape();
  const CameraParameters kb =
      fit_camera(sample_image(source, 4, 1), parse_model_spec("kannala-brandt"), source.parameters());
  const auto dir = test::scratch_dir("fit_opencv");
  write_camera(kb, dir / "kb.yaml", CameraFormat::opencv);
  // Read back with cv::FileStorage itself, as an OpenCV user would.
  cv::FileStorage fs((dir / "kb.yaml").string(), cv::FileStorage::READ);
  cv::Mat K, D;
  fs["K"] >> K;
  fs["D"] >> D;
  ASSERT_EQ(K.size(), cv::Size(3, 3));
  ASSERT_EQ(D.total(), 4u);
  const ErrorReport report = reprojection_errors(Camera(kb), sample_image(source, 2, 0));
  // Every source pixel below 90 deg, through cv::fisheye::projectPoints.
  const auto samples = sample_image(source, 3, 0, M_PI / 2 - 1e-3);
  std::vector<cv::Vec3d> points;
  for (const auto& s : samples) points.emplace_back(s.ray.x(), s.ray.y(), s.ray.z());
  std::vector<cv::Vec2d> projected;
  cv::fisheye::projectPoints(points, projected, cv::Vec3d::zeros(), cv::Vec3d::zeros(), K, D);
  double worst = 0, sum2 = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const double e = std::hypot(projected[i][0] - samples[i].pixel.x(), projected[i][1] - samples[i].pixel.y());
    worst = std::max(worst, e);
    sum2 += e * e;
  }
  EXPECT_LE(worst, report.max_below_90_px + 1e-6);
  EXPECT_NEAR(std::sqrt(sum2 / double(samples.size())), report.rms_below_90_px, 0.02 * report.rms_below_90_px);
}

TEST(Fit, WoodScapeFishcamWoodScapeRoundTripIsExact) {
  const auto dir = test::scratch_dir("fit_roundtrip");
  const CameraParameters original = woodscape().parameters();
  write_camera(original, dir / "cam.json", CameraFormat::fishcam);
  write_camera(read_camera(dir / "cam.json").parameters(), dir / "woodscape.json", CameraFormat::woodscape);
  const CameraParameters back = read_camera(dir / "woodscape.json").parameters();
  EXPECT_EQ(model_params(back.model), model_params(original.model));
  EXPECT_EQ(back.grid.principal_point, original.grid.principal_point);  // bit for bit
  EXPECT_EQ(back.grid.pixel_scale, original.grid.pixel_scale);
  EXPECT_EQ(back.width, original.width);
  EXPECT_EQ(back.pose->translation, original.pose->translation);
  EXPECT_EQ(back.pose->rotation.coeffs(), original.pose->rotation.coeffs());
}

TEST(Fit, PaperFormulas) {
  const Camera source = woodscape();
  const double half_fov = source.field_of_view_deg().horizontal / 2 * M_PI / 180;
  const auto eq = paper_camera(source, parse_model_spec("equidistant"));
  const auto st = paper_camera(source, parse_model_spec("stereographic"));
  EXPECT_DOUBLE_EQ(model_params(eq.model)[0], 640 / half_fov);                      // eq. 13
  EXPECT_DOUBLE_EQ(model_params(st.model)[0], 640 / (2 * std::tan(half_fov / 2)));  // eq. 14
  EXPECT_THROW(paper_camera(source, parse_model_spec("kannala-brandt")), Error);
}

TEST(Fit, BadInput) {
  for (const char* bad : {"fisheye", "polynomial:0", "polynomial:x", "equidistant:3", "", "polynomial:13"}) {
    EXPECT_THROW(parse_model_spec(bad), Error) << bad;
  }
  EXPECT_EQ(parse_model_spec("polynomial:6").order, 6);
  const Camera source = woodscape();
  EXPECT_THROW(fit_camera(sample_image(source, 16), parse_model_spec("pinhole"), source.parameters()), Error);
  const std::vector<Correspondence> few(5, Correspondence{{0.1, 0, 1}, {700, 480}});
  EXPECT_THROW(fit_camera(few, parse_model_spec("polynomial"), source.parameters()), Error);
  // All samples at one angle: a 4-parameter polynomial is not determined.
  std::vector<Correspondence> ring;
  for (int i = 0; i < 100; ++i) {
    const double phi = 0.0628 * i;
    ring.push_back({{std::cos(phi), std::sin(phi), 1.0},
                    source.principal_point() + 200 * Eigen::Vector2d(std::cos(phi), std::sin(phi))});
  }
  EXPECT_THROW(fit_camera(ring, parse_model_spec("polynomial"), source.parameters()), Error);
}

}  // namespace
}  // namespace fishcam

namespace fishcam {
namespace {

// A model whose domain ends at a fixed angle (a trait of its class: pinhole, 90 deg)
// refuses data past it, naming the angle.
TEST(Fit, RaysPastAModelsFixedLimitAreRefused) {
  const Camera wide(test::woodscape_front());
  const auto samples = sample_image(wide, 16, 0);  // up to ~100 deg off-axis
  try {
    fit_camera(samples, parse_model_spec("pinhole"), wide.parameters());
    ADD_FAILURE() << "a pinhole was fitted to rays past 90 deg";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("a pinhole model cannot see rays at or past 90 deg"), std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(fit_camera(sample_image(wide, 16, 0, 1.2), parse_model_spec("pinhole"), wide.parameters()));
}

}  // namespace
}  // namespace fishcam
