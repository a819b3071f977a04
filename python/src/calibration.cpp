// Chessboard calibration (fishcam.calibrate, fishcam.read_corners) and what a
// calibrated camera knows about its data (Camera.projection_uncertainty, ...).
#include "fishcam/fit/calibration.hpp"
#include "bindings.hpp"
#include "fishcam/augment/target.hpp"
#include "fishcam/io/corners.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <variant>

namespace fishcam::python {
namespace {

constexpr double kDeg = 180 / std::numbers::pi;

// A chessboard's (W, H) inner corners with its spacing, or a target's text
// ("aprilgrid:COLSxROWS:SIZE:SPACING", "charuco:..."), whose sizes are in the text.
using BoardArgument = std::variant<std::pair<int, int>, std::string>;

BoardSpec board_of(const BoardArgument& board, std::optional<double> spacing) {
  if (const auto* text = std::get_if<std::string>(&board)) {
    if (spacing) throw Error("spacing: a target's sizes are in its text ('" + *text + "'): give spacing=None");
    return target_board(parse_target(*text));
  }
  if (!spacing) throw Error("spacing: a chessboard (W, H) needs its spacing in metres");
  const auto [cols, rows] = std::get<std::pair<int, int>>(board);
  BoardSpec spec{cols, rows, *spacing};
  check_board(spec);
  return spec;
}

// (filename, corners (N, 2)) pairs; a partial board: the board's W*H rows in board
// order, NaN rows for the corners not observed (what read_corners gives).
std::vector<BoardObservation> observations_of(const py::list& items, const BoardSpec& board) {
  std::vector<BoardObservation> out;
  for (const py::handle& item : items) {
    if (!py::isinstance<py::tuple>(item) || py::len(item) != 2) {
      throw Error("observations: expected (filename, corners (N, 2)) pairs");
    }
    BoardObservation o;
    o.filename = py::str(item[py::int_(0)]);
    const PointArray corners = rows_of(item[py::int_(1)], 2, "observations: corners");
    const auto* rows = reinterpret_cast<const Eigen::Vector2d*>(corners.data());
    const auto missing = [](const Eigen::Vector2d& c) { return std::isnan(c.x()) && std::isnan(c.y()); };
    const bool partial = std::any_of(rows, rows + corners.shape(0), missing);
    if (partial && corners.shape(0) != board.corners()) {
      throw Error("observations: image " + o.filename + ": a partial board (NaN rows) lists all " +
                  std::to_string(board.corners()) + " corners of the board, got " + std::to_string(corners.shape(0)));
    }
    for (py::ssize_t k = 0; k < corners.shape(0); ++k) {
      if (partial && missing(rows[k])) continue;
      o.corners.push_back(rows[k]);
      if (partial) o.ids.push_back(int(k));
    }
    out.push_back(std::move(o));
  }
  return out;
}

// The Calibration class (one camera's result).
void bind_calibration_result(py::module_& m) {
  py::class_<CalibrationResult>(m, "Calibration",
                                "A chessboard calibration (what `fishcam calibrate --json` reports), typed.")
      .def_property_readonly(
          "camera", [](const CalibrationResult& r) { return Camera(r.camera); },
          "The calibrated camera, with its calibration record (observed angles, covariance).")
      .def_readonly("rms_px", &CalibrationResult::rms_px, "RMS of the corners' 2-D reprojection error (px).")
      .def_property_readonly(
          "rms_per_coordinate_px", [](const CalibrationResult& r) { return r.rms_px / std::sqrt(2.0); },
          "The same per coordinate (what mrcal and OpenCV print): rms_px / sqrt(2).")
      .def_readonly("noise_px", &CalibrationResult::noise_px,
                    "Residual standard deviation per coordinate (px), degrees of freedom accounted for.")
      .def_readonly("corners", &CalibrationResult::observations, "Corners used (outliers excluded).")
      .def_readonly("images", &CalibrationResult::used_images, "File names of the boards used, in file order.")
      .def_readonly("per_image_rms_px", &CalibrationResult::per_image_rms_px, "RMS per image (px), as `images`.")
      .def_property_readonly(
          "parameters",
          [](const CalibrationResult& r) {
            py::dict d;
            for (size_t i = 0; i < r.parameters.size(); ++i) d[py::str(r.parameter_names[i])] = r.parameters[i];
            return d;
          },
          "Model parameters, the tangential terms solved (MODEL+tangential: p1, p2), cx, cy, a_y by name (dict of "
          "float).")
      .def_property_readonly(
          "sigmas",
          [](const CalibrationResult& r) {
            py::dict d;
            for (size_t i = 0; i < r.sigmas.size(); ++i) {
              d[py::str(r.parameter_names[i])] =
                  std::isnan(r.sigmas[i]) ? py::object(py::none()) : py::float_(r.sigmas[i]);
            }
            return d;
          },
          "1-sigma uncertainty by name (dict); None for a parameter the data do not determine.")
      .def_readonly("undetermined", &CalibrationResult::undetermined,
                    "The combinations of parameters the data do not determine (list of str).")
      .def_property_readonly(
          "outliers",
          [](const CalibrationResult& r) {
            std::vector<std::tuple<std::string, int, double>> out;
            for (const auto& o : r.outliers) out.emplace_back(o.filename, o.corner, o.error_px);
            return out;
          },
          "Corners dropped as outliers: (image, corner index, error px).")
      .def_property_readonly(
          "poses",
          [](const CalibrationResult& r) {
            std::vector<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> out;
            for (const auto& p : r.poses) out.emplace_back(p.rotation.toRotationMatrix(), p.translation);
            return out;
          },
          "Board poses, as `images`: (R, t) with p_camera = R p_board + t.")
      .def_property_readonly(
          "board_warp",
          [](const CalibrationResult& r) -> std::optional<std::pair<double, double>> {
            if (!r.board_warp) return std::nullopt;
            return std::pair(r.board_warp->x2, r.board_warp->y2);
          },
          "The boards' warp (x2, y2), board units: mrcal's calobject_warp, the deflections at the middle of the "
          "board's width and height; None where the boards were held flat (board_warp=False).")
      .def_property_readonly(
          "board_warp_sigmas",
          [](const CalibrationResult& r) -> std::optional<std::pair<double, double>> {
            if (!r.board_warp) return std::nullopt;
            return std::pair(r.board_warp_sigma.x2, r.board_warp_sigma.y2);
          },
          "Their 1-sigma (x2, y2); None where the boards were held flat.")
      .def_readonly("warnings", &CalibrationResult::warnings, "What the user should know (list of str).")
      .def("__repr__", [](const CalibrationResult& r) {
        char buffer[160];
        std::snprintf(buffer, sizeof buffer, "<fishcam.Calibration %s, %zu images, rms %.4f px>",
                      std::string(model_name(r.camera.model)).c_str(), r.used_images.size(), r.rms_px);
        return std::string(buffer);
      });
}

// Calibration (one camera) and the functions that calibrate and measure.
void bind_camera_calibration(py::module_& m) {
  bind_calibration_result(m);
  m.def(
      "read_corners",
      [](const std::string& path, const BoardArgument& board) {
        const BoardSpec spec =
            std::holds_alternative<std::string>(board) ? board_of(board, std::nullopt) : board_of(board, 1.0);
        const auto observations = read_corners(path, spec);
        std::vector<std::pair<std::string, py::array_t<double>>> out;
        const int whole = spec.corners();
        for (const auto& o : observations) {
          const py::ssize_t rows = o.ids.empty() ? py::ssize_t(o.corners.size()) : py::ssize_t(whole);
          py::array_t<double> corners({rows, py::ssize_t(2)});
          auto* to = reinterpret_cast<Eigen::Vector2d*>(corners.mutable_data());
          std::fill(to, to + rows, Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN()));
          for (size_t k = 0; k < o.corners.size(); ++k) to[o.id(k)] = o.corners[k];
          out.emplace_back(o.filename, corners);
        }
        return out;
      },
      py::arg("path"), py::arg("board"),
      "A corners file (mrcal's vnlog: filename x y level) of a board of (W, H) inner corners, or of a target "
      "(its text, as calibrate takes it; an AprilGrid of C x R tags has 2C x 2R corners): a list of "
      "(filename, corners (N, 2) float64), N = 0 for an image without a board; a partial board (rows whose "
      "level is '-') has all W*H rows in board order, NaN for the corners not observed.");
  m.def(
      "calibrate",
      [](const py::list& observations, const BoardArgument& board, std::optional<double> spacing,
         std::pair<int, int> image_size, const std::string& model, int threads, bool board_warp) {
        const BoardSpec spec = board_of(board, spacing);
        const std::vector<BoardObservation> boards = observations_of(observations, spec);
        const ModelSpec model_spec = parse_model_spec(model);
        py::gil_scoped_release release;
        return calibrate(boards, spec, image_size.first, image_size.second, model_spec, {threads, board_warp});
      },
      py::arg("observations"), py::arg("board"), py::arg("spacing"), py::arg("image_size"), py::arg("model"),
      py::arg("threads") = 1, py::arg("board_warp") = true,
      "Calibrates `model` (a model name; 'MODEL+tangential' also solves OpenCV's p1, p2 and 'MODEL+thin-prism' "
      "p1, p2, s1..s4, for pinhole, opencv and mei; mrcal's splined model by its mrcal name, "
      "'LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=200', solved as mrcal-calibrate-cameras "
      "solves it) from chessboard corners (what read_corners gives: "
      "(filename, corners (N, 2)) pairs; "
      "board (W, H) inner corners with spacing in metres, or a target's text with spacing None: "
      "'aprilgrid:COLSxROWS:SIZE:SPACING' (Kalibr's AprilGrid: tag side SIZE metres, the gap between tags SPACING "
      "times it) or 'charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY]', as `fishcam detect-corners --target` "
      "found them; image_size (width, height)): a Calibration. threads: for "
      "the independent solves; the result is the same for every count. board_warp: solve the boards' warp "
      "(mrcal's calobject_warp, as mrcal does; Calibration.board_warp), False: flat boards (OpenCV's model). Raises "
      "fishcam.Error on data that cannot "
      "determine a camera (a transposed board, one pose, a principal point off the image, ...).");
}

// RigCalibration and calibrate_rig.
void bind_rig_calibration(py::module_& m) {
  py::class_<RigCalibrationResult>(m, "RigCalibration",
                                   "A camera rig's joint calibration (what `fishcam calibrate --corners A --corners B "
                                   "... --json` reports), typed.")
      .def_readonly("cameras", &RigCalibrationResult::cameras,
                    "Per camera its Calibration; camera.pose is camera -> camera 0.")
      .def_property_readonly(
          "rotation_sigma_deg",
          [](const RigCalibrationResult& r) {
            std::vector<double> out;
            for (double s : r.rotation_sigma_rad) out.push_back(s * kDeg);
            return out;
          },
          "Per camera, 1-sigma of its rotation relative to camera 0 (degrees; the largest angle-axis component).")
      .def_readonly("translation_sigma", &RigCalibrationResult::translation_sigma,
                    "Per camera, 1-sigma of its translation relative to camera 0 (board units; the largest "
                    "component).")
      .def_readonly("fixed_intrinsics", &RigCalibrationResult::fixed_intrinsics,
                    "Per camera, whether its intrinsics were held fixed (given as a Camera) or solved.")
      .def_readonly("rms_px", &RigCalibrationResult::rms_px, "RMS 2-D reprojection error over every camera (px).")
      .def_readonly("instants", &RigCalibrationResult::instants, "Distinct instants with a board.")
      .def_readonly("warnings", &RigCalibrationResult::warnings, "What the user should know (list of str).")
      .def("__repr__", [](const RigCalibrationResult& r) {
        return "<fishcam.RigCalibration " + std::to_string(r.cameras.size()) + " cameras, " +
               std::to_string(r.instants) + " instants>";
      });
  m.def(
      "calibrate_rig",
      [](const py::list& cameras, const BoardArgument& board, std::optional<double> spacing, int threads,
         bool board_warp) {
        const BoardSpec spec = board_of(board, spacing);
        std::vector<RigCamera> rig;
        for (const py::handle& item : cameras) {
          if (!py::isinstance<py::tuple>(item) || py::len(item) != 3) {
            throw Error("cameras: expected (observations, (width, height), model) per camera");
          }
          RigCamera camera;
          camera.observations = observations_of(item[py::int_(0)].cast<py::list>(), spec);
          std::tie(camera.width, camera.height) = item[py::int_(1)].cast<std::pair<int, int>>();
          // A model name solves the camera's intrinsics; a Camera holds them fixed.
          if (const py::handle model = item[py::int_(2)]; py::isinstance<Camera>(model)) {
            camera.fixed_intrinsics = model.cast<const Camera&>().parameters();
          } else if (py::isinstance<py::str>(model)) {
            camera.model = parse_model_spec(model.cast<std::string>());
          } else {
            throw Error("cameras[" + std::to_string(rig.size()) +
                        "]: expected a model name or a fishcam.Camera (intrinsics held fixed), got " +
                        std::string(py::str(model.get_type().attr("__name__"))));
          }
          rig.push_back(std::move(camera));
        }
        py::gil_scoped_release release;
        return calibrate_rig(rig, spec, {threads, board_warp});
      },
      py::arg("cameras"), py::arg("board"), py::arg("spacing"), py::arg("threads") = 1, py::arg("board_warp") = true,
      "Calibrates a camera rig jointly: cameras is a list of (observations, (width, height), model), one per "
      "camera, observations as read_corners gives them; board and spacing as calibrate takes them (a chessboard "
      "or a target); images of one instant share their file name (the last "
      "path component). model: a model name (the camera's intrinsics solved) or a fishcam.Camera for those "
      "images (its intrinsics held fixed, as calibrate --fix-intrinsics FILE: only where it sits is solved). "
      "Every solved camera's intrinsics, each camera's pose relative to camera 0 and the boards' poses: a "
      "RigCalibration. board_warp: solve the boards' warp in the joint solve (mrcal's calobject_warp, as mrcal "
      "does; every camera's Calibration.board_warp), False: flat boards (OpenCV's stereoCalibrate). Raises "
      "fishcam.Error when a camera cannot be calibrated alone or shares no instant.");
}

}  // namespace

void bind_calibration(py::module_& m) {
  bind_camera_calibration(m);
  bind_rig_calibration(m);
}

void bind_calibration_record(py::class_<Camera>& camera) {
  camera
      .def_property_readonly(
          "observed_theta_max_deg",
          [](const Camera& c) -> std::optional<double> {
            const auto& r = c.parameters().calibration;
            return r ? std::optional(r->theta_max * kDeg) : std::nullopt;
          },
          "The largest angle of incidence its calibration observed (degrees), or None for a camera without a "
          "calibration record.")
      .def(
          "observed",
          [](const Camera& c, const py::handle& rays) {
            const auto& r = c.parameters().calibration;
            if (!r) throw Error("observed: the camera carries no calibration record");
            const PointArray rows = rows_of(rays, 3, "rays");
            py::array_t<bool> out{rows.shape(0)};
            const auto* in = reinterpret_cast<const Eigen::Vector3d*>(rows.data());
            for (py::ssize_t i = 0; i < rows.shape(0); ++i) out.mutable_data()[i] = r->observed(in[i]);
            return out;
          },
          py::arg("rays"),
          "Whether camera-frame rays (N, 3) lie within the angles its calibration observed (per 15-degree azimuth "
          "sector, each sector's angle holding up to the middle of its neighbours): (N,) bool.")
      .def(
          "limited_to_observed",
          [](const Camera& c, double margin_deg) {
            return Camera(limited_to_observed(c.parameters(), margin_deg / kDeg));
          },
          py::arg("margin_deg") = 0.0,
          "The camera with its valid domain capped at the observed angles plus margin_deg, per azimuth "
          "(`--theta-limit data+DEG`): with margin_deg = 0 it unprojects exactly the pixels whose rays "
          "observed() accepts.")
      .def_property_readonly(
          "theta_limit_by_azimuth_deg",
          [](const Camera& c) -> std::optional<std::vector<double>> {
            const auto& limit = c.parameters().theta_limit_by_azimuth;
            if (!limit) return std::nullopt;
            std::vector<double> degrees;
            for (double a : *limit) degrees.push_back(a * kDeg);
            return degrees;
          },
          "The per-azimuth cap on the angle of incidence (degrees; 24 sectors of 15 degrees, sector k covering "
          "azimuths atan2(y, x) in [-180 + 15 k, -165 + 15 k)), or None: limited_to_observed sets it.")
      .def(
          "projection_uncertainty",
          [](const Camera& c, const py::handle& pixels, std::optional<double> distance) {
            const PointArray rows = rows_of(pixels, 2, "pixels");
            const size_t n = size_t(rows.shape(0));
            py::array_t<double> out{py::ssize_t(n)};
            const auto* in = reinterpret_cast<const Eigen::Vector2d*>(rows.data());
            double* values = out.mutable_data();
            if (n > 0) values[0] = projection_uncertainty(c, in[0], distance);  // errors with the GIL held
            py::gil_scoped_release release;
            for (size_t i = 1; i < n; ++i) values[i] = projection_uncertainty(c, in[i], distance);
            return out;
          },
          py::arg("pixels"), py::arg("distance") = py::none(),
          "Projection uncertainty (mrcal's definition, worst-direction 1-sigma, px) at pixels (N, 2): how far the "
          "projection of a point fixed relative to the calibration boards, seen there, moves through "
          "calibrations perturbed by the corner noise. distance: along the ray in board units (metres); None: "
          "at infinity. NaN where a pixel has no ray. Needs a camera written by calibration (fishcam JSON).");
}

}  // namespace fishcam::python
