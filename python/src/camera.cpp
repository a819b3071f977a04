// fishcam.Camera and fishcam.convert.
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>

#include "bindings.hpp"
#include "fishcam/fit/fit.hpp"

namespace fishcam::python {
namespace {

std::optional<CameraFormat> format_of(const std::optional<std::string>& name) {
  if (!name) return std::nullopt;
  const auto format = parse_camera_format(*name);
  if (!format) {
    throw Error("format: unknown camera format " + quoted_for_message(*name) +
                " (expected one of: " + camera_format_names() + ")");
  }
  return format;
}

// The camera's numbers as bytes: equal exactly when the cameras are (model, its
// parameters, size, theta limits, its pixel grid's numbers (PixelGrid::values), its
// plane distortion's (numbers_of) and, with_pose, the pose). A cache key that costs microseconds, where to_json()
// formats and reads back a file (milliseconds).
std::string parameters_key_of(const CameraParameters& p, bool with_pose) {
  std::string key(model_name(p.model));
  key.push_back('\0');
  std::vector<double> numbers = model_params(p.model);
  numbers.insert(numbers.end(), {double(p.width), double(p.height), p.theta_limit.value_or(-1.0)});
  if (p.theta_limit_by_azimuth) {
    numbers.insert(numbers.end(), p.theta_limit_by_azimuth->begin(), p.theta_limit_by_azimuth->end());
  } else {
    numbers.push_back(-1.0);
  }
  const std::vector<double> grid = p.grid.values();
  numbers.insert(numbers.end(), grid.begin(), grid.end());
  const PlaneDistortionNumbers part = numbers_of(p.distortion);  // its name and configuration, then its values
  key += part.name;
  key.push_back('\0');
  key += part.configuration;
  key.push_back('\0');
  numbers.push_back(double(part.values.size()));
  numbers.insert(numbers.end(), part.values.begin(), part.values.end());
  if (with_pose && p.pose) {
    const auto& q = p.pose->rotation;
    numbers.insert(numbers.end(), {q.w(), q.x(), q.y(), q.z(), p.pose->translation.x(), p.pose->translation.y(),
                                   p.pose->translation.z()});
  }
  key.append(reinterpret_cast<const char*>(numbers.data()), numbers.size() * sizeof(double));
  return key;
}

py::bytes parameters_key(const Camera& camera, bool with_pose) {
  return py::bytes(parameters_key_of(camera.parameters(), with_pose));
}

// Pickling, for DataLoader workers that send a camera with every sample: the
// camera's numbers (exact), and on the way back one Camera per distinct
// intrinsics kept by the process (building one computes its domain and inverse
// table, milliseconds), given the pickled pose (microseconds).
py::object camera_pickle_state(const Camera& c) {
  const CameraParameters& p = c.parameters();
  const PlaneDistortionNumbers part = numbers_of(p.distortion);
  // The record and a per-azimuth limit travel as fishcam JSON.
  if (p.calibration || p.theta_limit_by_azimuth) return py::str(format_camera(p, CameraFormat::fishcam));
  py::object pose = py::none();
  if (p.pose) {
    const auto& q = p.pose->rotation;
    const auto& t = p.pose->translation;
    pose = py::make_tuple(q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z());
  }
  return py::make_tuple(std::string(model_name(p.model)), model_params(p.model), p.width, p.height,
                        p.grid.principal_point.x(), p.grid.principal_point.y(), p.grid.pixel_scale.x(),
                        p.grid.pixel_scale.y(), p.theta_limit ? py::cast(*p.theta_limit) : py::none(), pose,
                        py::make_tuple(part.name, part.configuration, part.values),
                        py::make_tuple(p.grid.skew.xy, p.grid.skew.yx));
}

Camera camera_from_pickle_state(const py::object& state) {
  if (py::isinstance<py::str>(state)) return camera_from_state(state.cast<std::string>());  // earlier pickles
  const py::tuple t = state.cast<py::tuple>();
  if (t.size() < 10 || t.size() > 12) {
    throw Error("pickled camera: expected 12 fields, got " + std::to_string(t.size()));
  }
  CameraParameters p;
  p.model = make_model(t[0].cast<std::string>(), t[1].cast<std::vector<double>>());
  p.width = t[2].cast<int>(), p.height = t[3].cast<int>();
  p.grid.principal_point = {t[4].cast<double>(), t[5].cast<double>()};
  p.grid.pixel_scale = {t[6].cast<double>(), t[7].cast<double>()};
  if (!t[8].is_none()) p.theta_limit = t[8].cast<double>();
  if (t.size() == 12) {  // the plane distortion's numbers (numbers_of), the skew
    const auto part = t[10].cast<std::tuple<std::string, std::string, std::vector<double>>>();
    p.distortion = make_plane_distortion(std::get<0>(part), std::get<1>(part), std::get<2>(part));
    const auto skew = t[11].cast<std::array<double, 2>>();
    p.grid.skew = {skew[0], skew[1]};
  } else if (t.size() == 11) {  // earlier pickles: the tangential terms
    p.distortion = TangentialDistortion{TangentialTerms::from_values(t[10].cast<std::array<double, 6>>())};
  }
  std::optional<Pose> pose;
  if (!t[9].is_none()) {
    const auto v = t[9].cast<std::array<double, 7>>();
    pose = Pose{Eigen::Quaterniond(v[0], v[1], v[2], v[3]), {v[4], v[5], v[6]}};
  }
  // The cache holds cameras without a pose (the GIL guards it); a camera is
  // built, and so validated, the first time its numbers come.
  static std::map<std::string, Camera> cameras;
  const std::string key = parameters_key_of(p, false);
  auto it = cameras.find(key);
  if (it == cameras.end()) {
    if (cameras.size() >= 256) cameras.erase(cameras.begin());
    it = cameras.emplace(key, Camera(p)).first;
  }
  return it->second.with_pose(pose);
}

// The files it reads from and writes to.
void def_camera_files(py::class_<Camera>& cls) {
  cls.def_static(
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
         py::arg("format") = py::none(), py::arg("distortion_model") = py::none(),
         "Reads a camera file in any format fishcam knows (docs/formats.md). camera: which camera of a "
         "multi-camera file (index or name); image_size: (width, height) for files without one; format: force a "
         "reader; distortion_model: 'fisheye' or 'plumb_bob' for OpenCV files that do not say.")
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
            if (camera.parameters().calibration && !camera_format_holds_calibration_record(resolved)) {
              py::module_::import("warnings")
                  .attr("warn")("the " + std::string(to_string(resolved)) +
                                " format cannot hold the calibration record (observed angles, projection "
                                "uncertainty); " +
                                path + " was written without it (fishcam JSON keeps it)");
            }
          },
          py::arg("path"), py::arg("format") = py::none(), py::arg("overwrite") = false,
          "Writes the camera in `format` (default: from the extension); refuses an existing file unless "
          "overwrite=True, and a format that cannot hold the model. Only fishcam JSON keeps a calibration record "
          "(a UserWarning says when it is left out).");
}

// Its parts: the size, the radial model, the plane distortion, the pixel grid, the pose.
void def_camera_parts(py::class_<Camera>& cls) {
  cls.def_property_readonly(
         "width", [](const Camera& self) -> decltype(auto) { return self.width(); }, "Image width in pixels (int).")
      .def_property_readonly(
          "height", [](const Camera& self) -> decltype(auto) { return self.height(); }, "Image height in pixels (int).")
      .def_property_readonly(
          "model", [](const Camera& c) { return std::string(model_name(c.model())); },
          "The model's name (docs/conventions.md lists them), e.g. 'polynomial', 'kannala-brandt'.")
      .def_property_readonly(
          "parameters", [](const Camera& c) { return model_params(c.model()); },
          "The model's parameters (list of float), in the order docs/conventions.md gives.")
      .def_property_readonly(
          "tangential",
          [](const Camera& c) {
            std::map<std::string, double> terms;
            for (size_t i = 0; i < TangentialTerms::kNames.size(); ++i) {
              terms[std::string(TangentialTerms::kNames[i])] = c.parameters().tangential_terms().values()[i];
            }
            return terms;
          },
          "The tangential and thin-prism terms {'p1', 'p2', 's1', 's2', 's3', 's4'} (dict of float) on the model's "
          "undistorted plane (docs/conventions.md); all 0 unless distortion is 'tangential'.")
      .def_property_readonly(
          "distortion", [](const Camera& c) { return std::string(distortion_name(c.distortion())); },
          "The plane distortion's name: 'none', 'tangential' (the tangential property gives its terms) or "
          "'mrcal_lens' (the mrcal_lens property gives it); docs/architecture.md lists the parts of a camera.")
      .def_property_readonly(
          "mrcal_lens",
          [](const Camera& c) -> std::optional<std::pair<std::string, std::vector<double>>> {
            const MrcalLens* lens = c.parameters().mrcal_lens();
            if (!lens) return std::nullopt;
            return std::pair(lens->lensmodel(), lens->values());
          },
          "mrcal's lens model on the plane of the camera's model, evaluated by libmrcal (splined stereographic, "
          "CAHVOR on pinhole, CAHVORE, LONLAT and LATLON on stereographic): (lensmodel, its values after fx, fy, cx, "
          "cy), "
          "or None.")
      .def_property_readonly(
          "skew", [](const Camera& c) { return std::pair(c.skew().xy, c.skew().yx); },
          "The pixel grid's skew (xy, yx): pixel = c + a * ([[1, xy], [yx, 1]] q) with q the model's image offset "
          "(docs/conventions.md); (0, 0) for the usual grid.")
      .def_property_readonly(
          "radial", [](const Camera& self) -> decltype(auto) { return self.radial(); },
          "Whether the camera is radially symmetric (no plane distortion, no skew): only then do rho and "
          "theta_from_rho describe its whole projection.")
      .def_property_readonly(
          "principal_point", [](const Camera& c) { return Eigen::Vector2d(c.principal_point()); },
          "(cx, cy) in pixels, float64 array (2,).")
      .def_property_readonly(
          "pose",
          [](const Camera& c) -> std::optional<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> {
            const auto& pose = c.parameters().pose;
            if (!pose) return std::nullopt;
            return std::pair(Eigen::Matrix3d(pose->rotation.toRotationMatrix()), Eigen::Vector3d(pose->translation));
          },
          "The pose camera to reference, p_ref = R p_cam + t: a tuple of R (3, 3) and t (3,), or None")
      .def_property_readonly(
          "pixel_scale", [](const Camera& c) { return Eigen::Vector2d(c.pixel_scale()); },
          "(a_x, a_y): pixel = c + a * rho(theta) * direction; float64 array (2,).");
}

// What it computes: projection, unprojection, theta(rho), its domain and field of view.
void def_camera_geometry(py::class_<Camera>& cls) {
  cls.def(
         "project",
         [](const Camera& camera, const py::handle& points) {
           return batch<3, 2>(points, "points", [&](auto in, auto out, auto ok) { camera.project(in, out, ok); });
         },
         py::arg("points"),
         "Projects points (N, 3) of the camera frame: (pixels (N, 2) float64, ok (N,) bool); NaN where the "
         "point is outside the valid field of view.")
      .def(
          "unproject",
          [](const Camera& camera, const py::handle& pixels) {
            return batch<2, 3>(pixels, "pixels", [&](auto in, auto out, auto ok) { camera.unproject(in, out, ok); });
          },
          py::arg("pixels"),
          "Unit rays (N, 3) float64 of pixels (N, 2), and ok (N,) bool; NaN where a pixel has no ray.")
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
          py::arg("rho"),
          "theta (radians) of radii rho (pixels, any shape, float64; same shape out) under the radial model; NaN "
          "outside the valid domain. For a camera with tangential terms (radial is False) that is its radial part "
          "only: unproject pixels instead.")
      .def(
          "info_json", [](const Camera& c) { return camera_info_json(c); },
          "What `fishcam info --json` prints (str); the same values typed: model, parameters, principal_point, "
          "pixel_scale, domain, field_of_view_deg, pose.")
      .def(
          "resized",
          [](const Camera& c, int width, int height) { return Camera(resized(c.parameters(), width, height)); },
          py::arg("width"), py::arg("height"),
          "The same lens for the image resized to width x height: c' = (c + 0.5) s - 0.5, a' = a s.")
      .def(
          "cropped",
          [](const Camera& c, int left, int top, int width, int height) {
            return Camera(cropped(c.parameters(), left, top, width, height));
          },
          py::arg("left"), py::arg("top"), py::arg("width"), py::arg("height"),
          "The same lens for the image cropped to the width x height window whose top-left pixel is (left, top) "
          "(negative, or past the edges: a padded crop): c' = c - (left, top).")
      .def(
          "mirrored",
          [](const Camera& c, bool horizontal, bool vertical) {
            return Camera(mirrored(c.parameters(), horizontal, vertical));
          },
          py::arg("horizontal") = true, py::arg("vertical") = false,
          "The same lens for the image flipped left-right (horizontal: u -> width - 1 - u) and/or upside down "
          "(vertical): the pixel grid mirrored (c'x = width - 1 - cx, a'x = -a_x), so the camera projects every "
          "point where the flipped image shows it. Only fishcam JSON holds a mirrored camera.")
      .def_property_readonly(
          "domain", [](const Camera& self) -> decltype(auto) { return self.domain(); },
          "The model's valid domain (ValidDomain).")
      .def_property_readonly(
          "field_of_view_deg", [](const Camera& self) -> decltype(auto) { return self.field_of_view_deg(); },
          "The image's angular coverage (FieldOfView, degrees).");
}

// Its identity: equality, hashing, JSON, pickling.
void def_camera_identity(py::class_<Camera>& cls) {
  cls.def(
         "__eq__",
         [](const Camera& a, const py::object& b) {
           return py::isinstance<Camera>(b) &&
                  std::string(parameters_key(a, true)) == std::string(parameters_key(b.cast<const Camera&>(), true));
         },
         py::arg("other"), "Equal when every number of the two cameras is (parameters_key).")
      .def(
          "__hash__", [](const Camera& c) { return py::hash(parameters_key(c, true)); },
          "The hash of parameters_key(): equal cameras hash alike.")
      .def("to_json", &camera_state, "The camera as fishcam JSON text")
      .def("parameters_key", &parameters_key, py::arg("with_pose") = true,
           "bytes equal exactly when two cameras are (with_pose=False: the intrinsics and size only, what a "
           "warp depends on); cheap, for caches and hashing")
      .def_static(
          "from_json", [](const std::string& text) { return camera_from_state(text, "from_json text"); },
          py::arg("text"), "The camera of fishcam JSON text (what to_json gives).")
      .def(py::pickle(&camera_pickle_state,
                      [](const py::object& state) {
                        return from_pickle_state("pickled camera", [&] { return camera_from_pickle_state(state); });
                      }))
      .def("__repr__", [](const Camera& c) {
        return "<fishcam.Camera " + std::string(model_name(c.model())) + " " + std::to_string(c.width()) + "x" +
               std::to_string(c.height()) + ">";
      });
}

// ValidDomain and FieldOfView: what a camera reports of its coverage.
void bind_domain_and_field_of_view(py::module_& m) {
  py::class_<ValidDomain>(m, "ValidDomain",
                          "Where a camera's model is valid: theta in [0, theta_max] (closed) or [0, theta_max).")
      .def_property_readonly(
          "theta_max_deg", [](const ValidDomain& d) { return d.theta_max * 180 / std::numbers::pi; },
          "The largest valid angle of incidence (degrees).")
      .def_readonly("closed", &ValidDomain::closed, "Whether theta_max itself is valid.")
      .def_property_readonly(
          "limited_by", [](const ValidDomain& d) { return std::string(to_string(d.limited_by)); },
          "What sets theta_max: 'model', 'fold' (rho stops increasing) or 'user' (a theta limit).")
      .def_property_readonly(
          "rho_max_px",
          [](const ValidDomain& d) -> std::optional<double> {
            return d.closed ? std::optional(d.rho_max) : std::nullopt;
          },
          "rho(theta_max) in pixel-scale units, or None where the model diverges there.")
      .def("__repr__", [](const ValidDomain& d) {
        char buffer[128];
        std::snprintf(buffer, sizeof buffer, "ValidDomain(theta_max_deg=%.6g, closed=%s, limited_by='%s')",
                      d.theta_max * 180 / std::numbers::pi, d.closed ? "True" : "False", to_string(d.limited_by));
        return std::string(buffer);
      });
  py::class_<Camera::FieldOfView>(m, "FieldOfView",
                                  "The image's angular coverage through the principal point (degrees).")
      .def_readonly("horizontal", &Camera::FieldOfView::horizontal, "Degrees across the image's width.")
      .def_readonly("vertical", &Camera::FieldOfView::vertical, "Degrees across its height.")
      .def_readonly("diagonal", &Camera::FieldOfView::diagonal, "Degrees across its diagonal.")
      .def("__repr__", [](const Camera::FieldOfView& f) {
        char buffer[128];
        std::snprintf(buffer, sizeof buffer, "FieldOfView(horizontal=%.6g, vertical=%.6g, diagonal=%.6g)", f.horizontal,
                      f.vertical, f.diagonal);
        return std::string(buffer);
      });
}

// Camera, its members defined by job.
void bind_camera_class(py::module_& m) {
  py::class_<Camera> camera(
      m, "Camera",
      "A calibrated camera: a radial model rho(theta) (with tangential terms for some models), principal "
      "point, pixel scale, image size and "
      "an optional pose. Pixel centres at integer coordinates; camera frame x right, y down, z "
      "forward. Immutable; equal cameras compare equal and hash alike.");
  def_camera_files(camera);
  def_camera_parts(camera);
  def_camera_geometry(camera);
  def_camera_identity(camera);
  bind_calibration_record(camera);
}

// AngleBin and FitReport: a fit's error, overall and by angle.
void bind_fit_report(py::module_& m) {
  // fishcam convert's result, typed: the fitted camera and its error report.
  py::class_<ErrorReport::Bin>(m, "AngleBin", "A fit's error over the rays of one 10-degree band of theta.")
      .def_readonly("theta_from_deg", &ErrorReport::Bin::theta_from_deg, "The band's lower edge (degrees).")
      .def_readonly("theta_to_deg", &ErrorReport::Bin::theta_to_deg, "The band's upper edge (degrees).")
      .def_readonly("samples", &ErrorReport::Bin::samples, "Rays in the band (int).")
      .def_readonly("rms_px", &ErrorReport::Bin::rms_px, "Root mean square pixel error (2-D norm).")
      .def_readonly("max_px", &ErrorReport::Bin::max_px, "Largest pixel error.");
  py::class_<ErrorReport>(m, "FitReport",
                          "How far the fitted camera reprojects the source camera's rays (pixels, 2-D norm): what "
                          "`fishcam convert --json` prints.")
      .def_readonly("samples", &ErrorReport::samples, "Rays compared (int).")
      .def_readonly("unprojectable", &ErrorReport::unprojectable, "Rays the fitted camera cannot project (int).")
      .def_readonly("rms_px", &ErrorReport::rms_px, "Root mean square pixel error.")
      .def_readonly("p99_px", &ErrorReport::p99_px, "99th percentile of the pixel error.")
      .def_readonly("max_px", &ErrorReport::max_px, "Largest pixel error.")
      .def_readonly("samples_below_90", &ErrorReport::samples_below_90,
                    "Rays with theta < 90 deg (what OpenCV's fisheye functions can use).")
      .def_readonly("rms_below_90_px", &ErrorReport::rms_below_90_px, "RMS error over the rays below 90 deg.")
      .def_readonly("max_below_90_px", &ErrorReport::max_below_90_px, "Largest error over the rays below 90 deg.")
      .def_readonly("by_angle", &ErrorReport::by_angle, "The error per 10-degree band (list of AngleBin).")
      .def("__repr__", [](const ErrorReport& r) {
        char buffer[160];
        std::snprintf(buffer, sizeof buffer, "FitReport(rms_px=%.6g, p99_px=%.6g, max_px=%.6g, samples=%ld)", r.rms_px,
                      r.p99_px, r.max_px, r.samples);
        return std::string(buffer);
      });
}

// Conversion, and the functions that convert.
void bind_conversion_class(py::module_& m) {
  py::class_<Conversion>(m, "Conversion",
                         "fishcam.convert's result: the fitted camera and its FitReport; unpacks as "
                         "(camera, report).")
      .def_property_readonly(
          "camera", [](const Conversion& c) { return Camera(c.camera); }, "The fitted camera.")
      .def_readonly("report", &Conversion::report, "Its FitReport against the source camera.")
      .def_property_readonly(
          "widest_theta_deg", [](const Conversion& c) { return c.widest_theta * 180 / std::numbers::pi; },
          "The widest ray of the evaluation grid (degrees).")
      .def_readonly("center_and_aspect_fitted", &Conversion::center_and_aspect_fitted,
                    "Whether the principal point and a_y were fitted (always for a source with tangential terms).")
      .def_property_readonly(
          "non_radial_px",
          [](const Conversion& c) -> std::optional<std::pair<double, double>> {
            if (c.non_radial.samples == 0) return std::nullopt;
            return std::pair(c.non_radial.rms_px, c.non_radial.max_px);
          },
          "For a source that is not radially symmetric: (rms, max) pixels no radial model gets below about the "
          "fitted principal point (the best free-form rho(theta)'s error); None for a radial source.")
      .def(
          "to_json", [](const Conversion& c) { return fit_report_json(c.camera, c.report); },
          "What `fishcam convert --json` prints (str).")
      .def(
          "__iter__",
          [](const Conversion& c) { return py::iter(py::make_tuple(Camera(c.camera), py::cast(c.report))); },
          "camera, report = fishcam.convert(...)");

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
        py::gil_scoped_release release;
        return convert_camera(source, spec, method, max_theta, {fit_center, fit_aspect});
      },
      py::arg("camera"), py::arg("to"), py::arg("method") = "lsq", py::arg("max_angle") = py::none(),
      py::arg("fit_center") = false, py::arg("fit_aspect") = false,
      "Fits model `to` to `camera` as `fishcam convert` does (method 'lsq' or 'paper'; max_angle in degrees): "
      "a Conversion (camera, report).");
  m.def(
      "reprojection_error_map",
      [](const Camera& source, const Camera& fitted) {
        std::vector<float> map;
        {
          py::gil_scoped_release release;
          map = reprojection_error_map(source, fitted);
        }
        py::array_t<float> out({py::ssize_t(source.height()), py::ssize_t(source.width())});
        std::copy(map.begin(), map.end(), out.mutable_data());
        return out;
      },
      py::arg("source"), py::arg("fitted"),
      "The pixel error of `fitted` at every pixel of `source`'s image (float32 (H, W), NaN where the source has no "
      "ray or `fitted` none): what `fishcam convert --error-map` writes.");
}

// fishcam convert's result, typed: the fitted camera and its error report; the conversions.
void bind_conversion(py::module_& m) {
  bind_fit_report(m);
  bind_conversion_class(m);
}

}  // namespace

void bind_camera(py::module_& m) {
  bind_domain_and_field_of_view(m);
  bind_camera_class(m);
  bind_conversion(m);
}

}  // namespace fishcam::python
