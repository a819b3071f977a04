// fishcam._fishcam: the C++ library for Python. Thin: argument checks and array
// plumbing only (zero-copy numpy inputs when C-contiguous, outputs allocated as
// numpy arrays and written in place), the GIL released around every computation.
// The package's Python modules (fishcam/__init__.py, transforms.py, torch.py)
// build the documented API on top.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>

#include "fishcam/affine.hpp"
#include "fishcam/augmentation.hpp"
#include "fishcam/camera_io.hpp"
#include "fishcam/comparison.hpp"
#include "fishcam/fit.hpp"
#include "fishcam/metrics.hpp"
#include "fishcam/viewpoint.hpp"

namespace py = pybind11;

namespace fishcam::python {
namespace {

using PointArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// (N, k) float64, C-contiguous: the input itself when it already is one (no copy),
// else a converted copy (forcecast). `what` names the argument in errors.
PointArray rows_of(const py::handle& input, py::ssize_t k, const char* what) {
  PointArray array = PointArray::ensure(input);
  if (!array) throw Error(std::string(what) + ": expected an array of numbers");
  if (array.ndim() != 2 || array.shape(1) != k) {
    std::string shape = "(";
    for (py::ssize_t i = 0; i < array.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(array.shape(i));
    throw Error(std::string(what) + ": expected shape (N, " + std::to_string(k) + "), got " + shape + ")");
  }
  return array;
}

// A batch call of the library on (N, kIn) rows: (N, kOut) float64 results and
// (N,) bool validity, computed in place on numpy memory with the GIL released.
template <int kIn, int kOut, class Compute>
py::tuple batch(const py::handle& input, const char* what, const Compute& compute) {
  using In = Eigen::Matrix<double, kIn, 1>;
  using Out = Eigen::Matrix<double, kOut, 1>;
  const PointArray rows = rows_of(input, kIn, what);
  const size_t n = static_cast<size_t>(rows.shape(0));
  py::array_t<double> results({py::ssize_t(n), py::ssize_t(kOut)});
  py::array_t<bool> ok{py::ssize_t(n)};
  {
    py::gil_scoped_release release;
    compute(std::span<const In>(reinterpret_cast<const In*>(rows.data()), n),
            std::span<Out>(reinterpret_cast<Out*>(results.mutable_data()), n),
            std::span<std::uint8_t>(reinterpret_cast<std::uint8_t*>(ok.mutable_data()), n));
  }
  return py::make_tuple(results, ok);
}

// A numpy image as a cv::Mat header on its memory (no copy). HxW or HxWxC, C <= 4,
// C-contiguous (else copied), dtype among `depths`.
cv::Mat as_mat(py::array& array, const char* what, bool labels) {
  if (!(array.flags() & py::array::c_style)) {
    array = py::array::ensure(array, py::array::c_style);  // a contiguous copy: never strided reads
  }
  if (array.ndim() >= 2 && (array.shape(0) >= 32767 || array.shape(1) >= 32767)) {
    throw Error(std::string(what) + ": 32767 pixels or more per side (cv::remap takes fewer)");
  }
  const int ndim = static_cast<int>(array.ndim());
  if (ndim != 2 && !(ndim == 3 && !labels)) {
    throw Error(std::string(what) + (labels ? ": expected an HxW array" : ": expected an HxW or HxWxC array"));
  }
  const int channels = ndim == 3 ? static_cast<int>(array.shape(2)) : 1;
  if (channels < 1 || channels > 4) throw Error(std::string(what) + ": expected 1 to 4 channels, got " + std::to_string(channels));
  int depth = -1;
  if (py::isinstance<py::array_t<std::uint8_t>>(array)) depth = CV_8U;
  if (py::isinstance<py::array_t<std::uint16_t>>(array)) depth = CV_16U;
  if (!labels && py::isinstance<py::array_t<float>>(array)) depth = CV_32F;
  if (depth < 0) {
    throw Error(std::string(what) + ": expected dtype " + (labels ? "uint8 or uint16" : "uint8, uint16 or float32") +
                ", got " + std::string(py::str(array.dtype())));
  }
  // Inputs are only read: read-only arrays (np.asarray of a PIL image, a memory map
  // opened with mode 'r') are taken as they are.
  return cv::Mat(static_cast<int>(array.shape(0)), static_cast<int>(array.shape(1)), CV_MAKETYPE(depth, channels),
                 const_cast<void*>(array.data()));
}

// A new numpy array of height x width (x the channels of `like`), dtype of `like`,
// and a cv::Mat header on its memory.
py::array new_image(const py::array& like, int height, int width, cv::Mat* header) {
  std::vector<py::ssize_t> shape{height, width};
  if (like.ndim() == 3) shape.push_back(like.shape(2));
  py::array out(like.dtype(), shape);
  const int channels = like.ndim() == 3 ? static_cast<int>(like.shape(2)) : 1;
  const int depth = like.itemsize() == 1 ? CV_8U : like.itemsize() == 2 ? CV_16U : CV_32F;
  *header = cv::Mat(height, width, CV_MAKETYPE(depth, channels), out.mutable_data());
  return out;
}

MapKind map_kind(const std::string& name) {
  if (name == "geometric") return MapKind::geometric;
  if (name == "sampling") return MapKind::sampling;
  throw Error("kind: expected geometric or sampling, got '" + name + "'");
}

std::optional<CameraFormat> format_of(const std::optional<std::string>& name) {
  if (!name) return std::nullopt;
  const auto format = parse_camera_format(*name);
  if (!format) throw Error("format: unknown camera format '" + *name + "' (expected one of: " + camera_format_names() + ")");
  return format;
}

// The camera's full state as fishcam JSON (exact: doubles are written round-trip).
std::string camera_state(const Camera& camera) { return format_camera(camera.parameters(), CameraFormat::fishcam); }

// The camera's numbers as bytes: equal exactly when the cameras are (model, its
// parameters, size, principal point, pixel scale, theta limit and, with_pose, the
// pose). A cache key that costs microseconds, where to_json() formats and reads
// back a file (milliseconds).
py::bytes parameters_key(const Camera& camera, bool with_pose) {
  const CameraParameters& p = camera.parameters();
  std::string key(model_name(p.model));
  key.push_back('\0');
  std::vector<double> numbers = model_params(p.model);
  numbers.insert(numbers.end(), {double(p.width), double(p.height), p.principal_point.x(), p.principal_point.y(),
                                 p.pixel_scale.x(), p.pixel_scale.y(), p.theta_limit.value_or(-1.0)});
  if (with_pose && p.pose) {
    const auto& q = p.pose->rotation;
    numbers.insert(numbers.end(), {q.w(), q.x(), q.y(), q.z(), p.pose->translation.x(), p.pose->translation.y(),
                                   p.pose->translation.z()});
  }
  key.append(reinterpret_cast<const char*>(numbers.data()), numbers.size() * sizeof(double));
  return py::bytes(key);
}
Camera camera_from_state(const std::string& state) {
  return Camera(parse_camera(state, "pickled camera", CameraFormat::fishcam));
}

RandomPose change_from(const Eigen::Vector3d& rotation_deg, const Eigen::Vector3d& translation) {
  if (!rotation_deg.allFinite()) throw Error("rotation_deg: must be finite");
  if (!translation.allFinite()) throw Error("translation: must be finite");
  return RandomPose{rotation_deg, translation};
}

void bind_camera(py::module_& m) {
  py::class_<Camera>(m, "Camera")
      .def_static(
          "read",
          [](const std::string& path, std::optional<py::object> camera, std::optional<std::pair<int, int>> image_size,
             std::optional<std::string> format, std::optional<std::string> distortion_model) {
            CameraReadOptions options;
            options.format = format_of(format);
            options.distortion_model = distortion_model;
            if (camera && !camera->is_none()) options.camera = py::str(*camera);
            options.image_size = image_size;
            py::gil_scoped_release release;
            return read_camera(path, options);
          },
          py::arg("path"), py::arg("camera") = py::none(), py::arg("image_size") = py::none(),
          py::arg("format") = py::none(), py::arg("distortion_model") = py::none())
      .def(
          "write",
          [](const Camera& camera, const std::string& path, std::optional<std::string> format, bool overwrite) {
            CameraFormat resolved;
            if (format) {
              resolved = *format_of(format);
            } else if (const auto by_extension = camera_format_for_extension(path)) {
              resolved = *by_extension;
            } else {
              throw Error(path + ": cannot tell the format from the extension; pass format=");
            }
            write_camera(camera.parameters(), path, resolved, overwrite);
          },
          py::arg("path"), py::arg("format") = py::none(), py::arg("overwrite") = false)
      .def_property_readonly("width", &Camera::width)
      .def_property_readonly("height", &Camera::height)
      .def_property_readonly("model", [](const Camera& c) { return std::string(model_name(c.model())); })
      .def_property_readonly("parameters", [](const Camera& c) { return model_params(c.model()); })
      .def_property_readonly("principal_point", [](const Camera& c) { return Eigen::Vector2d(c.principal_point()); })
      .def_property_readonly(
          "pose",
          [](const Camera& c) -> std::optional<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> {
            const auto& pose = c.parameters().pose;
            if (!pose) return std::nullopt;
            return std::pair(Eigen::Matrix3d(pose->rotation.toRotationMatrix()), Eigen::Vector3d(pose->translation));
          },
          "(rotation (3, 3), translation (3,)) of camera -> reference (p_ref = R p_cam + t), or None")
      .def_property_readonly("pixel_scale", [](const Camera& c) { return Eigen::Vector2d(c.pixel_scale()); })
      .def(
          "project",
          [](const Camera& camera, const py::handle& points) {
            return batch<3, 2>(points, "points", [&](auto in, auto out, auto ok) { camera.project(in, out, ok); });
          },
          py::arg("points"))
      .def(
          "unproject",
          [](const Camera& camera, const py::handle& pixels) {
            return batch<2, 3>(pixels, "pixels", [&](auto in, auto out, auto ok) { camera.unproject(in, out, ok); });
          },
          py::arg("pixels"))
      .def(
          "theta_from_rho",
          [](const Camera& camera, py::array_t<double, py::array::c_style | py::array::forcecast> rho) {
            py::array_t<double> theta(std::vector<py::ssize_t>(rho.shape(), rho.shape() + rho.ndim()));
            const double* in = rho.data();
            double* out = theta.mutable_data();
            const py::ssize_t n = rho.size();
            {
              py::gil_scoped_release release;
              for (py::ssize_t i = 0; i < n; ++i) out[i] = camera.theta_from_rho(in[i]);
            }
            return theta;
          },
          py::arg("rho"))
      .def("info_json", [](const Camera& c) { return camera_info_json(c); })
      .def(
          "resized", [](const Camera& c, int width, int height) { return Camera(resized(c.parameters(), width, height)); },
          py::arg("width"), py::arg("height"))
      .def(
          "augmented",
          [](const Camera& c, const RandomPose& change) { return augmented_camera(c, change.change()); },
          py::arg("change"),
          "The camera of an image augmented by `change`: same intrinsics, the pose moved by the change (a camera "
          "without a pose gets one relative to its own frame)")
      .def("to_json", &camera_state, "The camera as fishcam JSON text")
      .def("parameters_key", &parameters_key, py::arg("with_pose") = true,
           "bytes equal exactly when two cameras are (with_pose=False: the intrinsics and size only, what a "
           "warp depends on); cheap, for caches and hashing")
      .def_static("from_json", &camera_from_state, py::arg("text"))
      .def(py::pickle([](const Camera& c) { return camera_state(c); },
                      [](const std::string& state) { return camera_from_state(state); }))
      .def("__repr__", [](const Camera& c) {
        return "<fishcam.Camera " + std::string(model_name(c.model())) + " " + std::to_string(c.width()) + "x" +
               std::to_string(c.height()) + ">";
      });

  m.def(
      "convert",
      [](const Camera& source, const std::string& to, const std::string& method, std::optional<double> max_angle_deg,
         bool fit_center, bool fit_aspect) {
        std::optional<double> max_theta;
        if (max_angle_deg) {
          if (!std::isfinite(*max_angle_deg)) throw Error("max_angle: must be finite");
          max_theta = *max_angle_deg * std::numbers::pi / 180;
        }
        const ModelSpec spec = parse_model_spec(to);
        std::optional<Conversion> c;
        {
          py::gil_scoped_release release;
          c = convert_camera(source, spec, method, max_theta, {fit_center, fit_aspect});
        }
        return py::make_tuple(Camera(c->camera), fit_report_json(c->camera, c->report), c->widest_theta);
      },
      py::arg("camera"), py::arg("to"), py::arg("method") = "lsq", py::arg("max_angle") = py::none(),
      py::arg("fit_center") = false, py::arg("fit_aspect") = false);
}

// What `fishcam augment` writes, into new numpy arrays: the image and labels (and
// optionally the validity) resampled by `apply` (an AugmentIO -> outputs written in
// place) from `source` to `target` size, the GIL released around the compute.
template <class Apply>
py::dict resample(std::optional<py::array> image, std::optional<py::array> labels, cv::Size source, cv::Size target,
                  double fill, int label_fill, bool return_valid, const Apply& apply) {
  py::dict out;
  cv::Mat image_in, labels_in, image_out, labels_out, valid_out;
  if (image) {
    image_in = as_mat(*image, "image", false);
    out["image"] = new_image(*image, target.height, target.width, &image_out);
  }
  if (labels) {
    labels_in = as_mat(*labels, "labels", true);
    out["labels"] = new_image(*labels, target.height, target.width, &labels_out);
  }
  if (return_valid) {
    py::array_t<bool> valid({target.height, target.width});
    valid_out = cv::Mat(target.height, target.width, CV_8UC1, valid.mutable_data());
    out["valid"] = valid;
  }
  py::gil_scoped_release release;
  for (const auto& [mat, what, given] : {std::tuple(&image_in, "image", bool(image)),
                                         std::tuple(&labels_in, "labels", bool(labels))}) {
    if (given && mat->size() != source) {
      throw Error(std::string(what) + ": is " + std::to_string(mat->cols) + "x" + std::to_string(mat->rows) +
                  " but the camera is " + std::to_string(source.width) + "x" + std::to_string(source.height));
    }
  }
  const std::array<const uchar*, 3> before{image_out.data, labels_out.data, valid_out.data};
  apply(AugmentIO{image ? &image_in : nullptr, &image_out, fill, labels ? &labels_in : nullptr, &labels_out, label_fill,
                  return_valid ? &valid_out : nullptr});
  // The library wrote into the numpy buffers (same size and type).
  if (before != std::array<const uchar*, 3>{image_out.data, labels_out.data, valid_out.data}) {
    throw Error("internal: an output was reallocated");
  }
  return out;
}

Sampling sampling_of(const std::string& name) {
  const auto sampling = parse_sampling(name);
  if (!sampling) {
    throw Error("sampling: expected " + choices_for_message(sampling_names()) + ", got " + quoted_for_message(name));
  }
  return *sampling;
}

void bind_augmentation(py::module_& m) {
  py::class_<RandomPose>(m, "ViewpointChange")
      .def(py::init(&change_from), py::arg("rotation_deg") = Eigen::Vector3d::Zero(),
           py::arg("translation") = Eigen::Vector3d::Zero())
      .def_readonly("rotation_deg", &RandomPose::rotation_deg)
      .def_readonly("translation", &RandomPose::translation)
      .def_property_readonly("rotation", [](const RandomPose& p) { return Eigen::Matrix3d(p.change().rotation); })
      .def(py::pickle(
          [](const RandomPose& p) { return py::make_tuple(p.rotation_deg, p.translation); },
          [](const py::tuple& t) { return change_from(t[0].cast<Eigen::Vector3d>(), t[1].cast<Eigen::Vector3d>()); }))
      .def("__repr__", [](const RandomPose& p) {
        char buffer[256];
        std::snprintf(buffer, sizeof buffer, "ViewpointChange(rotation_deg=(%.17g, %.17g, %.17g), translation=(%.17g, %.17g, %.17g))",
                      p.rotation_deg.x(), p.rotation_deg.y(), p.rotation_deg.z(), p.translation.x(),
                      p.translation.y(), p.translation.z());
        return std::string(buffer);
      });

  m.def(
      "random_change",
      [](const std::string& preset, std::uint64_t seed) {
        return random_pose(pose_preset(preset), seed);
      },
      py::arg("preset"), py::arg("seed"));
  m.def(
      "random_change_in",
      [](double max_rotation_deg, double max_translation, std::uint64_t seed) {
        if (!(max_rotation_deg >= 0 && max_rotation_deg <= 180) || !(max_translation >= 0) ||
            !std::isfinite(max_translation)) {
          throw Error("max_rotation_deg must be in [0, 180] and max_translation finite and >= 0");
        }
        return random_pose(PosePreset{"custom", max_rotation_deg, max_translation}, seed);
      },
      py::arg("max_rotation_deg"), py::arg("max_translation"), py::arg("seed"));
  m.def("presets", [] {
    py::dict out;
    for (const PosePreset& p : pose_presets()) {
      out[py::str(std::string(p.name))] = py::make_tuple(p.max_rotation_deg, p.max_translation);
    }
    return out;
  });
  m.def("depth_priors", [] { return depth_prior_names(); }, "The depth priors' names.");
  m.def("sampling_names", [] { return sampling_names(); }, "The sampling modes' names.");
  m.def("depth_values_names", [] { return depth_values_names(); }, "What depth maps' values can be.");
  m.def("check_depth_prior", [](const std::string& name) { depth_prior(name); },
        "Raises fishcam.Error naming the choices unless name is a depth prior.");
  m.def("check_preset", [](const std::string& name) { pose_preset(name); },
        "Raises fishcam.Error naming the choices unless name is a pose preset.");
  m.def("derive_seed", &derive_seed, py::arg("seed"), py::arg("key"), py::arg("index"));

  py::class_<ViewpointWarp>(m, "ViewpointWarp")
      .def(py::init([](const Camera& source, std::optional<Camera> target) {
             py::gil_scoped_release release;
             return target ? ViewpointWarp(source, *target) : ViewpointWarp(source);
           }),
           py::arg("camera"), py::arg("target") = py::none())
      .def_property_readonly("source", &ViewpointWarp::source)
      .def_property_readonly("target", &ViewpointWarp::target)
      .def_property_readonly("float_kernel", &ViewpointWarp::float_kernel)
      .def(
          "maps",
          [](const ViewpointWarp& warp, const RandomPose& change, const std::string& depth, const std::string& kind,
             bool exact, bool grid) {
            const DepthPrior prior = depth_prior(depth);
            const MapKind map = map_kind(kind);
            if (exact && map != MapKind::geometric) throw Error("exact: only geometric maps have an exact path");
            if (grid && (exact || map != MapKind::geometric)) throw Error("grid: gives geometric maps, not exact ones");
            const int h = warp.target().height(), w = warp.target().width();
            py::array_t<float> map_x({h, w}), map_y({h, w});
            py::array_t<bool> valid({h, w});
            WarpMaps maps;
            // Preallocated outputs: the library writes into the numpy buffers.
            maps.map_x = cv::Mat(h, w, CV_32FC1, map_x.mutable_data());
            maps.map_y = cv::Mat(h, w, CV_32FC1, map_y.mutable_data());
            if (map == MapKind::geometric) maps.valid = cv::Mat(h, w, CV_8UC1, valid.mutable_data());
            {
              py::gil_scoped_release release;
              if (exact) {
                warp.compute_exact(change.change(), prior, &maps);
              } else if (grid) {
                warp.compute_grid(change.change(), prior, &maps);
              } else {
                warp.compute(change.change(), prior, &maps, map);
              }
              if (maps.map_x.data != static_cast<void*>(map_x.mutable_data()) ||
                  maps.map_y.data != static_cast<void*>(map_y.mutable_data())) {
                throw Error("internal: a map was reallocated");
              }
              if (map == MapKind::sampling) {
                cv::Mat header(h, w, CV_8UC1, valid.mutable_data());
                maps.validity().copyTo(header);  // same size and type: written in place
              }
            }
            return py::make_tuple(map_x, map_y, valid);
          },
          py::arg("change"), py::arg("depth") = "source-sphere", py::arg("kind") = "geometric",
          py::arg("exact") = false, py::arg("grid") = false)
      .def(
          "warp",
          [](const ViewpointWarp& warp, std::optional<py::array> image, std::optional<py::array> labels,
             const RandomPose& change, const std::string& depth, double fill, int label_fill, bool return_valid,
             const std::string& sampling) {
            const DepthPrior prior = depth_prior(depth);
            const Sampling how = sampling_of(sampling);
            const cv::Size source(warp.source().width(), warp.source().height());
            const cv::Size target(warp.target().width(), warp.target().height());
            // The same calls as `fishcam augment`.
            return resample(image, labels, source, target, fill, label_fill, return_valid,
                            [&](const AugmentIO& io) { warp.augment(change.change(), prior, io, how); });
          },
          py::arg("image") = py::none(), py::arg("labels") = py::none(), py::arg("change"),
          py::arg("depth") = "source-sphere", py::arg("fill") = 0.0, py::arg("label_fill") = 0,
          py::arg("return_valid") = false, py::arg("sampling") = "grid")
      .def(
          "sampling_grid",
          [](const ViewpointWarp& warp, const RandomPose& change, const std::string& depth) {
            const DepthPrior prior = depth_prior(depth);
            const int h = warp.target().height(), w = warp.target().width();
            const int sw = warp.source().width(), sh = warp.source().height();
            py::array_t<float> grid({h, w, 2});
            py::array_t<bool> valid({h, w});
            {
              py::gil_scoped_release release;
              WarpMaps maps;
              warp.compute_grid(change.change(), prior, &maps);
              // torch.nn.functional.grid_sample's coordinates with align_corners=True:
              // -1 and 1 on the outer pixel centres; sources in the outer half pixel
              // clamped onto them (as fishcam's resampling does); 0 where there is none.
              const float sx = sw > 1 ? 2.0f / float(sw - 1) : 0.0f, sy = sh > 1 ? 2.0f / float(sh - 1) : 0.0f;
              float* out = grid.mutable_data();
              bool* ok = valid.mutable_data();
              for (int v = 0; v < h; ++v) {
                const float* x = maps.map_x.ptr<float>(v);
                const float* y = maps.map_y.ptr<float>(v);
                const uchar* inside = maps.valid.ptr<uchar>(v);
                for (int u = 0; u < w; ++u, out += 2, ++ok) {
                  *ok = inside[u] != 0;
                  out[0] = *ok ? std::clamp(x[u], 0.0f, float(sw - 1)) * sx - 1 : 0.0f;
                  out[1] = *ok ? std::clamp(y[u], 0.0f, float(sh - 1)) * sy - 1 : 0.0f;
                }
              }
            }
            return py::make_tuple(grid, valid);
          },
          py::arg("change"), py::arg("depth") = "source-sphere",
          "The grid path's maps as torch.nn.functional.grid_sample takes them (align_corners=True): "
          "(grid (H, W, 2) float32 in [-1, 1], valid (H, W) bool)")
      .def(
          "forward",
          [](const ViewpointWarp& warp, const py::handle& points, const RandomPose& change, const std::string& depth) {
            const DepthPrior prior = depth_prior(depth);
            return batch<2, 2>(points, "points", [&](auto in, auto out, auto ok) {
              warp.forward(change.change(), prior, in, out, ok);
            });
          },
          py::arg("points"), py::arg("change"), py::arg("depth") = "source-sphere",
          "Where source pixels (N, 2) appear after the change: (pixels (N, 2) float64, NaN where none; "
          "visible (N,) bool: inside the output and not hidden)")
      .def(
          "warp_depth",
          [](const ViewpointWarp& warp, py::array depth_map, const RandomPose& change, const std::string& depth,
             const std::string& values, float fill) {
            const DepthPrior prior = depth_prior(depth);
            const auto kind = parse_depth_values(values);
            if (!kind) {
              throw Error("values: expected " + choices_for_message(depth_values_names()) + ", got " +
                          quoted_for_message(values));
            }
            if (!py::isinstance<py::array_t<float>>(depth_map) || depth_map.ndim() != 2) {
              throw Error("depth_map: expected an HxW float32 array, got " + std::string(py::str(depth_map.dtype())) +
                          " with " + std::to_string(depth_map.ndim()) + " dimensions");
            }
            cv::Mat in = as_mat(depth_map, "depth_map", false);
            cv::Mat out_header;
            py::array out = new_image(depth_map, warp.target().height(), warp.target().width(), &out_header);
            const uchar* before = out_header.data;
            {
              py::gil_scoped_release release;
              warp.warp_depth(change.change(), prior, in, *kind, &out_header, fill);
            }
            if (out_header.data != before) throw Error("internal: an output was reallocated");
            return out;
          },
          py::arg("depth_map"), py::arg("change"), py::arg("depth") = "source-sphere", py::arg("values") = "range",
          py::arg("fill") = std::numeric_limits<float>::quiet_NaN(),
          "A depth map (HxW float32, range or z) seen from the moved camera: nearest-neighbour sampled, values "
          "re-expressed in the moved camera (exact for rotations); fill where there is no source")
      .def_property_readonly("grid_spacing", &ViewpointWarp::grid_spacing)
      .def_property_readonly("grid_error_px", &ViewpointWarp::grid_error_px)
      .def(py::pickle(
          [](const ViewpointWarp& w) { return py::make_tuple(camera_state(w.source()), camera_state(w.target())); },
          [](const py::tuple& t) {
            return ViewpointWarp(camera_from_state(t[0].cast<std::string>()),
                                 camera_from_state(t[1].cast<std::string>()));
          }));

  py::class_<AffineChange>(m, "AffineChange")
      .def(py::init([](double rotation_deg, const Eigen::Vector2d& translation, double scale) {
             AffineChange change{rotation_deg, translation, scale};
             check_affine(change);
             return change;
           }),
           py::arg("rotation_deg") = 0.0, py::arg("translation") = Eigen::Vector2d::Zero(), py::arg("scale") = 1.0)
      .def_readonly("rotation_deg", &AffineChange::rotation_deg)
      .def_readonly("translation", &AffineChange::translation)
      .def_readonly("scale", &AffineChange::scale)
      .def(py::pickle([](const AffineChange& c) { return py::make_tuple(c.rotation_deg, c.translation, c.scale); },
                      [](const py::tuple& t) {
                        AffineChange c{t[0].cast<double>(), t[1].cast<Eigen::Vector2d>(), t[2].cast<double>()};
                        check_affine(c);
                        return c;
                      }))
      .def("__repr__", [](const AffineChange& c) {
        char buffer[200];
        std::snprintf(buffer, sizeof buffer, "AffineChange(rotation_deg=%.17g, translation=(%.17g, %.17g), scale=%.17g)",
                      c.rotation_deg, c.translation.x(), c.translation.y(), c.scale);
        return std::string(buffer);
      });
  m.def(
      "random_affine",
      [](const std::string& preset, std::uint64_t seed) {
        return random_affine(affine_preset(preset), seed);
      },
      py::arg("preset"), py::arg("seed"));
  m.def(
      "random_affine_in",
      [](double max_rotation_deg, double max_translation, double min_scale, double max_scale, std::uint64_t seed) {
        if (!(max_rotation_deg >= 0 && max_rotation_deg <= 180) || !(max_translation >= 0) ||
            !std::isfinite(max_translation) || !(min_scale > 0) || !(max_scale >= min_scale) ||
            !std::isfinite(max_scale)) {
          throw Error("max_rotation_deg must be in [0, 180], max_translation finite and >= 0, and "
                      "0 < min_scale <= max_scale finite");
        }
        return random_affine(AffinePreset{"custom", max_rotation_deg, max_translation, min_scale, max_scale}, seed);
      },
      py::arg("max_rotation_deg"), py::arg("max_translation"), py::arg("min_scale"), py::arg("max_scale"),
      py::arg("seed"));
  m.def(
      "affine_forward",
      [](const py::handle& points, const AffineChange& change, int width, int height) {
        check_affine(change);
        if (width < 1 || height < 1) throw Error("affine_forward: image size must be positive");
        const cv::Size size(width, height);
        const double w = width - 0.5, h = height - 0.5;
        return batch<2, 2>(points, "points", [&](auto in, auto out, auto ok) {
          for (size_t i = 0; i < in.size(); ++i) {
            out[i] = affine_forward(change, size, in[i]);
            ok[i] = out[i].x() >= -0.5 && out[i].x() < w && out[i].y() >= -0.5 && out[i].y() < h;
          }
        });
      },
      py::arg("points"), py::arg("change"), py::arg("width"), py::arg("height"),
      "Where points (N, 2) land under the affine change: (pixels (N, 2), visible (N,) bool: inside the image)");
  m.def(
      "affine_warp_depth",
      [](py::array depth_map, const AffineChange& change, float fill) {
        if (!py::isinstance<py::array_t<float>>(depth_map) || depth_map.ndim() != 2) {
          throw Error("depth_map: expected an HxW float32 array, got " + std::string(py::str(depth_map.dtype())) +
                      " with " + std::to_string(depth_map.ndim()) + " dimensions");
        }
        cv::Mat in = as_mat(depth_map, "depth_map", false), out_header;
        py::array out = new_image(depth_map, in.rows, in.cols, &out_header);
        py::gil_scoped_release release;
        WarpMaps maps;
        affine_maps(change, in.size(), &maps);
        // No camera model: the values are kept, sampled as labels (never blended).
        cv::remap(in, out_header, maps.map_x, maps.map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(fill));
        return out;
      },
      py::arg("depth_map"), py::arg("change"), py::arg("fill") = std::numeric_limits<float>::quiet_NaN());
  m.def("affine_presets", [] {
    py::dict out;
    for (const AffinePreset& p : affine_presets()) {
      out[py::str(std::string(p.name))] = py::make_tuple(p.max_rotation_deg, p.max_translation, p.min_scale, p.max_scale);
    }
    return out;
  });
  m.def(
      "affine_warp",
      [](std::optional<py::array> image, std::optional<py::array> labels, const AffineChange& change, double fill,
         int label_fill, bool return_valid) {
        if (!image && !labels) throw Error("nothing to transform: pass image= and/or labels=");
        const py::array& given = image ? *image : *labels;
        if (given.ndim() < 2) throw Error(std::string(image ? "image" : "labels") + ": expected an HxW array");
        const cv::Size size(static_cast<int>(given.shape(1)), static_cast<int>(given.shape(0)));
        return resample(image, labels, size, size, fill, label_fill, return_valid,
                        [&](const AugmentIO& io) { affine_augment(change, size, io); });
      },
      py::arg("image") = py::none(), py::arg("labels") = py::none(), py::arg("change"), py::arg("fill") = 0.0,
      py::arg("label_fill") = 0, py::arg("return_valid") = false);

  m.def("set_num_threads", [](int n) {
    if (n < 1 || n > 1024) throw Error("set_num_threads: expected 1 to 1024, got " + std::to_string(n));
    cv::setNumThreads(n);
  });
  m.def("get_num_threads", [] { return cv::getNumThreads(); });

  // For the zero-copy tests: the address of the memory the bindings compute on
  // for an input (points with k columns, or an image / labels).
  m.def("_input_address", [](py::object input, const std::string& as) -> std::uintptr_t {
    if (as == "points3" || as == "points2") {
      return reinterpret_cast<std::uintptr_t>(rows_of(input, as == "points3" ? 3 : 2, "points").data());
    }
    py::array array = py::array::ensure(input);
    return reinterpret_cast<std::uintptr_t>(as_mat(array, as.c_str(), as == "labels").data);
  });
}

// Integer labels of any shape as a LabelSpan over the array's own memory (a
// C-contiguous copy only when it is strided); `keep` holds that memory.
LabelSpan labels_of(const py::handle& input, const char* what, py::array* keep) {
  *keep = py::array::ensure(input, py::array::c_style);
  if (!*keep) throw Error(std::string(what) + ": expected an array of integer labels");
  const py::array& a = *keep;
  const auto n = static_cast<std::size_t>(a.size());
  if (py::isinstance<py::array_t<std::uint8_t>>(a)) return std::span(static_cast<const std::uint8_t*>(a.data()), n);
  if (py::isinstance<py::array_t<std::uint16_t>>(a)) return std::span(static_cast<const std::uint16_t*>(a.data()), n);
  if (py::isinstance<py::array_t<std::int32_t>>(a)) return std::span(static_cast<const std::int32_t*>(a.data()), n);
  if (py::isinstance<py::array_t<std::int64_t>>(a)) return std::span(static_cast<const std::int64_t*>(a.data()), n);
  throw Error(std::string(what) + ": expected dtype uint8, uint16, int32 or int64, got " + std::string(py::str(a.dtype())));
}

std::string shape_text(const py::array& a) {
  std::string out = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) out += (i ? ", " : "") + std::to_string(a.shape(i));
  return out + (a.ndim() == 1 ? ",)" : ")");
}

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
          } else if (py::isinstance<py::tuple>(item) && py::len(item) == 2 && py::isinstance<Camera>(item[py::int_(1)])) {
            alternatives.push_back({py::str(item[py::int_(0)]), "given", item[py::int_(1)].cast<Camera>(), std::nullopt});
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
        return comparison_json(compare_models(camera, alternatives, options, named));
      },
      py::arg("camera"), py::arg("models"), py::arg("method"), py::arg("preset"), py::arg("samples"), py::arg("seed"),
      py::arg("depth"), py::arg("labels"));
}

void bind_metrics(py::module_& m) {
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
          py::arg("prediction"), py::arg("ground_truth"), py::arg("valid") = py::none())
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

}  // namespace
}  // namespace fishcam::python

PYBIND11_MODULE(_fishcam, m) {
  using fishcam::Error;
  m.doc() = "fishcam's C++ library (use the fishcam package, not this module)";
  static py::exception<Error> error(m, "Error", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    } catch (const cv::Exception& e) {
      PyErr_SetString(error.ptr(), ("OpenCV: " + e.err).c_str());
    }
  });
  m.attr("__version__") = FISHCAM_VERSION;
  fishcam::python::bind_camera(m);
  fishcam::python::bind_augmentation(m);
  fishcam::python::bind_metrics(m);
  fishcam::python::bind_comparison(m);
}
