// Every error of the extension a one-line fishcam.Error naming the call, raised by
// the extension's own functions (no wrapper in front of them: the objects Python
// holds are pybind11's, as the stubs describe them).
//
// pybind11 reports arguments of the wrong type (or an integer past 64 bits) from its
// dispatcher, as a multi-line TypeError, before any of our code runs, and an object
// made by cls.__new__(cls) alone reaches a method with its C++ object unmade. So
// every function of the module and its classes gets a dispatcher of ours in front of
// pybind11's: the same PyCFunction object, its PyMethodDef pointed at
// dispatch_tuple or dispatch_vector (pybind11 2 or 3), which check `self` and rewrite
// those errors.
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "bindings.hpp"

namespace fishcam::python {
namespace {

// pybind11's own dispatcher: pybind11 2 takes (self, args tuple, kwargs dict)
// (METH_VARARGS), pybind11 3 Python's vectorcall form (METH_FASTCALL).
using TupleDispatcher = PyObject* (*)(PyObject*, PyObject*, PyObject*);
using FastDispatcher = PyObject* (*)(PyObject*, PyObject* const*, size_t, PyObject*);
void (*pybind11_dispatcher)() = nullptr;
bool pybind11_fastcall = false;
PyObject* error_type = nullptr;
// The names of properties' getters and setters (their records have none).
std::map<const py::detail::function_record*, std::string> property_names;

// The record behind a pybind11 function's `self` (null for another function):
// pybind11 2 keeps it in a capsule, pybind11 3 in an object of its own type.
const py::detail::function_record* record_of(PyObject* self) {
  if (!self) return nullptr;
#if PYBIND11_VERSION_MAJOR >= 3
  return py::detail::function_record_ptr_from_PyObject(self);
#else
  if (!PyCapsule_CheckExact(self)) return nullptr;
  return static_cast<const py::detail::function_record*>(PyCapsule_GetPointer(self, PyCapsule_GetName(self)));
#endif
}

// How to make the objects of classes without a constructor.
const char* made_by(std::string_view type) {
  return type == "Camera" ? "fishcam.Camera.read(path) or fishcam.Camera.from_json(text)" : "its static methods";
}

std::string type_name(py::handle type) { return py::str(type.attr("__name__")); }

// "Camera.resized", "Camera" for a constructor, "derive_seed" for a module function.
std::string call_name(const py::detail::function_record& record) {
  const auto property = property_names.find(&record);
  const std::string name = property != property_names.end() ? property->second : record.name ? record.name : "";
  if (!record.scope || !PyType_Check(record.scope.ptr())) return name;
  const std::string scope = type_name(record.scope);
  return name == "__init__" || name.empty() ? scope : scope + "." + name;
}

std::string one_line(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}

// The arguments of one call, as either calling convention passes them.
struct CallArguments {
  std::vector<PyObject*> positional;
  std::vector<std::pair<PyObject*, PyObject*>> keywords;  // (name, value)

  // The argument types ("int, str, key=float"), past `self` for a method.
  std::string types(bool method) const {
    std::string given;
    for (size_t i = method ? 1 : 0; i < positional.size(); ++i) {
      given += (given.empty() ? "" : ", ") + std::string(Py_TYPE(positional[i])->tp_name);
    }
    for (const auto& [key, value] : keywords) {
      given += (given.empty() ? "" : ", ") + std::string(py::str(key)) + "=" + Py_TYPE(value)->tp_name;
    }
    return given;
  }
};

CallArguments from_tuple(PyObject* args, PyObject* kwargs) {
  CallArguments call;
  for (Py_ssize_t i = 0, n = args ? PyTuple_GET_SIZE(args) : 0; i < n; ++i) {
    call.positional.push_back(PyTuple_GET_ITEM(args, i));
  }
  if (kwargs) {
    PyObject *key, *value;
    Py_ssize_t at = 0;
    while (PyDict_Next(kwargs, &at, &key, &value)) call.keywords.emplace_back(key, value);
  }
  return call;
}

CallArguments from_vector(PyObject* const* args, size_t nargsf, PyObject* kwnames) {
  CallArguments call;
  const Py_ssize_t n = PyVectorcall_NARGS(nargsf);
  call.positional.assign(args, args + n);
  for (Py_ssize_t i = 0, k = kwnames ? PyTuple_GET_SIZE(kwnames) : 0; i < k; ++i) {
    call.keywords.emplace_back(PyTuple_GET_ITEM(kwnames, i), args[n + i]);
  }
  return call;
}

// pybind11's "incompatible function arguments" text, the first signature it lists
// ("1. (self: Camera, width: int, height: int) -> Camera").
std::string expected_signature(const std::string& text) {
  size_t line = 0;
  while (line < text.size()) {
    const size_t end = std::min(text.find('\n', line), text.size());
    const std::string row = text.substr(line, end - line);
    const size_t first = row.find_first_not_of(' ');
    if (first != std::string::npos && std::isdigit(static_cast<unsigned char>(row[first]))) {
      if (const size_t dot = row.find(". ", first); dot != std::string::npos) return row.substr(dot + 2);
    }
    line = end + 1;
  }
  return "";
}

// The error pybind11 or the call set, rewritten as one fishcam.Error line.
void rewrite_error(const py::detail::function_record& record, const CallArguments& call) {
  PyObject *type, *value, *traceback;
  PyErr_Fetch(&type, &value, &traceback);
  PyErr_NormalizeException(&type, &value, &traceback);
  const std::string text = value ? std::string(py::str(value)) : "";
  const std::string name = call_name(record);
  std::string message;
  if (PyErr_GivenExceptionMatches(type, error_type)) {
    if (text.find_first_of("\r\n") == std::string::npos) return PyErr_Restore(type, value, traceback);
    message = one_line(text);
  } else if (PyErr_GivenExceptionMatches(type, PyExc_TypeError) ||
             PyErr_GivenExceptionMatches(type, PyExc_OverflowError)) {
    const std::string given = call.types(record.is_method);
    message = name + ": arguments of the wrong type or range (" + given + ")";
    if (text.find("incompatible function arguments") != std::string::npos ||
        text.find("incompatible constructor arguments") != std::string::npos) {
      message += "; expected " + expected_signature(text);
    } else {
      message += ": " + one_line(text.substr(0, text.find('\n')));
    }
  } else {
    return PyErr_Restore(type, value, traceback);
  }
  Py_XDECREF(type), Py_XDECREF(value), Py_XDECREF(traceback);
  PyErr_SetString(error_type, message.c_str());
}

// A method (not the constructor, nor __setstate__, which make the object) on an
// object whose C++ object was never made reads garbage or crashes: refused.
bool refused_uninitialised(const py::detail::function_record& record, PyObject* first) {
  const std::string name = record.name ? record.name : "";
  if (!record.is_method || name == "__init__" || name == "__setstate__" || !first || initialised(first)) return false;
  PyErr_SetString(error_type, (call_name(record) + ": an object made without __init__ (cls.__new__ alone): make it "
                                                   "with its constructor, a reader or pickle")
                                  .c_str());
  return true;
}

PyObject* dispatch_tuple(PyObject* self, PyObject* args, PyObject* kwargs) {
  const auto* record = record_of(self);
  if (!record) return nullptr;
  if (refused_uninitialised(*record, PyTuple_GET_SIZE(args) > 0 ? PyTuple_GET_ITEM(args, 0) : nullptr)) return nullptr;
  PyObject* result = reinterpret_cast<TupleDispatcher>(pybind11_dispatcher)(self, args, kwargs);
  if (!result && PyErr_Occurred()) rewrite_error(*record, from_tuple(args, kwargs));
  return result;
}

PyObject* dispatch_vector(PyObject* self, PyObject* const* args, size_t nargsf, PyObject* kwnames) {
  const auto* record = record_of(self);
  if (!record) return nullptr;
  if (refused_uninitialised(*record, PyVectorcall_NARGS(nargsf) > 0 ? args[0] : nullptr)) return nullptr;
  PyObject* result = reinterpret_cast<FastDispatcher>(pybind11_dispatcher)(self, args, nargsf, kwnames);
  if (!result && PyErr_Occurred()) rewrite_error(*record, from_vector(args, nargsf, kwnames));
  return result;
}

// Calling a class without a constructor: pybind11 says "No constructor defined!".
int refuse_construction(PyObject* self, PyObject*, PyObject*) {
  const std::string name = type_name(py::handle(reinterpret_cast<PyObject*>(Py_TYPE(self))));
  PyErr_SetString(error_type, (name + ": has no constructor; make one with " + made_by(name)).c_str());
  return -1;
}

// Puts our dispatcher in front of pybind11's for the function `f` (a pybind11
// function, an instance method, static method or property around one).
void route(py::handle f, const std::string& name = "") {
  if (!f) return;
  if (PyInstanceMethod_Check(f.ptr())) return route(PyInstanceMethod_GET_FUNCTION(f.ptr()));
  if (py::isinstance<py::staticmethod>(f) || PyObject_TypeCheck(f.ptr(), &PyProperty_Type)) {
    for (const char* part : {"__func__", "fget", "fset"}) {
      if (py::hasattr(f, part)) route(f.attr(part), name);
    }
    return;
  }
  if (PyType_Check(f.ptr())) {  // a class of ours, and the classes nested in it
    auto* type = reinterpret_cast<PyTypeObject*>(f.ptr());
    static std::set<PyTypeObject*> routed;  // a class met again (an alias) is routed once
    if (!py::detail::get_type_info(type) || !routed.insert(type).second) return;
    const py::dict members = f.attr("__dict__").cast<py::dict>();
    for (const auto& member : members) {
      if (member.second.ptr() != f.ptr()) route(member.second, py::str(member.first));
    }
    // Without a constructor of ours, __init__ is the slot pybind11's base class fills.
    if (!members.contains("__init__") || !PyInstanceMethod_Check(members["__init__"].ptr())) {
      type->tp_init = refuse_construction, PyType_Modified(type);
    }
    return;
  }
  if (!PyCFunction_Check(f.ptr())) return;
  const auto* record = record_of(PyCFunction_GET_SELF(f.ptr()));
  if (!record) return;  // not a pybind11 function
  PyMethodDef* def = reinterpret_cast<PyCFunctionObject*>(f.ptr())->m_ml;
  if ((!record->name || !*record->name) && !name.empty()) property_names[record] = name;
  if (reinterpret_cast<void (*)()>(def->ml_meth) != pybind11_dispatcher) return;
  def->ml_meth = pybind11_fastcall ? reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(dispatch_vector))
                                   : reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(dispatch_tuple));
}

}  // namespace

bool initialised(py::handle obj) {
  if (!py::detail::get_type_info(Py_TYPE(obj.ptr()))) return true;  // not an extension class
  auto* inst = reinterpret_cast<py::detail::instance*>(obj.ptr());
  // An instance that refers to an object another owns (returned by reference) has
  // no holder of its own; one that owns its object has it once the object is made.
  for (const auto& value_and_holder : py::detail::values_and_holders(inst)) {
    if (!value_and_holder.value_ptr() || (inst->owned && !value_and_holder.holder_constructed())) return false;
  }
  return true;
}

void route_errors_to_fishcam_error(py::module_& m, py::handle error) {
  error_type = error.ptr();
  const py::object any = m.attr("_initialised");  // a pybind11 function: its dispatcher is every one's
  const PyMethodDef* def = reinterpret_cast<PyCFunctionObject*>(any.ptr())->m_ml;
  pybind11_dispatcher = reinterpret_cast<void (*)()>(def->ml_meth);
  pybind11_fastcall = (def->ml_flags & METH_FASTCALL) != 0;
  for (const auto& item : m.attr("__dict__").cast<py::dict>()) route(item.second);
}

}  // namespace fishcam::python
