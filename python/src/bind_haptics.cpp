// Force feedback from Python: snapshots of the cloth near the pointer, devices (a Python subclass of
// InputDevice is sampled by the haptic loop's own thread, taking the GIL for each call), and the
// 1 kHz haptic loop.
#include "bindings.h"

#include "kiji/haptics.h"

#include <atomic>
#include <cmath>

namespace kiji::python {

namespace {

// An error raised by a device's Python code on the haptic thread has no caller to reach: it is
// reported through sys.unraisablehook, counted, and the loop goes on with a harmless value.
std::atomic<std::size_t> g_device_errors{0};

void report(py::error_already_set& e, const char* where) {
  ++g_device_errors;
  e.discard_as_unraisable(where);
}

// The trampoline of InputDevice: a Python subclass overrides name, sample, set_force, max_force.
class PyInputDevice : public InputDevice {
 public:
  std::string name() const override {
    py::gil_scoped_acquire gil;
    try {
      if (py::function f = py::get_override(static_cast<const InputDevice*>(this), "name")) return py::str(f()).cast<std::string>();
    } catch (py::error_already_set& e) {
      report(e, "kiji.InputDevice.name");
    }
    return InputDevice::name();
  }
  ToolEvent sample() override {
    py::gil_scoped_acquire gil;
    try {
      if (py::function f = py::get_override(static_cast<const InputDevice*>(this), "sample")) {
        py::object r = f();
        if (!py::isinstance<ToolEvent>(r))
          throw py::type_error("InputDevice.sample() must return a kiji.ToolEvent, not " +
                               py::str(py::type::of(r).attr("__name__")).cast<std::string>());
        last_ = r.cast<ToolEvent>();
        return last_;
      }
    } catch (py::error_already_set& e) {
      report(e, "kiji.InputDevice.sample");
    } catch (const std::exception& e) {
      ++g_device_errors;
      PyErr_SetString(PyExc_TypeError, e.what());
      py::error_already_set err;
      err.discard_as_unraisable("kiji.InputDevice.sample");
    }
    ToolEvent released = last_;  // where the pen was, button up: nothing to act on
    released.buttons = 0;
    return released;
  }
  void set_force(const Vec3& force) override {
    py::gil_scoped_acquire gil;
    try {
      if (py::function f = py::get_override(static_cast<const InputDevice*>(this), "set_force")) f(vec3_array(force));
    } catch (py::error_already_set& e) {
      report(e, "kiji.InputDevice.set_force");
    }
  }
  double max_force() const override {
    py::gil_scoped_acquire gil;
    try {
      if (py::function f = py::get_override(static_cast<const InputDevice*>(this), "max_force")) {
        const double x = py::float_(f()).cast<double>();
        if (std::isfinite(x) && x >= 0) return x;
      }
    } catch (py::error_already_set& e) {
      report(e, "kiji.InputDevice.max_force");
    }
    return InputDevice::max_force();
  }

 private:
  ToolEvent last_;
};

// A haptic loop with what it uses kept alive: the device (its Python object too, for a subclass)
// and the session whose tool it asks. Stopping joins the loop's thread, which may be waiting for
// the GIL to sample a Python device: the GIL is released for it.
struct PyHapticLoop {
  std::shared_ptr<InputDevice> device;
  PyHandle device_object;
  std::unique_ptr<HapticLoop> loop;
  std::shared_ptr<Session> session;
  ~PyHapticLoop() {
    if (!loop) return;
    if (Py_IsInitialized() && PyGILState_Check()) {
      py::gil_scoped_release nogil;
      loop.reset();
    } else {
      loop.reset();
    }
  }
};

py::dict stats_dict(const HapticStats& s) {
  py::dict d;
  d["ticks"] = s.ticks;
  d["rate_hz"] = s.rate_hz;
  d["period_jitter_us"] = s.period_jitter_us;
  d["force_median_us"] = s.force_median_us;
  d["force_p99_us"] = s.force_p99_us;
  d["realtime"] = s.realtime;
  return d;
}

}  // namespace

void bind_haptics(py::module_& m) {
  py::class_<HapticSnapshot, std::shared_ptr<HapticSnapshot>>(m, "HapticSnapshot",
      "The cloth near the pointer as it was after a simulation step: what the haptic loop reads.")
      .def_readonly("time", &HapticSnapshot::time)
      .def_readonly("garment", &HapticSnapshot::garment)
      .def_property_readonly("center", [](const HapticSnapshot& s) { return vec3_array(s.center); })
      .def_readonly("radius", &HapticSnapshot::radius)
      .def_property_readonly("vertex_ids", [](const HapticSnapshot& s) {
        py::array_t<std::int64_t> a(static_cast<py::ssize_t>(s.vertices.size()));
        for (std::size_t i = 0; i < s.vertices.size(); ++i) a.mutable_data()[i] = s.vertices[i].idx();
        return a;
      }, "(K,) the ids of the vertices within radius of center, in id order")
      .def_property_readonly("positions", [](const HapticSnapshot& s) {
        py::array_t<double> a({static_cast<py::ssize_t>(s.positions.size()), py::ssize_t(3)});
        for (std::size_t i = 0; i < s.positions.size(); ++i)
          for (int k = 0; k < 3; ++k) a.mutable_at(i, k) = s.positions[i][k];
        return a;
      }, "(K, 3) their positions")
      .def_property_readonly("triangles", [](const HapticSnapshot& s) {
        py::array_t<std::int64_t> a({static_cast<py::ssize_t>(s.triangles.size()), py::ssize_t(3)});
        for (std::size_t i = 0; i < s.triangles.size(); ++i)
          for (int k = 0; k < 3; ++k) a.mutable_at(i, k) = s.triangles[i][k];
        return a;
      }, "(T, 3) faces whose three vertices are all in, as rows of positions")
      .def("position_of", [](const HapticSnapshot& s, long long id) -> py::object {
        if (id < 0) return py::none();
        const Vec3* p = s.position_of(Vertex(static_cast<Vertex::size_type>(id)));
        return p ? py::object(vec3_array(*p)) : py::object(py::none());
      }, py::arg("vertex_id"), "Where a vertex (by id) was, or None if the snapshot does not hold it.")
      .def("nearest", [](const HapticSnapshot& s, py::handle p) { return s.nearest(to_vec3(p, "point")); }, py::arg("point"),
           "The snapshot's cloth surface point nearest a point (SurfaceHit).");
  m.def("take_snapshot", [](const std::shared_ptr<Session>& s, std::size_t garment, py::handle center, double radius) {
    const Vec3 c = to_vec3(center, "center");
    if (!std::isfinite(radius) || radius <= 0) throw InputError("take_snapshot: radius must be a positive number of metres");
    SessionGuard lock(*s);
    return std::make_shared<HapticSnapshot>(take_snapshot(*s, garment, c, radius));
  }, py::arg("session"), py::arg("garment"), py::arg("center"), py::arg("radius"),
     "The cloth of a session's garment within radius of center, for the haptic loop (HapticLoop.publish).");

  py::class_<InputDevice, PyInputDevice, std::shared_ptr<InputDevice>>(m, "InputDevice",
      "A haptic pointing device. Subclass it in Python (sample, set_force, max_force, name) to feed the\n"
      "haptic loop from your own hardware: the loop's thread takes the GIL for each call, so it reaches\n"
      "1 kHz only while other Python threads leave the GIL free (waiting, sleeping, or in Kiji's long calls,\n"
      "which release it); see docs/python.md for measured rates. An error raised there goes to\n"
      "sys.unraisablehook (the loop goes on with the button up). The base class is a null device.")
      .def(py::init<>())
      .def("name", &InputDevice::name, "The device's name, for messages and status lines.")
      .def("sample", &InputDevice::sample, "The device's state now: a kiji.ToolEvent (position in world metres).")
      .def("set_force", [](InputDevice& d, py::handle f) { d.set_force(to_vec3(f, "force")); }, py::arg("force"),
           "The force to render, newtons (already clamped to max_force()).")
      .def("max_force", &InputDevice::max_force, "Newtons the device can render (a Phantom Omni's 3.3 by default).");
  m.def("device_errors", []() { return g_device_errors.load(); },
        "Errors raised by Python devices' methods on the haptic thread so far (each reported to sys.unraisablehook).");

  py::class_<ScriptedDevice, InputDevice, std::shared_ptr<ScriptedDevice>>(m, "ScriptedDevice",
      "A device that plays a path: path(t) gives the ToolEvent at t seconds since the loop started (called on\n"
      "the haptic thread, with the GIL); it records the forces it was sent.")
      .def(py::init([](py::function path) {
             PyHandle handle(std::move(path));
             return std::make_shared<ScriptedDevice>([handle](double t) -> ToolEvent {
               py::gil_scoped_acquire gil;
               try {
                 return handle.get()(t).cast<ToolEvent>();
               } catch (py::error_already_set& e) {
                 report(e, "kiji.ScriptedDevice path");
               } catch (const py::cast_error&) {
                 ++g_device_errors;
               }
               ToolEvent none;
               none.buttons = 0;
               return none;
             });
           }),
           py::arg("path"))
      .def_property_readonly("last_force", [](const ScriptedDevice& d) { return vec3_array(d.last_force()); })
      .def_property_readonly("forces_received", &ScriptedDevice::forces_received);

  py::class_<PyHapticLoop, std::shared_ptr<PyHapticLoop>>(m, "HapticLoop",
      "The haptic loop: a thread at rate_hz (1 kHz) that samples the device, asks the tool set with set_tool\n"
      "for a force on the latest published snapshot (HapticLoop.publish), clamps it to the device's maximum and\n"
      "sends it. Use it as a context manager, or start() and stop().")
      .def(py::init([](py::object device, double rate_hz) {
             if (!std::isfinite(rate_hz) || rate_hz < 1 || rate_hz > 10000)
               throw InputError("HapticLoop: rate_hz must be 1 to 10000");
             auto l = std::make_shared<PyHapticLoop>();
             l->device = device.cast<std::shared_ptr<InputDevice>>();
             l->device_object = PyHandle(device);
             l->loop = std::make_unique<HapticLoop>(*l->device, rate_hz);
             return l;
           }),
           py::arg("device"), py::arg("rate_hz") = 1000.0)
      .def("set_tool", [](PyHapticLoop& l, const std::shared_ptr<Session>& s, const std::string& tool, UserId user) {
        if (!s) {
          l.loop->set_tool(nullptr);
          l.session.reset();
          return;
        }
        SessionGuard lock(*s);
        l.loop->set_tool(&s->tool(tool, user));
        l.session = s;
      }, py::arg("session"), py::arg("tool") = "", py::arg("user") = 0,
         "The tool (of a session, for a user) whose force the loop renders; session None for no force.")
      .def("publish", [](PyHapticLoop& l, std::shared_ptr<HapticSnapshot> snap) { l.loop->publish(std::move(snap)); },
           py::arg("snapshot"), "A new snapshot for the loop to read (after each simulation step).")
      .def("latest_sample", [](const PyHapticLoop& l) { return l.loop->latest_sample(); },
           "The latest device sample (a ToolEvent), to turn into the session's events at its own rate.")
      .def("start", [](PyHapticLoop& l) {
        py::gil_scoped_release nogil;
        l.loop->start();
      }, "Starts the thread; returns once the device has been sampled.")
      .def("stop", [](PyHapticLoop& l) {
        py::gil_scoped_release nogil;
        l.loop->stop();
      }, "Stops the thread and sends the device a zero force.")
      .def_property_readonly("running", [](const PyHapticLoop& l) { return l.loop->running(); })
      .def("stats", [](const PyHapticLoop& l) { return stats_dict(l.loop->stats()); },
           "ticks, rate_hz, period_jitter_us, force_median_us, force_p99_us and realtime (the thread got\n"
           "real-time priority).")
      .def("__enter__", [](std::shared_ptr<PyHapticLoop> l) {
        {
          py::gil_scoped_release nogil;
          l->loop->start();
        }
        return l;
      })
      .def("__exit__", [](PyHapticLoop& l, py::args) {
        py::gil_scoped_release nogil;
        l.loop->stop();
      });
}

}  // namespace kiji::python
