// fishcam._fishcam: the C++ library for Python. Thin: argument checks and array
// plumbing only, the GIL released around every computation; one file per area
// (camera.cpp, augmentation.cpp, metrics.cpp, calibration.cpp, scene.cpp; shared plumbing in arrays.cpp). The
// package's Python modules (fishcam/__init__.py, transforms.py, torch/,
// albumentations.py) build the documented API on top.
#include "bindings.hpp"

namespace py = pybind11;

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
    } catch (const py::reference_cast_error&) {
      // pybind11's only way to meet an instance whose C++ object was never made
      // (cls.__new__(cls) without __init__ or __setstate__).
      PyErr_SetString(error.ptr(),
                      "an object made without __init__ (cls.__new__ alone): make it with its constructor, "
                      "a reader or pickle");
    }
  });
  m.attr("__version__") = FISHCAM_VERSION;
  // Whether obj's C++ object was made: cls.__new__(cls) alone leaves it unmade (its
  // memory unset), and a method or property on it would read garbage or crash. The
  // package checks this before every public method and property (fishcam/__init__.py).
  m.def("_initialised", [](py::handle obj) {
    if (!py::detail::get_type_info(Py_TYPE(obj.ptr()))) return true;  // not an extension class
    auto* inst = reinterpret_cast<py::detail::instance*>(obj.ptr());
    // An instance that refers to an object another owns (returned by reference) has
    // no holder of its own; one that owns its object has it once the object is made.
    for (const auto& value_and_holder : py::detail::values_and_holders(inst)) {
      if (!value_and_holder.value_ptr() || (inst->owned && !value_and_holder.holder_constructed())) return false;
    }
    return true;
  });
  fishcam::python::bind_camera(m);
  fishcam::python::bind_augmentation(m);
  fishcam::python::bind_metrics(m);
  fishcam::python::bind_calibration(m);
  fishcam::python::bind_scene(m);
}
