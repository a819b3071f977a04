// fishcam._fishcam: the C++ library for Python. Thin: argument checks and array
// plumbing only, the GIL released around every computation; one file per area
// (camera.cpp, augmentation.cpp, metrics.cpp, calibration.cpp, scene.cpp; shared plumbing in arrays.cpp). The
// package's Python modules (fishcam/__init__.py, transforms.py, torch/,
// albumentations.py) build the documented API on top.
#include "bindings.hpp"

namespace py = pybind11;

namespace {

// One reduction for every pickle protocol: pybind11's own (py::pickle) needs
// protocol 2, and 0 and 1 abort the interpreter in copyreg ("no registered base
// types"). copyreg.__newobj__ makes the object by cls.__new__(cls), pickle then calls
// its __setstate__ with the state.
void reduce_through_getstate(py::handle cls) {
  py::setattr(cls, "__reduce__",
              py::cpp_function(
                  [](py::handle self) {
                    return py::make_tuple(py::module_::import("copyreg").attr("__newobj__"),
                                          py::make_tuple(py::type::handle_of(self)), self.attr("__getstate__")());
                  },
                  py::name("__reduce__"), py::is_method(cls),
                  py::doc("Pickling at every protocol: (copyreg.__newobj__, (type,), __getstate__())")));
}

}  // namespace

PYBIND11_MODULE(_fishcam, m) {
  using fishcam::Error;
  m.doc() = "fishcam's C++ library (use the fishcam package, not this module)";
  static py::exception<Error> error(m, "Error", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      PyErr_SetString(error.ptr(), e.what());  // one line: errors.cpp
    } catch (const cv::Exception& e) {
      PyErr_SetString(error.ptr(), ("OpenCV: " + e.err).c_str());
    } catch (const py::reference_cast_error&) {
      // pybind11's only way to meet an instance whose C++ object was never made
      // (cls.__new__(cls) without __init__ or __setstate__).
      PyErr_SetString(error.ptr(),
                      "an object made without __init__ (cls.__new__ alone): make it with its constructor, "
                      "a reader or pickle");
    }
  });
  m.attr("__version__") = FISHCAM_VERSION;
  // Whether obj's C++ object was made (cls.__new__(cls) alone leaves it unmade).
  m.def("_initialised", [](py::handle obj) { return fishcam::python::initialised(obj); });
  fishcam::python::bind_camera(m);
  fishcam::python::bind_augmentation(m);
  fishcam::python::bind_metrics(m);
  fishcam::python::bind_calibration(m);
  fishcam::python::bind_scene(m);
  for (const char* name : {"Camera", "ViewpointWarp", "ViewpointChange", "AffineChange"}) {
    reduce_through_getstate(m.attr(name));
  }
  fishcam::python::route_errors_to_fishcam_error(m, error);
}
