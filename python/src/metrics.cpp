// Evaluation (fishcam.metrics.ConfusionMatrix) and the comparison of augmentations.
#include <algorithm>
#include <filesystem>

#include "bindings.hpp"
#include "fishcam/eval/comparison.hpp"
#include "fishcam/eval/metrics.hpp"
#include "fishcam/fit/fit.hpp"

namespace fishcam::python {
namespace {

void bind_comparison(py::module_& m) {
  m.def(
      "compare",
      [](const Camera& camera, const py::list& models, const std::string& method, const std::string& preset,
         int samples, std::uint64_t seed, const std::string& depth, const py::dict& labels) {
        check_conversion_method(method);
        ComparisonOptions options;
        options.preset = pose_preset(preset);
        options.samples = samples;
        options.seed = seed;
        options.prior = depth_prior(depth);
        std::vector<AlternativeModel> alternatives;
        for (const py::handle& item : models) {
          if (py::isinstance<Camera>(item)) {
            const Camera& given = item.cast<const Camera&>();
            alternatives.push_back({std::string(model_name(given.model())), "given", given, std::nullopt});
          } else if (py::isinstance<py::tuple>(item) && py::len(item) == 2 &&
                     py::isinstance<Camera>(item[py::int_(1)])) {
            alternatives.push_back(
                {py::str(item[py::int_(0)]), "given", item[py::int_(1)].cast<Camera>(), std::nullopt});
          } else if (py::isinstance<py::str>(item)) {
            alternatives.push_back({item.cast<std::string>(), "", camera, std::nullopt});  // resolved below
          } else {
            throw Error("models: expected model names, camera files, fishcam.Camera or (name, Camera), got " +
                        std::string(py::str(py::type::of(item).attr("__name__"))));
          }
        }
        NamedLabels named;
        std::vector<py::array> keep;
        for (const auto& [key, value] : labels) {
          keep.push_back(py::array::ensure(value));
          if (!keep.back()) throw Error("labels: expected arrays");
          named.emplace_back(py::str(key), as_mat(keep.back(), "labels", true));
        }
        py::gil_scoped_release release;
        for (AlternativeModel& a : alternatives) {
          if (!a.how.empty()) continue;  // a Camera given as such
          std::error_code ec;
          a = std::filesystem::is_regular_file(a.name, ec) ? alternative_from_file(a.name, read_camera(a.name))
                                                           : alternative_model(camera, a.name, method);
        }
        return compare_models(camera, alternatives, options, named);
      },
      py::arg("camera"), py::arg("models"), py::arg("method"), py::arg("preset"), py::arg("samples"), py::arg("seed"),
      py::arg("depth"), py::arg("labels"));
}

// fishcam compare's result, typed.
void bind_comparison_results(py::module_& m) {
  py::class_<DisplacementStats>(m, "DisplacementStats",
                                "How far the alternative model's augmentation puts pixels from the reference's (px).")
      .def_readonly("pixels", &DisplacementStats::pixels, "(output pixel, change) pairs compared (int).")
      .def_readonly("mean_px", &DisplacementStats::mean_px, "Mean displacement.")
      .def_readonly("p95_px", &DisplacementStats::p95_px, "95th percentile (numpy's linear interpolation).")
      .def_readonly("max_px", &DisplacementStats::max_px, "Largest displacement.")
      .def("__repr__", [](const DisplacementStats& d) {
        char buffer[160];
        std::snprintf(buffer, sizeof buffer, "DisplacementStats(mean_px=%.6g, p95_px=%.6g, max_px=%.6g, pixels=%ld)",
                      d.mean_px, d.p95_px, d.max_px, d.pixels);
        return std::string(buffer);
      });
  py::class_<ModelComparison>(m, "ModelComparison", "One alternative model against the reference camera.")
      .def_property_readonly(
          "name", [](const ModelComparison& c) { return c.alternative.name; },
          "The model as named: a model name or a file.")
      .def_property_readonly(
          "how", [](const ModelComparison& c) { return c.alternative.how; },
          "Where it came from: 'least-squares fit', \"the paper's eqs. 13-14\", 'read from FILE', ...")
      .def_property_readonly(
          "camera", [](const ModelComparison& c) { return c.alternative.camera; }, "The alternative camera.")
      .def_property_readonly(
          "fit_rms_px", [](const ModelComparison& c) { return c.alternative.fit_rms_px; },
          "The fit's RMS error over the camera's image when fitted, else None.")
      .def_readonly("identity_max_px", &ModelComparison::identity_max_px,
                    "Largest displacement of the identity change (the models' own disagreement).")
      .def_readonly("displacement", &ModelComparison::all, "Over every compared pixel (DisplacementStats).")
      .def_property_readonly(
          "by_angle",
          [](const ModelComparison& c) { return std::vector<DisplacementStats>(c.by_angle.begin(), c.by_angle.end()); },
          "Per band of Comparison.angle_bands_deg (list of DisplacementStats).")
      .def_readonly("validity_differs_pct", &ModelComparison::validity_differs_pct,
                    "Percent of output pixels with a source under one model only.")
      .def_readonly("labels_differ_pct", &ModelComparison::labels_differ_pct,
                    "Percent of labels that differ, per label image (aligned with Comparison.label_names).")
      .def_property_readonly(
          "mean_displacement",
          [](const ModelComparison& c) {
            const cv::Mat& d = c.mean_displacement;
            py::array_t<float> out({d.rows, d.cols});
            for (int v = 0; v < d.rows; ++v) std::copy_n(d.ptr<float>(v), d.cols, out.mutable_data(v, 0));
            return out;
          },
          "Mean displacement per output pixel over the changes, (H, W) float32, NaN where none.");
  py::class_<Comparison>(m, "Comparison", "What `fishcam compare` measures (docs/comparison.md).")
      .def_property_readonly(
          "preset", [](const Comparison& c) { return std::string(c.options.preset.name); },
          "The pose preset of the changes.")
      .def_property_readonly(
          "samples", [](const Comparison& c) { return c.options.samples; }, "Changes compared.")
      .def_property_readonly(
          "seed", [](const Comparison& c) { return c.options.seed; }, "The changes' seed.")
      .def_property_readonly(
          "depth", [](const Comparison& c) { return std::string(to_string(c.options.prior)); }, "The depth prior.")
      .def_property_readonly(
          "angle_bands_deg",
          [](const Comparison&) {
            return std::vector<double>(Comparison::kAngleBandsDeg.begin(), Comparison::kAngleBandsDeg.end());
          },
          "The edges of ModelComparison.by_angle's bands (degrees).")
      .def_readonly("label_names", &Comparison::label_names, "The label images compared.")
      .def_readonly("changes", &Comparison::changes, "The viewpoint changes (list of ViewpointChange).")
      .def_readonly("models", &Comparison::models, "One ModelComparison per alternative model.")
      .def(
          "to_json", [](const Comparison& c) { return comparison_json(c); },
          "What `fishcam compare --json` prints (str).");
}

}  // namespace

void bind_metrics(py::module_& m) {
  bind_comparison_results(m);
  bind_comparison(m);
  py::class_<ConfusionMatrix>(m, "ConfusionMatrix")
      .def(py::init<int, std::optional<std::int64_t>>(), py::arg("num_classes"), py::arg("ignore") = py::none())
      .def(
          "update",
          [](ConfusionMatrix& matrix, const py::handle& prediction, const py::handle& ground_truth,
             const py::handle& valid) {
            py::array pred_array, gt_array;
            const LabelSpan pred = labels_of(prediction, "prediction", &pred_array);
            const LabelSpan gt = labels_of(ground_truth, "ground_truth", &gt_array);
            if (pred_array.ndim() != gt_array.ndim() ||
                !std::equal(pred_array.shape(), pred_array.shape() + pred_array.ndim(), gt_array.shape())) {
              throw Error("prediction: shape " + shape_text(pred_array) + " differs from the ground truth's " +
                          shape_text(gt_array));
            }
            py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast> mask;
            std::span<const std::uint8_t> mask_span;
            if (!valid.is_none()) {
              // bool, or integers that are all 0 or 1: a cast to uint8 would turn 256
              // (or 0.5) into 0 and leave those pixels silently unscored.
              const py::array given = py::array::ensure(valid);
              const char kind = given ? given.dtype().kind() : '?';
              if (kind != 'b' && kind != 'i' && kind != 'u') {
                throw Error("valid: expected a bool mask or integers 0 and 1, got " +
                            (given ? "dtype " + std::string(py::str(given.dtype())) : std::string("no array")));
              }
              if (kind != 'b') {
                const auto values = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(given);
                const std::int64_t* v = values.data();
                if (!std::all_of(v, v + values.size(), [](std::int64_t x) { return x == 0 || x == 1; })) {
                  throw Error("valid: integer masks may hold only 0 and 1 (use a bool array, e.g. mask != 0)");
                }
              }
              mask = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>::ensure(given);
              if (!mask || mask.ndim() != gt_array.ndim() ||
                  !std::equal(mask.shape(), mask.shape() + mask.ndim(), gt_array.shape())) {
                throw Error("valid: expected an array of the ground truth's shape " + shape_text(gt_array));
              }
              mask_span = std::span(mask.data(), static_cast<std::size_t>(mask.size()));
            }
            const int width = gt_array.ndim() >= 2 ? static_cast<int>(gt_array.shape(gt_array.ndim() - 1)) : 0;
            py::gil_scoped_release release;
            matrix.update(pred, gt, mask_span, width);
          },
          py::arg("prediction"), py::arg("ground_truth"), py::arg("valid") = py::none(),
          "Counts pixels: prediction and ground_truth integer arrays of one shape (uint8, uint16, int32, int64), "
          "valid an optional bool mask of that shape; a value that is not a class raises and counts nothing.")
      .def("merge", &ConfusionMatrix::merge, py::arg("other"))
      .def_property_readonly("num_classes", &ConfusionMatrix::num_classes)
      .def_property_readonly("ignore", &ConfusionMatrix::ignore)
      .def_property_readonly("scored_pixels", &ConfusionMatrix::scored_pixels)
      .def_property_readonly("counts",
                             [](const ConfusionMatrix& matrix) {
                               const py::ssize_t n = matrix.num_classes();
                               py::array_t<std::int64_t> out({n, n});
                               std::copy(matrix.counts().begin(), matrix.counts().end(), out.mutable_data());
                               return out;
                             })
      .def("_iou", &ConfusionMatrix::iou)
      .def("_miou", &ConfusionMatrix::miou);
}

}  // namespace fishcam::python
