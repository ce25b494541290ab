// `import cfuse`: the library from Python. This unit turns cfuse's error tiers into Python's
// exceptions and converts between JSON and Python objects; each other unit binds one area.
#include <pybind11/pybind11.h>

#include <cmath>

#include "bindings.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/error.h"

namespace cfuse::python {

py::object ToPython(const nlohmann::json& json) {
  switch (json.type()) {
    case nlohmann::json::value_t::object: {
      py::dict out;
      for (const auto& [key, value] : json.items()) out[py::str(key)] = ToPython(value);
      return out;
    }
    case nlohmann::json::value_t::array: {
      py::list out(json.size());
      for (size_t i = 0; i < json.size(); ++i) out[i] = ToPython(json[i]);
      return out;
    }
    case nlohmann::json::value_t::string:
      return py::str(json.get_ref<const std::string&>());
    case nlohmann::json::value_t::boolean:
      return py::bool_(json.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(json.get<long long>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(json.get<unsigned long long>());
    case nlohmann::json::value_t::number_float:
      return py::float_(json.get<double>());
    default:
      return py::none();
  }
}

nlohmann::json FromPython(const py::handle& object, const std::string& what) {
  if (object.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(object)) return object.cast<bool>();
  if (py::isinstance<py::int_>(object)) return object.cast<long long>();
  if (py::isinstance<py::float_>(object)) return object.cast<double>();
  if (py::isinstance<py::str>(object)) return object.cast<std::string>();
  if (py::isinstance<py::dict>(object)) {
    nlohmann::json out = nlohmann::json::object();
    for (const auto& [key, value] : object.cast<py::dict>()) {
      if (!py::isinstance<py::str>(key)) {
        throw InputError(SourceLocation(what), "a key that is not a string");
      }
      const std::string k = key.cast<std::string>();
      out[k] = FromPython(value, what + "." + k);
    }
    return out;
  }
  if (py::hasattr(object, "tolist")) return FromPython(object.attr("tolist")(), what);  // numpy
  if (py::isinstance<py::sequence>(object)) {
    nlohmann::json out = nlohmann::json::array();
    size_t i = 0;
    for (const py::handle item : object) {
      out.push_back(FromPython(item, what + "[" + std::to_string(i++) + "]"));
    }
    return out;
  }
  throw InputError(SourceLocation(what),
                   "a " + py::str(py::type::of(object).attr("__name__")).cast<std::string>() +
                       " where numbers, strings, lists or dicts are expected");
}

namespace {

// Raises `type` with the error's location as attributes: file, line, column (0 unknown),
// element ("" unknown) and message (without the location).
void RaiseLocated(const py::object& type, const InputError& e) {
  py::object error = type(e.what());
  const SourceLocation& where = e.where();
  error.attr("file") = where.file;
  error.attr("line") = where.line;
  error.attr("column") = where.column;
  error.attr("element") = where.element;
  error.attr("message") = e.message();
  PyErr_SetObject(type.ptr(), error.ptr());
}

}  // namespace

}  // namespace cfuse::python

PYBIND11_MODULE(_cfuse, m) {
  namespace py = pybind11;
  using namespace cfuse::python;
  m.doc() = "cfuse's C++ library; use the `cfuse` package, which wraps it.";
  m.attr("__version__") = CFUSE_VERSION;
  // Bad input (tier 1): a ValueError naming the file and the place. A bug in cfuse (tier 3):
  // InternalError, a RuntimeError. Either way the interpreter lives on.
  static py::exception<cfuse::InputError> input_error(m, "InputError", PyExc_ValueError);
  static py::exception<cfuse::InternalError> internal_error(m, "InternalError",
                                                            PyExc_RuntimeError);
  input_error.attr("__doc__") =
      "Bad input: a ValueError naming the place. Attributes: file, line and column (0 when "
      "unknown), element (\"\" when unknown) and message (without the location).";
  internal_error.attr("__doc__") = "A bug in cfuse (a broken internal contract): please report it.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const cfuse::InputError& e) {
      RaiseLocated(input_error, e);
    } catch (const cfuse::InternalError& e) {
      internal_error(e.what());
    }
  });
  BindModels(m);
  BindMeasurements(m);
  BindEstimates(m);
  BindTracking(m);
}
