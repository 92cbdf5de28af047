// Shared pieces of the pybind11 module: the garment handle, NumPy conversions with checks,
// tool-parameter conversion and the progress hook that releases and re-takes the GIL.
#pragma once

#include "kiji/error.h"
#include "kiji/garment.h"
#include "kiji/params.h"
#include "kiji/session.h"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace py = pybind11;

namespace kiji::python {

// The one-thread-at-a-time rule for a session (Session::mutex) as Python keeps it: every binding
// that uses a session holds this guard. If another thread holds the session (a long step with the
// GIL released), the GIL is released while waiting, so that the holder can call back into Python.
class SessionGuard {
 public:
  explicit SessionGuard(const Session& session);
  SessionGuard(SessionGuard&&) = default;

 private:
  std::unique_lock<std::recursive_mutex> lock_;
};

// What a tool written in Python is working on, while one of its calls (begin, update, end, cancel)
// runs: the ToolContext the session gave the call, as a C++ tool has it. Views made through it
// change the session's garments in place (the stroke is the operation), and are refused outside the
// tool's calls, when a change in place would escape the journal.
struct ToolScope {
  ToolContext* context = nullptr;  // the call's; null outside the tool's calls
  int depth = 0;                   // calls of the tool in progress on the applying thread
  ToolEvent event;                 // the event of the call in progress
  bool active() const { return context != nullptr && depth > 0; }
  ToolContext& get(const char* what) const;  // throws kiji.Error outside the tool's calls
};

// A garment as Python sees it: either its own (made by a pattern function or loaded from a file), or
// the garment at an index of a session. Adding an own garment to a session moves it there and makes
// the handle a view of the session's, so `g` keeps showing what the tools did to it. A change made
// through a view is a copy of the session's garment, changed and given back with
// Session::set_garment: an operation of the session's journal like any other.
class GarmentRef {
 public:
  explicit GarmentRef(Garment g) : owned_(std::make_shared<Garment>(std::move(g))) {}
  GarmentRef(std::shared_ptr<Session> session, std::size_t index) : session_(std::move(session)), index_(index) {}
  GarmentRef(std::shared_ptr<ToolScope> scope, std::size_t index) : scope_(std::move(scope)), index_(index) {}

  // The garment to read; hold guard() while reading a session's.
  const Garment& get() const {
    if (scope_) return scope_->get("a garment view").garment(index_);
    return session_ ? session_->garment(index_) : *owned_;
  }
  std::optional<SessionGuard> guard() const {
    if (!session_) return std::nullopt;
    return std::optional<SessionGuard>(std::in_place, *session_);
  }
  // Changes the garment: in place if it is its own or a tool's during its stroke, else as an
  // operation on the session.
  void edit(const std::function<void(Garment&)>& change) {
    if (scope_) {
      change(scope_->get("a garment view").garment(index_));
      return;
    }
    if (!session_) {
      change(*owned_);
      return;
    }
    SessionGuard lock(*session_);
    Garment copy = session_->garment(index_);
    change(copy);
    session_->set_garment(index_, copy);
  }
  bool in_session() const { return session_ != nullptr || scope_ != nullptr; }
  // A view a tool written in Python was given: edits change the session's garment in place.
  bool in_tool() const { return scope_ != nullptr; }
  std::size_t index() const { return index_; }
  const std::shared_ptr<Session>& session() const { return session_; }
  void adopt(std::shared_ptr<Session> session, std::size_t index) {
    owned_.reset();
    session_ = std::move(session);
    index_ = index;
  }

 private:
  std::shared_ptr<Garment> owned_;
  std::shared_ptr<Session> session_;
  std::shared_ptr<ToolScope> scope_;
  std::size_t index_ = 0;
};

// Live vertices in index order: row r of every per-vertex array is vertex rows[r].
struct VertexRows {
  std::vector<Vertex> vertices;
  std::vector<long> row;  // by vertex index; -1 for a removed vertex
  explicit VertexRows(const Garment& g);
};

// An (n, cols) float64 array from any real array-like: TypeError for a non-numeric one, InputError
// for the wrong shape or a value that is not finite. cols == 0: a vector of length n.
// n < 0: any number of rows.
py::array_t<double, py::array::c_style> real_array(py::handle obj, const char* what, long n, long cols,
                                                   bool finite = true);
// Copies an Eigen-like row of three into a NumPy vector.
py::array_t<double> vec3_array(const Vec3& v);
Vec3 to_vec3(py::handle obj, const char* what);
// A file path from a str or an os.PathLike.
std::string path_arg(py::handle obj);

// Tool parameters from Python values, checked against the tool's declarations: TypeError for an
// unknown name or a value of the wrong type, InputError (a ValueError) for one out of range.
ParamSet params_from_python(const Session& session, const std::string& tool, const py::dict& values);
py::object param_value_to_python(const ParamValue& value);
std::map<std::string, ParamValue> param_map_from_python(const py::dict& values);
py::dict param_map_to_python(const std::map<std::string, ParamValue>& values);

// Progress and Ctrl-C for long work run with the GIL released: each call re-takes the GIL, raises
// KeyboardInterrupt (as a thrown error_already_set) if a signal is pending, and calls the user's
// callback with the fraction done; the callback may return False to stop early.
class ProgressHook {
 public:
  explicit ProgressHook(py::object callback) : callback_(std::move(callback)) {}
  bool operator()(double fraction) const;

 private:
  py::object callback_;
};

// A Python object that may be dropped from any thread, and after the interpreter has gone (a
// registry or a session destroyed late): it takes the GIL to drop its reference, and leaks it
// when Python is already finalised.
class PyHandle {
 public:
  PyHandle() = default;
  explicit PyHandle(py::object obj) : obj_(new py::object(std::move(obj)), Drop{}) {}
  PyHandle(const PyHandle&) = default;
  PyHandle& operator=(const PyHandle&) = default;
  const py::object& get() const { return *obj_; }
  explicit operator bool() const { return obj_ && *obj_; }

 private:
  struct Drop {
    void operator()(py::object* obj) const;
  };
  std::shared_ptr<py::object> obj_;
};

// The time of a kiji.ToolEvent made without one: the session's clock when it is applied (NaN never
// reaches the session: at_the_clock replaces it).
inline const double kAtTheClock = std::numeric_limits<double>::quiet_NaN();
inline ToolEvent at_the_clock(ToolEvent e, double clock) {
  if (std::isnan(e.time)) e.time = clock;
  return e;
}
// A ToolEvent from Python: a kiji.ToolEvent (whose phase must be `phase`) or a pointer position
// (3,), at `time` (default: the session's clock).
ToolEvent event_arg(py::handle event, Phase phase, double default_time);
Phase parse_phase(const std::string& name);

// Throws InputError naming the garments there are when a session has no garment `index`.
void check_garment_index(const Session& session, std::size_t index);
// The solver of a session's garment as a tool written in Python has it during its calls.
py::object tool_solver(std::shared_ptr<ToolScope> scope, std::size_t index);

void bind_errors(py::module_& m);
void bind_scene(py::module_& m);
void bind_garment(py::module_& m);
void bind_session(py::module_& m);
void bind_solver(py::module_& m);
void bind_topology(py::module_& m);
void bind_interactive(py::module_& m);
void bind_operations(py::module_& m);
void bind_haptics(py::module_& m);
void bind_tools(py::module_& m);
void bind_collision(py::module_& m);
void bind_peer(py::module_& m);

}  // namespace kiji::python
