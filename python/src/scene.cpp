// Python bindings: the street scenes (fishcam.render, woodscape_classes) and the
// augmentation's fidelity against their re-renders (dataset_fidelity).
#include "fishcam/augment/scene.hpp"
#include "bindings.hpp"
#include "fishcam/eval/fidelity.hpp"

#include <opencv2/imgproc.hpp>

namespace fishcam::python {
namespace {
// The street scenes: rendering and the WoodScape classes.
void bind_rendering(py::module_& m) {
  m.def(
      "render",
      [](const Camera& camera, std::optional<std::uint64_t> scene_seed, std::optional<ViewpointChange> change,
         int supersampling) {
        const auto& mount = camera.parameters().pose;
        if (!mount) {
          throw Error(
              "render: the camera has no pose to place it in the scene (give the camera file an extrinsic "
              "pose, as data/woodscape_front.json has)");
        }
        const Pose pose = change ? moved_camera(*mount, change->motion()) : *mount;
        const int h = camera.height(), w = camera.width();
        py::array_t<std::uint8_t> image({h, w, 3}), mask({h, w});
        py::array_t<float> depth({h, w});
        {
          py::gil_scoped_release release;
          const StreetScene scene = scene_seed ? StreetScene::generate(*scene_seed) : StreetScene::bundled();
          const SceneRender render = scene.render(camera, pose, supersampling);
          cv::Mat rgb(h, w, CV_8UC3, image.mutable_data());
          cv::cvtColor(render.image, rgb, cv::COLOR_BGR2RGB);
          render.labels.copyTo(cv::Mat(h, w, CV_8UC1, mask.mutable_data()));
          render.range.copyTo(cv::Mat(h, w, CV_32FC1, depth.mutable_data()));
        }
        py::dict out;
        out["image"] = image, out["mask"] = mask, out["depth"] = depth;
        return out;
      },
      py::arg("camera"), py::arg("scene_seed") = py::none(), py::arg("change") = py::none(),
      py::arg("supersampling") = 2,
      "Ray-casts a street scene through `camera` at its pose (moved by `change` when given): the bundled street, "
      "or the random street of `scene_seed`. Returns {'image': (H, W, 3) uint8 RGB (supersampling^2 rays per "
      "pixel), 'mask': (H, W) uint8 WoodScape class ids, 'depth': (H, W) float32 range along each pixel's ray in "
      "metres (inf: sky, NaN: outside the camera's domain)}; mask and depth from one ray through each pixel centre.");

  m.def(
      "woodscape_classes",
      [] {
        std::vector<std::pair<std::string, std::tuple<int, int, int>>> out;
        for (int c = 0; c < woodscape_class::kCount; ++c) {
          const cv::Vec3b bgr = woodscape_class_colour(c);
          out.emplace_back(woodscape_class_name(c), std::tuple<int, int, int>{bgr[2], bgr[1], bgr[0]});
        }
        return out;
      },
      "The WoodScape classes the renderer labels, by id: [(name, (r, g, b) display colour), ...].");
}

// Augmentation fidelity against re-rendered truth.
void bind_fidelity(py::module_& m) {
  m.def(
      "dataset_fidelity",
      [](const std::string& dataset) {
        std::vector<DatasetFidelity> rows;
        {
          py::gil_scoped_release release;
          rows = fishcam::dataset_fidelity(dataset);
        }
        std::vector<py::dict> out;
        for (const DatasetFidelity& r : rows) {
          py::dict row;
          row["test_set"] = r.test_set, row["prior"] = r.prior, row["samples"] = r.samples;
          row["valid_share"] = r.valid_share, row["label_agreement"] = r.label_agreement, row["psnr_db"] = r.psnr_db;
          out.push_back(row);
        }
        return out;
      },
      py::arg("dataset"),
      "How faithful the augmentation is to the truth on a dataset of `fishcam sample-dataset --scenes N [--depth]` "
      "(as `fishcam fidelity`): each test sample augmented by the change of each true viewpoint test set "
      "(test-*/changes.jsonl) under every depth prior, and its depth map when the dataset has test/depth/, against "
      "the re-render from the moved camera. One dict per test set and prior: test_set, prior, samples, "
      "valid_share (pixels with a source), label_agreement (away from class boundaries), psnr_db; means over the "
      "samples.");

  m.def(
      "dataset_model_fidelity",
      [](const std::string& dataset, const std::vector<std::string>& models, const std::string& depth) {
        const DepthPrior prior = depth_prior(depth, "depth");
        std::vector<ModelFidelity> rows;
        {
          py::gil_scoped_release release;
          rows = fishcam::dataset_model_fidelity(dataset, models, prior);
        }
        std::vector<py::dict> out;
        for (const ModelFidelity& r : rows) {
          py::dict row;
          row["test_set"] = r.test_set, row["model"] = r.model, row["how"] = r.how, row["samples"] = r.samples;
          row["valid_share"] = r.valid_share, row["label_agreement"] = r.label_agreement, row["psnr_db"] = r.psnr_db;
          row["endpoint_px"] = r.endpoint_px;
          row["endpoint_by_angle_px"] =
              std::vector<double>(r.endpoint_by_angle_px.begin(), r.endpoint_by_angle_px.end());
          out.push_back(row);
        }
        return out;
      },
      py::arg("dataset"), py::arg("models"), py::arg("depth") = "source-sphere",
      "The paper's Table 5 by geometry (as `fishcam fidelity --models`): each true viewpoint test set of a dataset "
      "of `fishcam sample-dataset --scenes N` augmented through each of `models` -- 'own' (the camera itself) or a "
      "model fitted to each sample's camera, 'NAME' or 'NAME:paper' / 'NAME:lsq' (eqs. 13-14 or least squares) -- "
      "under the depth prior `depth`, against the re-render from the moved camera. One dict per test set and "
      "model: test_set, model, how, samples, valid_share, label_agreement, psnr_db (means over the samples), "
      "endpoint_px (mean distance of the model's map from the camera's own, px) and endpoint_by_angle_px (by the "
      "output pixel's angle of incidence: 0-30, 30-60, 60-90, 90+ degrees; NaN for a band without pixels).");
}

}  // namespace

void bind_scene(py::module_& m) {
  bind_rendering(m);
  bind_fidelity(m);
}

}  // namespace fishcam::python
