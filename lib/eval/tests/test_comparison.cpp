// compare_models: what the projection model used for augmentation changes.
#include <nlohmann/json.hpp>

#include "fishcam/augment/scene.hpp"
#include "fishcam/eval/comparison.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

Camera front() { return read_camera(test::data_path("woodscape_front.json")); }

TEST(Comparison, TheCameraAgainstItselfIsZeroAndTheIdentityIsACheck) {
  const Camera camera = front();
  const SceneRender scene = render_street_scene(camera, *camera.parameters().pose);
  ComparisonOptions options;
  options.samples = 2;
  const Comparison c =
      compare_models(camera, {{"itself", "given", camera, std::nullopt}}, options, {{"scene", scene.labels}});
  ASSERT_EQ(c.models.size(), 1u);
  const ModelComparison& m = c.models[0];
  EXPECT_EQ(m.all.max_px, 0);
  EXPECT_EQ(m.identity_max_px, 0);
  EXPECT_EQ(m.validity_differs_pct, 0);
  EXPECT_EQ(m.labels_differ_pct.at(0), 0);
  EXPECT_GT(m.all.pixels, 2 * camera.width() * camera.height() / 2);
  long banded = 0;
  for (const auto& band : m.by_angle) banded += band.pixels;
  EXPECT_EQ(banded, m.all.pixels);
  // The seeded changes are the documented ones.
  EXPECT_EQ(c.changes[1].rotation_deg, random_change(options.preset, derive_seed(0, "compare", 1)).rotation_deg);
}

// Kannala-Brandt fits the WoodScape camera to 0.145 px rms (0.55 px below 20 deg,
// <= 0.2 px from 30 to 100 deg): augmenting with it moves samples by well under a
// pixel where the fit is good.
TEST(Comparison, KannalaBrandtOfTheWoodScapeCameraIsSubPixel) {
  const Camera camera = front();
  ComparisonOptions options;
  options.samples = 3;
  options.seed = 5;
  const Comparison c = compare_models(camera, {alternative_model(camera, "kannala-brandt")}, options);
  const ModelComparison& m = c.models[0];
  EXPECT_EQ(m.alternative.how, "least-squares fit");
  EXPECT_NEAR(*m.alternative.fit_rms_px, 0.145, 0.005);
  EXPECT_LT(m.identity_max_px, 1e-3);
  EXPECT_LT(m.all.mean_px, 0.25);
  EXPECT_LT(m.all.p95_px, 0.6);
  EXPECT_LT(m.by_angle[2].mean_px, 0.2);  // 60-90 deg
  EXPECT_LT(m.by_angle[3].mean_px, 0.2);  // past 90 deg
  EXPECT_LT(m.validity_differs_pct, 0.1);
  // And the equidistant model is tens of pixels off.
  const Comparison e = compare_models(camera, {alternative_model(camera, "equidistant", "paper")}, options);
  EXPECT_EQ(e.models[0].alternative.how, "the paper's eqs. 13-14");
  EXPECT_GT(e.models[0].all.mean_px, 5);
  const auto j = nlohmann::json::parse(comparison_json(e));
  EXPECT_EQ(j["models"][0]["model"], "equidistant");
  EXPECT_EQ(j["changes"].size(), 3u);
  EXPECT_EQ(j["models"][0]["by_angle"].size(), 4u);
}

TEST(Comparison, BadInputsAreRefused) {
  const Camera camera = front();
  CameraParameters small = camera.parameters();
  small.width = 640;
  EXPECT_THROW(compare_models(camera, {{"small", "given", Camera(small), std::nullopt}}, {}), Error);
  EXPECT_THROW(compare_models(camera, {}, {}, {{"labels", cv::Mat(4, 4, CV_8UC1)}}), Error);
  ComparisonOptions none;
  none.samples = 0;
  EXPECT_THROW(compare_models(camera, {}, none), Error);
  ComparisonOptions many;
  many.samples = 60;  // 60 x 1280 x 966 > 64 million displacements
  try {
    compare_models(camera, {}, many);
    ADD_FAILURE() << "60 samples accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("at most 51 changes here"), std::string::npos) << e.what();
  }
  EXPECT_THROW(alternative_model(camera, "no-such-model"), Error);
  EXPECT_THROW(alternative_model(camera, "equidistant", "guess"), Error);
}

}  // namespace
}  // namespace fishcam
