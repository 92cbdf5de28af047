// Operations, the session's log and listeners, the undo history, and the journal and session files
// at the level of operations (kiji/operation.h, journal.h, journal_file.h, session_file.h).
#include "bindings.h"

#include "kiji/journal_file.h"
#include "kiji/operation.h"
#include "kiji/session_file.h"

#include <variant>

namespace kiji::python {

namespace {

using SessionPtr = std::shared_ptr<Session>;

template <typename T>
const T* as(const Operation& op) {
  return std::get_if<T>(&op.data);
}

std::vector<Operation> operation_list(py::handle obj) {
  std::vector<Operation> out;
  for (auto item : obj) {
    if (!py::isinstance<Operation>(item))
      throw py::type_error("expected a list of kiji.Operation, found " +
                           py::str(py::type::of(item).attr("__name__")).cast<std::string>());
    out.push_back(item.cast<Operation>());
  }
  return out;
}

py::dict file_report(const SessionFileReport& r) {
  py::dict d;
  d["operations"] = r.operations;
  d["good_bytes"] = r.good_bytes;
  d["file_bytes"] = r.file_bytes;
  d["damage"] = r.damage;
  return d;
}

}  // namespace

void bind_operations(py::module_& m) {
  py::class_<Operation>(m, "Operation",
      "One change to a session, as data: a tool event, a garment added, removed or set, a new body, new\n"
      "solver parameters, pausing, undo ... (kind). The session's log is a list of them (session.operations);\n"
      "replaying it on a new session gives the same garments bit for bit. Read-only; to_bytes/from_bytes\n"
      "give the binary form files and peers carry.")
      .def_readonly("step", &Operation::step, "simulation steps the session had taken when it was applied")
      .def_readonly("user", &Operation::user, "who made it (0: the local user)")
      .def_property_readonly("kind", [](const Operation& op) { return std::string(operation_kind(op.data)); },
                             "'tool', 'add_garment', 'remove_garment', 'set_garment', 'set_body', 'set_solver_params', "
                             "'set_frame_rate', 'set_simulating', 'set_pick_radius', 'undo', 'redo' or 'advance'")
      .def_property_readonly("changes_garments", [](const Operation& op) { return changes_garments(op.data); },
                             "whether it can change a garment (and so is a step of the undo history)")
      .def_property_readonly("tool", [](const Operation& op) -> py::object {
        if (auto t = as<op::ToolInput>(op)) return py::str(t->tool);
        return py::none();
      }, "a tool event's tool id (None for other kinds)")
      .def_property_readonly("event", [](const Operation& op) -> py::object {
        if (auto t = as<op::ToolInput>(op)) return py::cast(t->event);
        return py::none();
      }, "a tool event as the device gave it (None for other kinds)")
      .def_property_readonly("params", [](const Operation& op) -> py::object {
        if (auto t = as<op::ToolInput>(op)) return param_map_to_python(t->params);
        return py::none();
      }, "a begin event's tool parameters (empty for later events; None for other kinds)")
      .def_property_readonly("index", [](const Operation& op) -> py::object {
        if (auto r = as<op::RemoveGarment>(op)) return py::int_(r->index);
        if (auto g = as<op::SetGarment>(op)) return py::int_(g->index);
        return py::none();
      }, "the garment index of remove_garment and set_garment")
      .def_property_readonly("garment", [](const Operation& op) -> py::object {
        std::shared_ptr<const std::string> bytes;
        if (auto a = as<op::AddGarment>(op)) bytes = a->garment;
        if (auto g = as<op::SetGarment>(op)) bytes = g->garment;
        if (!bytes) return py::none();
        return py::cast(std::make_shared<GarmentRef>(decode_garment(*bytes)));
      }, "the garment that add_garment and set_garment carry (a new Garment, in no session)")
      .def_property_readonly("body", [](const Operation& op) -> py::object {
        auto b = as<op::SetBody>(op);
        if (!b || !b->body) return py::none();
        return py::cast(std::make_shared<Body>(decode_body(*b->body)));
      }, "the body of set_body (None for none, or for other kinds)")
      .def_property_readonly("solver_params", [](const Operation& op) -> py::object {
        if (auto p = as<op::SetSolverParams>(op)) return py::cast(p->params);
        return py::none();
      })
      .def_property_readonly("value", [](const Operation& op) -> py::object {
        if (auto r = as<op::SetFrameRate>(op)) return py::float_(r->steps_per_second);
        if (auto s = as<op::SetSimulating>(op)) return py::bool_(s->simulating);
        if (auto p = as<op::SetPickRadius>(op)) return py::float_(p->radius);
        return py::none();
      }, "the new frame rate, simulating flag or pick radius")
      .def("to_bytes", [](const Operation& op) { return py::bytes(encode_operation(op)); },
           "The binary form: version OPERATION_VERSION at most, the oldest that holds the operation.")
      .def_static("from_bytes", [](const py::bytes& b) {
        const std::string bytes = b;
        return decode_operation(bytes);
      }, py::arg("data"), "An operation from its binary form; InputError saying what is malformed, and where.")
      .def("__repr__", [](const Operation& op) {
        std::string extra;
        if (auto t = as<op::ToolInput>(op)) extra = " '" + t->tool + "' " + phase_name(t->event.phase);
        return "<kiji.Operation " + std::string(operation_kind(op.data)) + extra + " at step " + std::to_string(op.step) +
               ", user " + std::to_string(op.user) + ">";
      });
  m.attr("OPERATION_FORMAT_VERSION") = kOperationFormatVersion;
  m.attr("OPERATION_VERSION") = kOperationVersion;
  m.def("hash_bytes", [](const py::bytes& b) { return hash_bytes(std::string(b)); }, py::arg("data"),
        "Kiji's 64-bit FNV-1a hash of bytes (names payloads and states; not a security measure).");

  py::class_<JournalEntry>(m, "HistoryStep", "One step of a session's undo history: a stroke, or a garment added, removed or set.")
      .def_readonly("tool", &JournalEntry::tool, "a stroke's tool id, else the operation's kind")
      .def_readonly("user", &JournalEntry::user)
      .def_property_readonly("params", [](const JournalEntry& e) { return param_map_to_python(e.params); })
      .def_readonly("events", &JournalEntry::events, "a stroke's events as the tool received them (hits filled in)")
      .def("__repr__", [](const JournalEntry& e) {
        return "<kiji.HistoryStep '" + e.tool + "', " + std::to_string(e.events.size()) + " events>";
      });

  py::class_<JournalFile>(m, "JournalFile", "A journal file's content: strokes (version 1) or operations (version 2).")
      .def_readonly("version", &JournalFile::version)
      .def_readonly("strokes", &JournalFile::strokes)
      .def_readonly("operations", &JournalFile::operations);
  m.def("read_journal", [](py::handle path) { return read_journal_file(path_arg(path)); }, py::arg("path"),
        "Reads a journal file of either version; InputError naming the entry and field that is wrong.");
  m.def("parse_journal", [](const std::string& text, const std::string& name) { return parse_journal(text, name); },
        py::arg("text"), py::arg("name") = "journal", "A journal file's content from its JSON text.");
  m.def("strokes_of", [](py::handle ops) { return strokes_of(operation_list(ops)); }, py::arg("operations"),
        "The strokes a list of operations leaves done (undone, cancelled and unfinished ones left out).");
  m.def("save_operations", [](py::handle ops, py::handle path) { save_journal(operation_list(ops), path_arg(path)); },
        py::arg("operations"), py::arg("path"), "Writes operations as a JSON journal (version 2).");
  m.def("load_session_operations", [](py::handle path) {
    SessionFileReport report;
    std::vector<Operation> ops;
    const std::string p = path_arg(path);
    {
      py::gil_scoped_release nogil;
      ops = load_session(p, &report);
    }
    return py::make_tuple(ops, file_report(report));
  }, py::arg("path"),
     "The operations of a session file and a report (operations, good_bytes, file_bytes, damage): a damaged\n"
     "or cut-off end is left out and said in damage.");
  m.attr("SESSION_CHANNEL") = kSessionChannel;
  m.attr("SESSION_STATE_CHANNEL") = kSessionStateChannel;
  m.attr("SESSION_FILE_PROTOCOL") = kSessionFileProtocol;
  m.def("garment_bytes", [](const std::shared_ptr<GarmentRef>& g, bool with_texture) {
    if (!g) throw py::type_error("garment_bytes: expected a kiji.Garment");
    auto lock = g->guard();
    return garment_bytes(g->get(), with_texture);
  }, py::arg("garment"), py::arg("with_texture") = true,
     "Approximate memory of a garment (mesh, properties and texture), bytes: what an undo step holds.");

  auto s = py::reinterpret_borrow<py::class_<Session, SessionPtr>>(m.attr("Session"));
  s.def_property_readonly("operations", [](const Session& self) {
    SessionGuard lock(self);
    return self.journal().operations();
  }, "The session's log: every operation applied, in order (copies).");
  s.def("operations_to_save", [](const Session& self) {
    SessionGuard lock(self);
    return operations_to_save(self);
  }, "The log and, if time passed since its last operation, an 'advance' to the clock: what save writes.");
  s.def("perform", [](Session& self, const Operation& op) {
    SessionGuard lock(self);
    py::gil_scoped_release nogil;
    return self.perform(op);
  }, py::arg("operation"),
     "Applies an operation as the session that made it did (replay, recovery and peers use this): steps the\n"
     "clock to its step first. InputError, changing nothing, for one that cannot apply here.");
  s.def("add_listener", [](Session& self, py::function fn) {
    SessionGuard lock(self);
    PyHandle handle(std::move(fn));
    return self.add_listener([handle](const Operation& op) {
      py::gil_scoped_acquire gil;
      handle.get()(op);
    });
  }, py::arg("listener"),
     "Calls listener(operation) after each operation is applied and logged, on the thread that applied it\n"
     "(autosave and peers are listeners). An error it raises reaches the caller of the operation, which is\n"
     "applied and logged all the same. Returns an id for remove_listener.");
  s.def("remove_listener", [](Session& self, int id) {
    SessionGuard lock(self);
    self.remove_listener(id);
  }, py::arg("id"));
  s.def_property_readonly("history", [](const Session& self) {
    SessionGuard lock(self);
    return self.journal().entries();
  }, "The undo history, oldest first (HistoryStep); steps from history_cursor on were undone.");
  s.def_property_readonly("history_cursor", [](const Session& self) {
    SessionGuard lock(self);
    return self.journal().cursor();
  }, "Steps of the history that are done: undo goes back from here, redo forward.");
  s.def_property_readonly("history_dropped", [](const Session& self) {
    SessionGuard lock(self);
    return self.journal().dropped();
  }, "Steps dropped from the front of the history to keep within history_limit.");
  s.def("_replay_operations", [](Session& self, py::handle ops, const py::object& progress) {
    const auto list = operation_list(ops);
    const ProgressHook hook(progress);
    SessionGuard lock(self);
    py::gil_scoped_release nogil;
    return replay(self, list, [&](std::size_t done, std::size_t total) { return hook(double(done) / double(total)); });
  });
}

}  // namespace kiji::python
