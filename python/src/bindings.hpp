// The bindings' shared pieces: numpy <-> library plumbing (zero-copy inputs when
// C-contiguous, outputs allocated as numpy arrays and written in place) and the
// camera's state, for the per-area binding files (camera.cpp, augmentation.cpp,
// metrics.cpp) that module.cpp assembles.
#pragma once

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <opencv2/core.hpp>

#include <optional>
#include <span>
#include <string>

#include "fishcam/augment/viewpoint.hpp"
#include "fishcam/core/camera.hpp"
#include "fishcam/eval/metrics.hpp"
#include "fishcam/io/camera_io.hpp"

namespace fishcam::python {

namespace py = pybind11;

// Whether obj's C++ object was made: cls.__new__(cls) alone leaves it unmade (its
// memory unset), and a method or property on it would read garbage or crash.
bool initialised(py::handle obj);
// After every binding (errors.cpp): every function of module `m` and its classes
// raises `error` (fishcam.Error) in one line naming the call, for arguments of the
// wrong type too, and refuses objects made without __init__.
void route_errors_to_fishcam_error(py::module_& m, py::handle error);

using PointArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// (N, k) float64, C-contiguous: the input itself when it already is one (no copy),
// else a converted copy (forcecast). `what` names the argument in errors.
PointArray rows_of(const py::handle& input, py::ssize_t k, const char* what);

// A batch call of the library on (N, kIn) rows: (N, kOut) float64 results and
// (N,) bool validity, computed in place on numpy memory with the GIL released.
template <int kIn, int kOut, class Compute>
std::pair<py::array_t<double>, py::array_t<bool>> batch(const py::handle& input, const char* what,
                                                        const Compute& compute) {
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
  return {results, ok};
}

// A numpy image as a cv::Mat header on its memory (no copy). HxW or HxWxC, C <= 4,
// C-contiguous (else copied) -- or, with rows_apart, an HxW array of contiguous rows
// at any larger step -- dtype uint8, uint16 or float32 (labels: uint8 or uint16).
cv::Mat as_mat(py::array& array, const char* what, bool labels, bool rows_apart = false);

// A new numpy array of height x width (x the channels of `like`), dtype of `like`,
// and a cv::Mat header on its memory.
py::array new_image(const py::array& like, int height, int width, cv::Mat* header);
// Channels-first images (what torch's CxHxW images are as numpy: np.moveaxis of C
// HxW planes of contiguous rows, a crop's too) are handed to the library and written
// plane by plane, never through a numpy copy: whether `array` is such an HxWxC view;
// a header per plane of it
// (AugmentIO::image_planes); a new (C, H, W) array like it, returned as its HxWxC
// view, with a header per plane for the library to write the result into.
bool is_planar_view(const py::array& array);
std::vector<cv::Mat> image_planes(py::array& array, const char* what);
py::array new_planar_image(const py::array& like, int height, int width, std::vector<cv::Mat>* planes);

// Integer labels of any shape as a LabelSpan over the array's own memory (a
// C-contiguous copy only when it is strided); `keep` holds that memory.
LabelSpan labels_of(const py::handle& input, const char* what, py::array* keep);
// "(2, 3)" for messages.
std::string shape_text(const py::array& a);

// The camera's full state as fishcam JSON (exact: doubles are written round-trip).
std::string camera_state(const Camera& camera);
// A camera from fishcam JSON; `what` names the text in messages ("pickled camera",
// "from_json text").
Camera camera_from_state(const std::string& state, const char* what = "pickled camera");

// A pickled state read by `read`: any state of the wrong shape or type (a tampered
// or truncated pickle, a hand-made __setstate__ call) becomes a one-line Error
// naming `what`, never a pybind11 cast or index error.
template <class Read>
auto from_pickle_state(const char* what, const Read& read) -> decltype(read()) {
  try {
    return read();
  } catch (const py::cast_error&) {
    throw Error(std::string(what) + ": a field of the wrong type (not a state fishcam pickled)");
  } catch (const py::error_already_set& e) {
    throw Error(std::string(what) + ": not a state fishcam pickled (" +
                std::string(e.type().attr("__name__").cast<std::string>()) + ")");
  }
}

void bind_camera(py::module_& m);
void bind_augmentation(py::module_& m);
void bind_metrics(py::module_& m);
void bind_calibration(py::module_& m);
void bind_scene(py::module_& m);
// Camera's methods on its calibration record (calibration.cpp), added where Camera is bound.
void bind_calibration_record(py::class_<Camera>& camera);

}  // namespace fishcam::python
