// Conversions between Python and Kiji, with the checks that keep bad input from reaching the core,
// and the translation of Kiji's exceptions into Python's.
#include "bindings.h"

#include <cmath>
#include <sstream>

namespace kiji::python {

namespace {

// The exception types, created once and kept for the life of the process.
PyObject* g_error = nullptr;
PyObject* g_input_error = nullptr;
PyObject* g_topology_error = nullptr;
PyObject* g_simulation_error = nullptr;

std::string shape_text(const py::array& a) {
  std::ostringstream s;
  s << "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s << (i ? ", " : "") << a.shape(i);
  s << (a.ndim() == 1 ? ",)" : ")");
  return s.str();
}

}  // namespace

void bind_errors(py::module_& m) {
  auto make = [&](const char* name, py::handle bases, const char* doc) {
    PyObject* type = PyErr_NewExceptionWithDoc((std::string("kiji.") + name).c_str(), doc, bases.ptr(), nullptr);
    if (!type) throw py::error_already_set();
    m.attr(name) = py::handle(type);  // the module holds a reference; the global another, never released
    return type;
  };
  g_error = make("Error", PyExc_RuntimeError, "Base of the errors Kiji raises on purpose.");
  py::tuple input_bases = py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError));
  g_input_error = make("InputError", input_bases,
                       "The input cannot be used (a missing file, a wrong shape, NaN, a value out of range); "
                       "nothing was changed.");
  g_topology_error = make("TopologyError", input_bases,
                          "A topology edit was refused because its result would not be a valid manifold mesh; "
                          "the garment is as it was.");
  g_simulation_error = make("SimulationError", py::handle(g_error),
                            "A step would have made the cloth non-finite (forces or pulls too large for the time "
                            "step); it was undone and the garment is as it was.");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const TopologyError& e) {
      PyErr_SetString(g_topology_error, e.what());
    } catch (const InputError& e) {
      PyErr_SetString(g_input_error, e.what());
    } catch (const SimulationError& e) {
      PyErr_SetString(g_simulation_error, e.what());
    } catch (const Error& e) {
      PyErr_SetString(g_error, e.what());
    }
  });
}

std::string path_arg(py::handle obj) {
  if (!py::isinstance<py::str>(obj) && !py::hasattr(obj, "__fspath__"))
    throw py::type_error("expected a path (str or os.PathLike), not " + std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  return py::str(py::module_::import("os").attr("fspath")(obj)).cast<std::string>();
}

SessionGuard::SessionGuard(const Session& session) : lock_(session.mutex(), std::try_to_lock) {
  if (lock_.owns_lock()) return;
  py::gil_scoped_release nogil;
  lock_.lock();
}

VertexRows::VertexRows(const Garment& g) : row(g.vertex_capacity(), -1) {
  for (Vertex v : g.mesh().vertices()) {
    row[v.idx()] = static_cast<long>(vertices.size());
    vertices.push_back(v);
  }
}

py::array_t<double, py::array::c_style> real_array(py::handle obj, const char* what, long n, long cols, bool finite) {
  py::array a;
  try {
    a = py::module_::import("numpy").attr("asarray")(obj);
  } catch (py::error_already_set&) {
    throw py::type_error(std::string(what) + " must be an array of numbers");
  }
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    throw py::type_error(std::string(what) + " must be an array of real numbers, not of dtype " +
                         py::str(a.dtype()).cast<std::string>());
  const bool shape_ok = cols == 0 ? (a.ndim() == 1 && (n < 0 || a.shape(0) == n))
                                  : (a.ndim() == 2 && a.shape(1) == cols && (n < 0 || a.shape(0) == n));
  if (!shape_ok) {
    std::ostringstream want;
    want << "(" << (n < 0 ? std::string("N") : std::to_string(n)) << (cols ? ", " + std::to_string(cols) : std::string(",")) << ")";
    throw InputError(std::string(what) + " has shape " + shape_text(a) + "; expected " + want.str());
  }
  auto out = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!out) throw py::error_already_set();
  if (finite) {
    const double* d = out.data();
    for (py::ssize_t i = 0; i < out.size(); ++i)
      if (!std::isfinite(d[i])) {
        std::ostringstream msg;
        msg << what << " has a value that is not a finite number (NaN or infinity) at flat index " << i;
        throw InputError(msg.str());
      }
  }
  return out;
}

py::array_t<double> vec3_array(const Vec3& v) {
  py::array_t<double> a(3);
  auto r = a.mutable_unchecked<1>();
  for (int i = 0; i < 3; ++i) r(i) = v[i];
  return a;
}

Vec3 to_vec3(py::handle obj, const char* what) {
  auto a = real_array(obj, what, 3, 0);
  return Vec3(a.data()[0], a.data()[1], a.data()[2]);
}

py::object param_value_to_python(const ParamValue& value) {
  return std::visit(
      [](const auto& v) -> py::object {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, Vec3>) return py::make_tuple(v.x(), v.y(), v.z());
        else return py::cast(v);
      },
      value);
}

namespace {

bool is_bool(py::handle v) {
  return py::isinstance<py::bool_>(v) || py::str(py::type::of(v).attr("__name__")).cast<std::string>() == "bool_";
}
bool is_integer(py::handle v) {
  if (is_bool(v)) return false;
  return py::isinstance(v, py::module_::import("numbers").attr("Integral"));
}
bool is_real(py::handle v) {
  if (is_bool(v)) return false;
  return py::isinstance(v, py::module_::import("numbers").attr("Real"));
}

[[noreturn]] void wrong_type(const std::string& tool, const ParamSpec& spec, py::handle v, const char* want) {
  throw py::type_error(tool + "(): parameter '" + spec.name + "' must be " + want + ", not " +
                       py::str(py::type::of(v).attr("__name__")).cast<std::string>());
}

ParamValue convert(const std::string& tool, const ParamSpec& spec, py::handle v) {
  switch (spec.type) {
    case ParamType::Bool:
      if (!is_bool(v)) wrong_type(tool, spec, v, "a bool");
      return v.cast<bool>();
    case ParamType::Int:
      if (!is_integer(v)) wrong_type(tool, spec, v, "an int");
      return v.cast<long long>();
    case ParamType::Float: {
      if (!is_real(v)) wrong_type(tool, spec, v, "a number");
      const double x = py::float_(py::reinterpret_borrow<py::object>(v)).cast<double>();
      if (!std::isfinite(x))
        throw InputError(tool + "(): parameter '" + spec.name + "' is not a finite number");
      return x;
    }
    case ParamType::String:
    case ParamType::Choice:
      if (!py::isinstance<py::str>(v)) wrong_type(tool, spec, v, "a str");
      return v.cast<std::string>();
    case ParamType::Color: {
      if (py::isinstance<py::str>(v)) wrong_type(tool, spec, v, "a colour (r, g, b)");
      try {
        return to_vec3(v, (tool + "(): parameter '" + spec.name + "'").c_str());
      } catch (const InputError&) {
        throw;
      } catch (const py::type_error&) {
        wrong_type(tool, spec, v, "a colour (r, g, b) of numbers");
      }
    }
  }
  wrong_type(tool, spec, v, "a value");
}

}  // namespace

ParamSet params_from_python(const Session& session, const std::string& tool, const py::dict& values) {
  ParamSet set(session.tools().info(tool).parameters);
  for (auto item : values) {
    const std::string name = py::str(item.first).cast<std::string>();
    const ParamSpec* spec = nullptr;
    for (const auto& s : set.specs())
      if (s.name == name) spec = &s;
    if (!spec) {
      std::string known;
      for (const auto& s : set.specs()) known += (known.empty() ? "" : ", ") + s.name;
      throw py::type_error(tool + "() got an unexpected keyword argument '" + name + "'; its parameters are: " +
                           (known.empty() ? std::string("none") : known));
    }
    set.set(name, convert(tool, *spec, item.second));
  }
  return set;
}

std::map<std::string, ParamValue> param_map_from_python(const py::dict& values) {
  std::map<std::string, ParamValue> out;
  for (auto item : values) {
    const std::string name = py::str(item.first).cast<std::string>();
    py::handle v = item.second;
    if (is_bool(v)) out[name] = v.cast<bool>();
    else if (is_integer(v)) out[name] = v.cast<long long>();
    else if (is_real(v)) out[name] = py::float_(py::reinterpret_borrow<py::object>(v)).cast<double>();
    else if (py::isinstance<py::str>(v)) out[name] = v.cast<std::string>();
    else out[name] = to_vec3(v, ("parameter '" + name + "'").c_str());
  }
  return out;
}

py::dict param_map_to_python(const std::map<std::string, ParamValue>& values) {
  py::dict d;
  for (const auto& [name, value] : values) d[py::str(name)] = param_value_to_python(value);
  return d;
}

Phase parse_phase(const std::string& name) {
  for (Phase p : {Phase::Begin, Phase::Move, Phase::End, Phase::Cancel})
    if (name == phase_name(p)) return p;
  throw InputError("unknown event phase '" + name + "': use 'begin', 'move', 'end' or 'cancel'");
}

ToolEvent event_arg(py::handle event, Phase phase, double default_time) {
  ToolEvent e;
  if (py::isinstance<ToolEvent>(event)) {
    e = at_the_clock(event.cast<ToolEvent>(), default_time);
    if (e.phase != phase) {
      const auto article = [](Phase p) { return p == Phase::End ? "an '" : "a '"; };
      throw InputError(std::string("expected ") + article(phase) + phase_name(phase) + "' event, not " +
                       article(e.phase) + phase_name(e.phase) + "' one: make it with kiji.ToolEvent('" +
                       phase_name(phase) + "', position, ...), or pass the pointer position alone");
    }
    return e;
  }
  if (event.is_none())
    throw py::type_error(std::string("a '") + phase_name(phase) + "' event needs a kiji.ToolEvent or a pointer position (3,)");
  e.phase = phase;
  e.position = to_vec3(event, "the pointer position");
  e.time = default_time;
  return e;
}

ToolContext& ToolScope::get(const char* what) const {
  if (!active())
    throw Error(std::string(what) + " given to a tool written in Python is used outside the tool's begin, update, "
                "end or cancel: a tool changes the session only while the session calls it (the stroke is the "
                "operation); take the garment again from the session passed to the call");
  return *context;
}

void PyHandle::Drop::operator()(py::object* obj) const {
  if (!Py_IsInitialized()) {
    obj->release();  // the interpreter is gone: nothing to give the reference back to
  } else {
    py::gil_scoped_acquire gil;
    *obj = py::object();
  }
  delete obj;
}

bool ProgressHook::operator()(double fraction) const {
  py::gil_scoped_acquire gil;
  if (PyErr_CheckSignals() != 0) throw py::error_already_set();
  if (callback_.is_none()) return true;
  py::object r = callback_(fraction);
  return r.is_none() || py::bool_(r).cast<bool>();
}

}  // namespace kiji::python

namespace kiji::python {

void check_garment_index(const Session& session, std::size_t index) { session.garment(index); }

}  // namespace kiji::python
