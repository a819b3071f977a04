// Viewpoint changes, warps and the affine baseline; the thread count.
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include "bindings.hpp"
#include "fishcam/augment/affine.hpp"
#include "fishcam/augment/augmentation.hpp"

namespace fishcam::python {
namespace {

MapKind map_kind(const std::string& name) {
  const auto kind = parse_map_kind(name);
  if (!kind)
    throw Error("kind: expected " + choices_for_message(map_kind_names()) + ", got " + quoted_for_message(name));
  return *kind;
}

ViewpointChange change_from(const Eigen::Vector3d& rotation_deg, const Eigen::Vector3d& translation) {
  if (!rotation_deg.allFinite()) throw Error("rotation_deg: must be finite");
  if (!translation.allFinite()) throw Error("translation: must be finite");
  return ViewpointChange{rotation_deg, translation};
}

// What `fishcam augment` writes, into new numpy arrays: the image and labels (and
// optionally the validity) resampled by `apply` (an AugmentIO -> outputs written in
// place) from `source` to `target` size, the GIL released around the compute.
template <class Apply>
py::dict resample(std::optional<py::array> image, std::optional<py::array> labels, cv::Size source, cv::Size target,
                  double fill, int label_fill, bool return_valid, const Apply& apply) {
  py::dict out;
  cv::Mat image_in, labels_in, image_out, labels_out, valid_out;
  // A channels-first image: its planes and the output's, handed over where they lie.
  std::vector<cv::Mat> in_planes, out_planes;
  const bool planar = image && is_planar_view(*image);
  if (planar) {
    in_planes = image_planes(*image, "image");
    out["image"] = new_planar_image(*image, target.height, target.width, &out_planes);
    image_in = in_planes[0];  // for the checks below: its size and depth
  } else if (image) {
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
  for (const auto& [mat, what, given] :
       {std::tuple(&image_in, "image", bool(image)), std::tuple(&labels_in, "labels", bool(labels))}) {
    if (given && mat->size() != source) {
      throw Error(std::string(what) + ": is " + std::to_string(mat->cols) + "x" + std::to_string(mat->rows) +
                  " but the camera is " + std::to_string(source.width) + "x" + std::to_string(source.height));
    }
  }
  // A fill the image's type cannot hold would be saturated or wrapped by OpenCV (2^31
  // became 0 on uint8): refused, as the transforms refuse it.
  if (image) {
    const int depth = image_in.depth();
    const auto [lowest, highest] = depth == CV_8U    ? std::pair{0.0, 255.0}
                                   : depth == CV_16U ? std::pair{0.0, 65535.0}
                                   : depth == CV_16S ? std::pair{-32768.0, 32767.0}
                                                     : std::pair{-double(std::numeric_limits<float>::max()),
                                                                 double(std::numeric_limits<float>::max())};
    const bool integral = depth == CV_8U || depth == CV_16U || depth == CV_16S;
    if (!(fill >= lowest && fill <= highest) || (integral && fill != std::floor(fill))) {
      throw Error("fill: " + number_for_message(fill) + " is not a value of the image's type (" +
                  (integral ? "integers in [" + number_for_message(lowest) + ", " + number_for_message(highest) + "]"
                            : std::string("finite float32")) +
                  ")");
    }
  }
  const std::array<const uchar*, 3> before{image_out.data, labels_out.data, valid_out.data};
  const uchar* first_plane = planar ? out_planes[0].data : nullptr;
  AugmentIO io{image && !planar ? &image_in : nullptr, &image_out,  fill,
               labels ? &labels_in : nullptr,          &labels_out, label_fill,
               return_valid ? &valid_out : nullptr};
  if (planar) io.image_planes = in_planes, io.out_image_planes = out_planes;
  apply(io);
  // The library wrote into the numpy buffers (same size and type).
  if (before != std::array<const uchar*, 3>{image_out.data, labels_out.data, valid_out.data} ||
      (planar && out_planes[0].data != first_plane)) {
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

// depth=: a prior's name, or "map" with the source image's depth map (depth_map=,
// HxW float32, range or z per depth_values=; the DepthMap holds a header on the numpy
// array, kept alive by the caller).
DepthSource depth_choice(const std::string& depth, std::optional<py::array>& depth_map, const std::string& values) {
  const auto kind = parse_depth_values(values);
  if (!kind) {
    throw Error("depth_values: expected " + choices_for_message(depth_values_names()) + ", got " +
                quoted_for_message(values));
  }
  if (depth != kDepthMapName) {
    if (depth_map) throw Error("depth_map: only used with depth=\"map\"");
    return depth_prior(depth, "depth");
  }
  if (!depth_map) throw Error("depth=\"map\" needs depth_map= (the source image's HxW float32 depth)");
  if (!py::isinstance<py::array_t<float>>(*depth_map) || depth_map->ndim() != 2) {
    throw Error("depth_map: expected an HxW float32 array, got " + std::string(py::str(depth_map->dtype())) + " with " +
                std::to_string(depth_map->ndim()) + " dimensions");
  }
  return DepthMap{as_mat(*depth_map, "depth_map", false), *kind};
}

// One augmented sample, what `fishcam augment` writes (ViewpointWarp.warp and __call__).
py::dict augment_sample(const ViewpointWarp& warp, std::optional<py::array> image, std::optional<py::array> labels,
                        const ViewpointChange& change, const std::string& depth, double fill, int label_fill,
                        bool return_valid, const std::string& sampling, std::optional<py::array> depth_map,
                        const std::string& depth_values) {
  const DepthSource depth_source = depth_choice(depth, depth_map, depth_values);
  const Sampling how = sampling_of(sampling);
  const cv::Size source(warp.source().width(), warp.source().height());
  const cv::Size target(warp.target().width(), warp.target().height());
  return resample(image, labels, source, target, fill, label_fill, return_valid,
                  [&](const AugmentIO& io) { warp.augment(change.motion(), depth_source, io, how); });
}

// ViewpointChange, Camera.augmented, the presets and seeds.
void bind_viewpoint_changes(py::module_& m) {
  py::class_<ViewpointChange>(
      m, "ViewpointChange",
      "A viewpoint change (the paper's eq. 7): a point P of the camera frame is at R P + t in the "
      "moved camera's frame; R = Rz Ry Rx of rotation_deg (x applied first), t in unit-sphere units.")
      .def(py::init(&change_from), py::arg("rotation_deg") = Eigen::Vector3d::Zero(),
           py::arg("translation") = Eigen::Vector3d::Zero(),
           "rotation_deg: (3,) degrees about x, y, z; translation: (3,).")
      .def_readonly("rotation_deg", &ViewpointChange::rotation_deg, "Degrees about x, y, z: float64 array (3,).")
      .def_readonly("translation", &ViewpointChange::translation, "t of eq. 7: float64 array (3,).")
      .def_property_readonly(
          "rotation", [](const ViewpointChange& p) { return Eigen::Matrix3d(p.motion().rotation); },
          "R of eq. 7: float64 array (3, 3).")
      .def(py::pickle([](const ViewpointChange& p) { return py::make_tuple(p.rotation_deg, p.translation); },
                      [](const py::tuple& t) {
                        return from_pickle_state("pickled ViewpointChange", [&] {
                          if (t.size() != 2)
                            throw Error("pickled ViewpointChange: expected 2 fields, got " + std::to_string(t.size()));
                          return change_from(t[0].cast<Eigen::Vector3d>(), t[1].cast<Eigen::Vector3d>());
                        });
                      }))
      .def("__repr__", [](const ViewpointChange& p) {
        char buffer[256];
        std::snprintf(buffer, sizeof buffer,
                      "ViewpointChange(rotation_deg=(%.17g, %.17g, %.17g), translation=(%.17g, %.17g, %.17g))",
                      p.rotation_deg.x(), p.rotation_deg.y(), p.rotation_deg.z(), p.translation.x(), p.translation.y(),
                      p.translation.z());
        return std::string(buffer);
      });

  // Camera.augmented takes a ViewpointChange: defined once that type is bound, so
  // its signature (and the stubs) name it.
  py::reinterpret_borrow<py::class_<Camera>>(m.attr("Camera"))
      .def(
          "augmented",
          [](const Camera& c, const ViewpointChange& change) { return augmented_camera(c, change.motion()); },
          py::arg("change"),
          "The camera of an image augmented by `change`: same intrinsics, the pose moved by the change (a camera "
          "without a pose gets one relative to its own frame)");

  m.def(
      "random_change",
      [](const std::string& preset, std::uint64_t seed) { return random_change(pose_preset(preset), seed); },
      py::arg("preset"), py::arg("seed"));
  m.def(
      "random_change_in",
      [](double max_rotation_deg, double max_translation, std::uint64_t seed) {
        if (!(max_rotation_deg >= 0 && max_rotation_deg <= 180) || !(max_translation >= 0) ||
            !std::isfinite(max_translation)) {
          throw Error("max_rotation_deg must be in [0, 180] and max_translation finite and >= 0");
        }
        return random_change(PosePreset{"custom", max_rotation_deg, max_translation}, seed);
      },
      py::arg("max_rotation_deg"), py::arg("max_translation"), py::arg("seed"));
  m.def("presets", [] {
    py::dict out;
    for (const PosePreset& p : pose_presets()) {
      out[py::str(std::string(p.name))] = py::make_tuple(p.max_rotation_deg, p.max_translation);
    }
    return out;
  });
  m.def(
      "depth_priors", [] { return depth_prior_names(); }, "The depth priors' names.");
  m.def(
      "depth_priors_and_map", [] { return depth_prior_and_map_names(); },
      "The depth priors' names and \"map\" (the source image's depth map in place of a prior).");
  m.def(
      "sampling_names", [] { return sampling_names(); }, "The sampling modes' names.");
  m.def(
      "depth_values_names", [] { return depth_values_names(); }, "What depth maps' values can be.");
  m.def(
      "check_depth_prior", [](const std::string& name) { depth_prior(name); },
      "Raises fishcam.Error naming the choices unless name is a depth prior.");
  m.def(
      "check_preset", [](const std::string& name) { pose_preset(name); },
      "Raises fishcam.Error naming the choices unless name is a pose preset.");
  m.def("derive_seed", &derive_seed, py::arg("seed"), py::arg("key"), py::arg("index"),
        "A 64-bit seed per (key, index) from one user seed (SplitMix64 over FNV-1a of the key): "
        "the seeds of augment-dataset, compare and WoodScapeDataset(seed=).");
}

// Its construction and cameras.
void def_warp_cameras(py::class_<ViewpointWarp>& cls) {
  cls.def(py::init([](const Camera& source, std::optional<Camera> target) {
            py::gil_scoped_release release;
            return target ? ViewpointWarp(source, *target) : ViewpointWarp(source);
          }),
          py::arg("camera"), py::arg("target") = py::none(),
          "camera: the images' camera; target: the output camera (default: the same).")
      .def_property_readonly(
          "source", [](const ViewpointWarp& self) -> decltype(auto) { return self.source(); }, "The images' camera.")
      .def_property_readonly(
          "target", [](const ViewpointWarp& self) -> decltype(auto) { return self.target(); }, "The output camera.")
      .def_property_readonly(
          "float_kernel", [](const ViewpointWarp& self) -> decltype(auto) { return self.float_kernel(); },
          "Whether maps come from the float kernel (within 1e-3 px), else the exact path.");
}

// ViewpointWarp.maps: the maps of a change, written into new numpy arrays.
std::tuple<py::array_t<float>, py::array_t<float>, py::array_t<bool>> warp_maps(const ViewpointWarp& warp,
                                                                                const ViewpointChange& change,
                                                                                const std::string& depth,
                                                                                const std::string& kind, bool exact,
                                                                                bool grid) {
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
      warp.compute_exact(change.motion(), prior, &maps);
    } else if (grid) {
      warp.compute_grid(change.motion(), prior, &maps);
    } else {
      warp.compute(change.motion(), prior, &maps, map);
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
  return std::tuple(map_x, map_y, valid);
}

// ViewpointWarp.sampling_grid: the grid path's maps in grid_sample's coordinates.
std::pair<py::array_t<float>, py::array_t<bool>> warp_sampling_grid(const ViewpointWarp& warp,
                                                                    const ViewpointChange& change,
                                                                    const std::string& depth) {
  const DepthPrior prior = depth_prior(depth);
  const int h = warp.target().height(), w = warp.target().width();
  const int sw = warp.source().width(), sh = warp.source().height();
  py::array_t<float> grid({h, w, 2});
  py::array_t<bool> valid({h, w});
  {
    py::gil_scoped_release release;
    WarpMaps maps;
    warp.compute_grid(change.motion(), prior, &maps);
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
  return std::pair(grid, valid);
}

// Its maps: per pixel, for remap, and for torch's grid_sample.
void def_warp_maps(py::class_<ViewpointWarp>& cls) {
  cls.def("maps", &warp_maps, py::arg("change"), py::arg("depth") = "source-sphere", py::arg("kind") = "geometric",
          py::arg("exact") = false, py::arg("grid") = false,
          "The maps of a change: (map_x, map_y (H, W) float32, valid (H, W) bool). kind='geometric': source "
          "coordinates, NaN where none; 'sampling': what resampling uses. exact=True: the double-precision "
          "reference; grid=True: the grid path's (within 1/32 px), geometric.")
      .def("warp", &augment_sample, py::kw_only(), py::arg("image") = py::none(), py::arg("labels") = py::none(),
           py::arg("change"), py::arg("depth") = "source-sphere", py::arg("fill") = 0.0, py::arg("label_fill") = 0,
           py::arg("return_valid") = false, py::arg("sampling") = "grid", py::arg("depth_map") = py::none(),
           py::arg("depth_values") = "range",
           "One augmented sample (what `fishcam augment` writes): image HxW or HxWxC (uint8, uint16, float32; "
           "bilinear) and labels HxW (uint8, uint16; nearest); a dict of new arrays: image, labels, valid when "
           "asked. depth: a prior, or \"map\" with depth_map (the source's HxW float32 range or z, "
           "depth_values; exact, no source where the source never saw the scene).")
      .def("sampling_grid", &warp_sampling_grid, py::arg("change"), py::arg("depth") = "source-sphere",
           "The grid path's maps as torch.nn.functional.grid_sample takes them (align_corners=True): "
           "(grid (H, W, 2) float32 in [-1, 1], valid (H, W) bool)");
}

// What it moves besides images: points and depth maps; a sample by call.
void def_warp_targets(py::class_<ViewpointWarp>& cls) {
  cls.def(
         "forward",
         [](const ViewpointWarp& warp, const py::handle& points, const ViewpointChange& change,
            const std::string& depth, std::optional<py::array> depth_map, const std::string& depth_values) {
           const DepthSource source = depth_choice(depth, depth_map, depth_values);
           return batch<2, 2>(points, "points",
                              [&](auto in, auto out, auto ok) { warp.forward(change.motion(), source, in, out, ok); });
         },
         py::arg("points"), py::arg("change"), py::arg("depth") = "source-sphere", py::arg("depth_map") = py::none(),
         py::arg("depth_values") = "range",
         "Where source pixels (N, 2) appear after the change: (pixels (N, 2) float64, NaN where none; "
         "visible (N,) bool: inside the output and not hidden)")
      .def(
          "warp_depth",
          [](const ViewpointWarp& warp, py::array depth_map, const ViewpointChange& change, const std::string& depth,
             const std::string& values, float fill) {
            const bool map = depth == kDepthMapName;  // the depth map is its own source
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
            const DepthSource source = map ? DepthSource(DepthMap{in, *kind}) : DepthSource(depth_prior(depth));
            cv::Mat out_header;
            py::array out = new_image(depth_map, warp.target().height(), warp.target().width(), &out_header);
            const uchar* before = out_header.data;
            {
              py::gil_scoped_release release;
              warp.warp_depth(change.motion(), source, in, *kind, &out_header, fill);
            }
            if (out_header.data != before) throw Error("internal: an output was reallocated");
            return out;
          },
          py::arg("depth_map"), py::arg("change"), py::arg("depth") = "source-sphere", py::arg("values") = "range",
          py::arg("fill") = std::numeric_limits<float>::quiet_NaN(),
          "A depth map (HxW float32, range or z) seen from the moved camera: nearest-neighbour sampled, values "
          "re-expressed in the moved camera (exact for rotations; with depth=\"map\", the map is the prior: exact); "
          "fill where there is no source")
      .def("__call__", &augment_sample, py::kw_only(), py::arg("image") = py::none(), py::arg("labels") = py::none(),
           py::arg("change"), py::arg("depth") = "source-sphere", py::arg("fill") = 0.0, py::arg("label_fill") = 0,
           py::arg("return_valid") = false, py::arg("sampling") = "grid", py::arg("depth_map") = py::none(),
           py::arg("depth_values") = "range",
           "warp(...): one augmented sample (what `fishcam augment` writes): image HxW or HxWxC (uint8, uint16, "
           "float32; "
           "bilinear) and labels HxW (uint8, uint16; nearest); a dict of new arrays: image, labels, valid when "
           "asked.");
}

// Its grid path, and pickling.
void def_warp_grid_and_pickle(py::class_<ViewpointWarp>& cls) {
  cls.def_property_readonly(
         "grid_spacing", [](const ViewpointWarp& self) -> decltype(auto) { return self.grid_spacing(); },
         "The grid path's node spacing in pixels (0: no grid, per-pixel maps).")
      .def_property_readonly(
          "grid_error_px", [](const ViewpointWarp& self) -> decltype(auto) { return self.grid_error_px(); },
          "The grid's measured worst interpolation error against the per-pixel map (px).")
      .def(py::pickle(
          [](const ViewpointWarp& w) { return py::make_tuple(camera_state(w.source()), camera_state(w.target())); },
          [](const py::tuple& t) {
            return from_pickle_state("pickled ViewpointWarp", [&] {
              if (t.size() != 2)
                throw Error("pickled ViewpointWarp: expected 2 fields, got " + std::to_string(t.size()));
              return ViewpointWarp(camera_from_state(t[0].cast<std::string>()),
                                   camera_from_state(t[1].cast<std::string>()));
            });
          }));
}

// ViewpointWarp: the maps, samples, points and depth maps of a viewpoint change.
void bind_viewpoint_warp(py::module_& m) {
  py::class_<ViewpointWarp> warp_class(
      m, "ViewpointWarp",
      "The viewpoint augmentation of one calibration (source camera -> target camera, the same "
      "by default): caches the target's rays and the grid plan, so keep one per calibration.");
  def_warp_cameras(warp_class);
  def_warp_maps(warp_class);
  def_warp_targets(warp_class);
  def_warp_grid_and_pickle(warp_class);
}

// AffineChange: one draw of the affine baseline.
void bind_affine_change(py::module_& m) {
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
                        return from_pickle_state("pickled AffineChange", [&] {
                          if (t.size() != 3)
                            throw Error("pickled AffineChange: expected 3 fields, got " + std::to_string(t.size()));
                          AffineChange c{t[0].cast<double>(), t[1].cast<Eigen::Vector2d>(), t[2].cast<double>()};
                          check_affine(c);
                          return c;
                        });
                      }))
      .def("__repr__", [](const AffineChange& c) {
        char buffer[200];
        std::snprintf(buffer, sizeof buffer,
                      "AffineChange(rotation_deg=%.17g, translation=(%.17g, %.17g), scale=%.17g)", c.rotation_deg,
                      c.translation.x(), c.translation.y(), c.scale);
        return std::string(buffer);
      });
}

// The affine baseline's draws, presets and warp.
void bind_affine_functions(py::module_& m) {
  m.def(
      "random_affine",
      [](const std::string& preset, std::uint64_t seed) { return random_affine(affine_preset(preset), seed); },
      py::arg("preset"), py::arg("seed"));
  m.def(
      "random_affine_in",
      [](double max_rotation_deg, double max_translation, double min_scale, double max_scale, std::uint64_t seed) {
        if (!(max_rotation_deg >= 0 && max_rotation_deg <= 180) || !(max_translation >= 0) ||
            !std::isfinite(max_translation) || !(min_scale > 0) || !(max_scale >= min_scale) ||
            !std::isfinite(max_scale)) {
          throw Error(
              "max_rotation_deg must be in [0, 180], max_translation finite and >= 0, and "
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
      out[py::str(std::string(p.name))] =
          py::make_tuple(p.max_rotation_deg, p.max_translation, p.min_scale, p.max_scale);
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
      py::kw_only(), py::arg("image") = py::none(), py::arg("labels") = py::none(), py::arg("change"),
      py::arg("fill") = 0.0, py::arg("label_fill") = 0, py::arg("return_valid") = false);
}

// The affine baseline: AffineChange, its draws and its warp.
void bind_affine(py::module_& m) {
  bind_affine_change(m);
  bind_affine_functions(m);
}

// The thread count, and what the zero-copy tests ask.
void bind_threads_and_test_hooks(py::module_& m) {
  m.def("set_num_threads", [](int n) {
    if (n < 1 || n > 1024) throw Error("set_num_threads: expected 1 to 1024, got " + std::to_string(n));
    cv::setNumThreads(n);
  });
  m.def(
      "get_num_threads", [] { return cv::getNumThreads(); }, "The threads fishcam's compute uses (int).");

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

}  // namespace

void bind_augmentation(py::module_& m) {
  bind_viewpoint_changes(m);
  bind_viewpoint_warp(m);
  bind_affine(m);
  bind_threads_and_test_hooks(m);
}

}  // namespace fishcam::python
