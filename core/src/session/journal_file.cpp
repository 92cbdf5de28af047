#include "kiji/journal_file.h"

#include "base/overloaded.h"
#include "kiji/error.h"
#include "kiji/session.h"
#include "kiji/version.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <sstream>

namespace kiji {

using json = nlohmann::json;

namespace {

using detail::Overloaded;

// --- base64, for the binary forms of garments and bodies ---

const char kBase64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::string base64(std::string_view in) {
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const std::uint32_t n = (std::uint8_t(in[i]) << 16) | (std::uint8_t(in[i + 1]) << 8) | std::uint8_t(in[i + 2]);
    for (int k = 3; k >= 0; --k) out.push_back(kBase64[(n >> (6 * k)) & 63]);
  }
  if (i < in.size()) {
    std::uint32_t n = std::uint8_t(in[i]) << 16;
    if (i + 1 < in.size()) n |= std::uint8_t(in[i + 1]) << 8;
    out.push_back(kBase64[(n >> 18) & 63]);
    out.push_back(kBase64[(n >> 12) & 63]);
    out.push_back(i + 1 < in.size() ? kBase64[(n >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

// Reads fields of one entry, saying where a malformed one is.
struct Reader {
  std::string where;
  [[noreturn]] void fail(const std::string& what) const { throw InputError(where + ": " + what); }
  const json& field(const json& j, const char* key) const {
    if (!j.is_object() || !j.contains(key)) fail(std::string("'") + key + "' is missing");
    return j[key];
  }
  double number(const json& j, const char* key) const {
    const json& v = field(j, key);
    if (!v.is_number()) fail(std::string("'") + key + "' is not a number");
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail(std::string("'") + key + "' is not a finite number");
    return d;
  }
  // A whole number in [lo, hi]: counts, indices, buttons.
  std::uint64_t whole(const json& j, const char* key, std::uint64_t lo, std::uint64_t hi) const {
    const json& v = field(j, key);
    if (v.is_number_unsigned() || (v.is_number_integer() && v.get<std::int64_t>() >= 0)) {
      const std::uint64_t u = v.get<std::uint64_t>();
      if (u >= lo && u <= hi) return u;
    }
    fail(std::string("'") + key + "' is not a whole number from " + std::to_string(lo) + " to " + std::to_string(hi));
  }
  bool boolean(const json& j, const char* key) const {
    const json& v = field(j, key);
    if (!v.is_boolean()) fail(std::string("'") + key + "' is not true or false");
    return v.get<bool>();
  }
  std::string text(const json& j, const char* key) const {
    const json& v = field(j, key);
    if (!v.is_string()) fail(std::string("'") + key + "' is not a string");
    return v.get<std::string>();
  }
  Vec3 vec3(const json& j, const char* key) const {
    const json& v = field(j, key);
    if (!v.is_array() || v.size() != 3) fail(std::string("'") + key + "' is not a list of 3 numbers");
    Vec3 out;
    for (int i = 0; i < 3; ++i) {
      if (!v[i].is_number() || !std::isfinite(v[i].get<double>()))
        fail(std::string("'") + key + "' is not a list of 3 finite numbers");
      out[i] = v[i].get<double>();
    }
    return out;
  }
  std::string bytes(const json& j, const char* key) const {
    const std::string s = text(j, key);
    if (s.size() % 4 != 0) fail(std::string("'") + key + "' is not base64");
    std::string out;
    out.reserve(s.size() / 4 * 3);
    for (std::size_t i = 0; i < s.size(); i += 4) {
      std::uint32_t n = 0;
      int pad = 0;
      for (int k = 0; k < 4; ++k) {
        const char c = s[i + k];
        int v;
        if (c >= 'A' && c <= 'Z') v = c - 'A';
        else if (c >= 'a' && c <= 'z') v = c - 'a' + 26;
        else if (c >= '0' && c <= '9') v = c - '0' + 52;
        else if (c == '+') v = 62;
        else if (c == '/') v = 63;
        else if (c == '=' && i + 4 == s.size() && k >= 2) v = 0, ++pad;
        else fail(std::string("'") + key + "' is not base64");
        if (pad && c != '=') fail(std::string("'") + key + "' is not base64");
        n = (n << 6) | std::uint32_t(v);
      }
      out.push_back(char((n >> 16) & 255));
      if (pad < 2) out.push_back(char((n >> 8) & 255));
      if (pad < 1) out.push_back(char(n & 255));
    }
    return out;
  }
};

json vec_json(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

json value_json(const ParamValue& value) {
  return std::visit(
      [](const auto& v) -> json {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, Vec3>) return vec_json(v);
        else return json(v);
      },
      value);
}

ParamValue parse_value(const json& j, const Reader& r, const std::string& name) {
  if (j.is_boolean()) return j.get<bool>();
  if (j.is_number_integer()) return j.get<long long>();
  if (j.is_number() && std::isfinite(j.get<double>())) return j.get<double>();
  if (j.is_string()) return j.get<std::string>();
  if (j.is_array() && j.size() == 3 && j[0].is_number() && j[1].is_number() && j[2].is_number())
    return Vec3(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  r.fail("parameter '" + name + "' is not a boolean, number, string or [r, g, b]");
}

json params_json(const std::map<std::string, ParamValue>& params) {
  json out = json::object();
  for (const auto& [name, value] : params) out[name] = value_json(value);
  return out;
}

std::map<std::string, ParamValue> parse_params(const json& j, const Reader& r) {
  std::map<std::string, ParamValue> out;
  if (!j.is_object()) r.fail("'params' is not an object");
  for (const auto& [name, value] : j.items()) out[name] = parse_value(value, r, name);
  return out;
}

json event_json(const ToolEvent& e) {
  const auto& q = e.orientation;
  return {{"phase", phase_name(e.phase)},     {"time", e.time},
          {"position", vec_json(e.position)}, {"orientation", json::array({q.w(), q.x(), q.y(), q.z()})},
          {"buttons", e.buttons},             {"pressure", e.pressure},
          {"ray", vec_json(e.ray)}};
}

Phase parse_phase(const std::string& name, const Reader& r) {
  for (Phase p : {Phase::Begin, Phase::Move, Phase::End, Phase::Cancel})
    if (name == phase_name(p)) return p;
  r.fail("unknown phase '" + name + "' (begin, move, end or cancel)");
}

ToolEvent parse_event(const json& je, const Reader& r) {
  if (!je.is_object()) r.fail("is not an object");
  ToolEvent e;
  e.phase = parse_phase(r.text(je, "phase"), r);
  e.time = r.number(je, "time");
  e.position = r.vec3(je, "position");
  if (je.contains("orientation")) {
    const json& q = je["orientation"];
    if (!q.is_array() || q.size() != 4) r.fail("'orientation' is not [w, x, y, z]");
    double c[4];
    for (int i = 0; i < 4; ++i) {
      if (!q[i].is_number() || !std::isfinite(q[i].get<double>())) r.fail("'orientation' is not 4 finite numbers");
      c[i] = q[i].get<double>();
    }
    e.orientation = Eigen::Quaterniond(c[0], c[1], c[2], c[3]);
  }
  if (je.contains("buttons")) e.buttons = static_cast<std::uint32_t>(r.whole(je, "buttons", 0, 0xffffffffu));
  if (je.contains("pressure")) {
    e.pressure = r.number(je, "pressure");
    if (e.pressure < 0 || e.pressure > 1) r.fail("'pressure' is not between 0 and 1");
  }
  if (je.contains("ray")) e.ray = r.vec3(je, "ray");
  try {
    check_tool_event(e);
  } catch (const InputError& error) {
    r.fail(error.what());
  }
  return e;
}

json solver_json(const SolverParams& p) {
  json j = {{"model", solver_model_name(p.model)},
          {"gravity", vec_json(p.gravity)},
          {"substeps", p.substeps},
          {"iterations", p.iterations},
          {"body_collision", p.body_collision},
          {"self_collision", p.self_collision},
          {"strain_limit", p.strain_limit},
          {"spring_k", p.spring_k},
          {"spring_damping", p.spring_damping},
          {"local_radius", p.local_radius},
          {"local_center", vec_json(p.local_center)},
          {"sleep_after", p.sleep_after},
          {"sleep_distance", p.sleep_distance}};
  // Written only when on, as in the binary form: journals of earlier builds had no floor.
  if (p.floor) j["floor"] = true;
  // Likewise the substeps while a hand holds: absent, a hand's step took `substeps`.
  if (p.held_substeps != 0) j["held_substeps"] = p.held_substeps;
  return j;
}

SolverParams parse_solver(const json& j, const Reader& r) {
  SolverParams p;
  try {
    p.model = parse_solver_model(r.text(j, "model"));
  } catch (const InputError& e) {
    r.fail(e.what());
  }
  p.gravity = r.vec3(j, "gravity");
  p.substeps = static_cast<int>(r.whole(j, "substeps", 1, 1000));
  p.iterations = static_cast<int>(r.whole(j, "iterations", 1, 100));
  p.held_substeps = j.contains("held_substeps") ? static_cast<int>(r.whole(j, "held_substeps", 0, 1000)) : 0;
  p.body_collision = r.boolean(j, "body_collision");
  p.self_collision = r.boolean(j, "self_collision");
  p.floor = j.contains("floor") && r.boolean(j, "floor");
  p.strain_limit = r.number(j, "strain_limit");
  p.spring_k = r.number(j, "spring_k");
  p.spring_damping = r.number(j, "spring_damping");
  p.local_radius = r.number(j, "local_radius");
  p.local_center = r.vec3(j, "local_center");
  p.sleep_after = r.number(j, "sleep_after");
  p.sleep_distance = r.number(j, "sleep_distance");
  try {
    p.validate();
  } catch (const InputError& e) {
    r.fail(e.what());
  }
  return p;
}

json operation_json(const Operation& op) {
  json j = {{"step", op.step}, {"user", op.user}, {"kind", operation_kind(op.data)}};
  auto bytes = [](const std::shared_ptr<const std::string>& b) { return b ? json(base64(*b)) : json(nullptr); };
  std::visit(Overloaded{[&](const op::ToolInput& t) {
                          j["tool"] = t.tool;
                          if (t.event.phase == Phase::Begin) j["params"] = params_json(t.params);
                          j["event"] = event_json(t.event);
                        },
                        [&](const op::AddGarment& a) { j["garment"] = bytes(a.garment); },
                        [&](const op::RemoveGarment& a) { j["index"] = a.index; },
                        [&](const op::SetGarment& a) {
                          j["index"] = a.index;
                          j["garment"] = bytes(a.garment);
                        },
                        [&](const op::SetBody& a) { j["body"] = bytes(a.body); },
                        [&](const op::SetSolverParams& a) { j["params"] = solver_json(a.params); },
                        [&](const op::SetFrameRate& a) { j["steps_per_second"] = a.steps_per_second; },
                        [&](const op::SetSimulating& a) { j["simulating"] = a.simulating; },
                        [&](const op::SetPickRadius& a) { j["radius"] = a.radius; }, [&](const op::Undo&) {},
                        [&](const op::Redo&) {}, [&](const op::Advance&) {},
                        [&](const op::Checkpoint& a) { j["state"] = bytes(a.state); }},
             op.data);
  return j;
}

Operation parse_operation(const json& j, const Reader& r) {
  if (!j.is_object()) r.fail("is not an object");
  Operation op;
  op.step = r.whole(j, "step", 0, std::uint64_t(1) << 53);
  op.user = static_cast<UserId>(r.whole(j, "user", 0, 0xffffffffu));
  const std::string kind = r.text(j, "kind");
  auto payload = [&](const char* key) -> std::shared_ptr<const std::string> {
    if (r.field(j, key).is_null()) return nullptr;
    return std::make_shared<const std::string>(r.bytes(j, key));
  };
  const auto index = [&] { return static_cast<std::uint32_t>(r.whole(j, "index", 0, 0xffffffffu)); };
  if (kind == "tool") {
    op::ToolInput t;
    t.tool = r.text(j, "tool");
    t.event = parse_event(r.field(j, "event"), Reader{r.where + ", its event"});
    if (t.event.phase == Phase::Begin && j.contains("params")) t.params = parse_params(j["params"], r);
    op.data = std::move(t);
  } else if (kind == "add_garment") {
    auto g = payload("garment");
    if (!g) r.fail("'garment' is null");
    op.data = op::AddGarment{std::move(g)};
  } else if (kind == "remove_garment") {
    op.data = op::RemoveGarment{index()};
  } else if (kind == "set_garment") {
    const std::uint32_t i = index();
    auto g = payload("garment");
    if (!g) r.fail("'garment' is null");
    op.data = op::SetGarment{i, std::move(g)};
  } else if (kind == "set_body") {
    op.data = op::SetBody{payload("body")};
  } else if (kind == "set_solver_params") {
    op.data = op::SetSolverParams{parse_solver(r.field(j, "params"), Reader{r.where + ", its params"})};
  } else if (kind == "set_frame_rate") {
    op.data = op::SetFrameRate{r.number(j, "steps_per_second")};
  } else if (kind == "set_simulating") {
    op.data = op::SetSimulating{r.boolean(j, "simulating")};
  } else if (kind == "set_pick_radius") {
    op.data = op::SetPickRadius{r.number(j, "radius")};
  } else if (kind == "undo") {
    op.data = op::Undo{};
  } else if (kind == "redo") {
    op.data = op::Redo{};
  } else if (kind == "advance") {
    op.data = op::Advance{};
  } else if (kind == "checkpoint") {
    op.data = op::Checkpoint{payload("state")};
  } else {
    r.fail("unknown kind '" + kind + "'");
  }
  try {
    check_operation(op);
  } catch (const InputError& error) {
    r.fail(error.what());
  }
  return op;
}

void write_json(const json& doc, const std::string& path, const char* what) {
  std::ofstream out(path);
  if (!out) throw InputError(std::string("cannot write the ") + what + " '" + path +
                             "': check that its folder exists and is writable");
  out << doc.dump(1) << "\n";
  if (!out) throw InputError(std::string("writing the ") + what + " '" + path + "' failed (is the disk full?)");
}

void cancel_strokes_in_progress(Session& session) {
  for (UserId user : session.active_users()) {
    const std::string tool = session.active_tool(user);
    session.apply(tool, cancel_event(session.time()), nullptr, user);
  }
}

}  // namespace

std::vector<JournalStroke> journal_strokes(const Journal& journal) {
  std::vector<JournalStroke> out;
  for (std::size_t i = 0; i < journal.cursor(); ++i) {
    const JournalEntry& e = journal.entries()[i];
    if (!e.events.empty()) out.push_back({e.tool, e.params, e.events});
  }
  return out;
}

std::vector<JournalStroke> strokes_of(const std::vector<Operation>& operations) {
  // The undo history the operations build, followed step by step: a finished stroke, or a garment
  // added, removed or set, is a step (-1 for those that are no stroke); undo and redo move the
  // cursor, and a new step drops what was undone.
  std::vector<JournalStroke> strokes;
  std::map<UserId, JournalStroke> open;
  std::vector<long> history;
  std::size_t cursor = 0;
  auto push = [&](long step) {
    history.resize(cursor);
    history.push_back(step);
    cursor = history.size();
  };
  for (const Operation& op : operations) {
    if (std::holds_alternative<op::Undo>(op.data)) {
      open.clear();
      if (cursor > 0) --cursor;
      continue;
    }
    if (std::holds_alternative<op::Redo>(op.data)) {
      open.clear();
      if (cursor < history.size()) ++cursor;
      continue;
    }
    if (std::holds_alternative<op::Checkpoint>(op.data)) {  // a new undo history
      open.clear();
      history.clear();
      cursor = 0;
      continue;
    }
    const auto* t = std::get_if<op::ToolInput>(&op.data);
    if (!t) {
      if (changes_garments(op.data)) push(-1);
      continue;
    }
    if (t->event.phase == Phase::Begin) {
      open[op.user] = {t->tool, t->params, {t->event}};
      continue;
    }
    auto it = open.find(op.user);
    if (it == open.end()) continue;
    it->second.events.push_back(t->event);
    if (t->event.phase == Phase::End) {
      strokes.push_back(std::move(it->second));
      push(static_cast<long>(strokes.size() - 1));
    }
    if (t->event.phase == Phase::End || t->event.phase == Phase::Cancel) open.erase(it);
  }
  std::vector<JournalStroke> done;
  for (std::size_t i = 0; i < cursor; ++i)
    if (history[i] >= 0) done.push_back(strokes[static_cast<std::size_t>(history[i])]);
  return done;
}

std::vector<Operation> operations_to_save(const Session& session) {
  std::vector<Operation> ops = session.journal().operations();
  if (ops.empty() || ops.back().step < session.steps()) ops.push_back({session.steps(), 0, op::Advance{}});
  return ops;
}

void save_journal(const Session& session, const std::string& path) { save_journal(operations_to_save(session), path); }

void save_journal(const std::vector<Operation>& operations, const std::string& path) {
  json list = json::array();
  for (const Operation& op : operations) list.push_back(operation_json(op));
  write_json({{"format", "kiji-journal"}, {"version", kJournalFileVersion}, {"kiji", version()}, {"operations", list}},
             path, "journal file");
}

void save_journal(const std::vector<JournalStroke>& strokes, const std::string& path) {
  json list = json::array();
  for (const JournalStroke& s : strokes) {
    json events = json::array();
    for (const ToolEvent& e : s.events) events.push_back(event_json(e));
    list.push_back({{"tool", s.tool}, {"params", params_json(s.params)}, {"events", events}});
  }
  write_json({{"format", "kiji-journal"}, {"version", 1}, {"kiji", version()}, {"strokes", list}}, path,
             "journal file");
}

JournalFile parse_journal(std::string_view text, const std::string& name) {
  json doc;
  try {
    doc = json::parse(text.begin(), text.end());
  } catch (const std::exception& e) {
    throw InputError("journal file '" + name + "' is not valid JSON: " + e.what());
  }
  if (!doc.is_object() || !doc.contains("format") || doc["format"] != "kiji-journal")
    throw InputError("'" + name + "' is not a Kiji journal (no \"format\": \"kiji-journal\")");
  if (!doc.contains("version") || !doc["version"].is_number_integer())
    throw InputError("journal file '" + name + "' has no version");
  JournalFile file;
  const auto v = doc["version"].get<long long>();
  if (v < 1 || v > kJournalFileVersion)
    throw InputError("journal file '" + name + "' is version " + std::to_string(v) + "; this Kiji reads versions 1 to " +
                     std::to_string(kJournalFileVersion) + ": use a newer Kiji");
  file.version = static_cast<int>(v);
  if (file.version >= 2) {
    if (!doc.contains("operations") || !doc["operations"].is_array())
      throw InputError("journal file '" + name + "' has no list of operations");
    const json& ops = doc["operations"];
    for (std::size_t i = 0; i < ops.size(); ++i)
      file.operations.push_back(parse_operation(ops[i], Reader{"journal '" + name + "', operation " + std::to_string(i)}));
    return file;
  }
  if (!doc.contains("strokes") || !doc["strokes"].is_array())
    throw InputError("journal file '" + name + "' has no list of strokes");
  for (std::size_t i = 0; i < doc["strokes"].size(); ++i) {
    const json& js = doc["strokes"][i];
    Reader r{"journal '" + name + "', stroke " + std::to_string(i)};
    if (!js.is_object() || !js.contains("tool") || !js["tool"].is_string()) r.fail("has no tool id");
    JournalStroke s;
    s.tool = js["tool"].get<std::string>();
    if (js.contains("params")) s.params = parse_params(js["params"], r);
    if (!js.contains("events") || !js["events"].is_array() || js["events"].empty()) r.fail("has no events");
    for (std::size_t k = 0; k < js["events"].size(); ++k)
      s.events.push_back(parse_event(js["events"][k], Reader{r.where + ", event " + std::to_string(k)}));
    if (s.events.front().phase != Phase::Begin) r.fail("does not start with a begin event");
    file.strokes.push_back(std::move(s));
  }
  return file;
}

JournalFile read_journal_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot read the journal file '" + path + "': it does not exist or is not readable");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_journal(text.str(), path);
}

std::vector<JournalStroke> load_journal(const std::string& path) {
  JournalFile file = read_journal_file(path);
  return file.version >= 2 ? strokes_of(file.operations) : std::move(file.strokes);
}

std::size_t replay(Session& session, const std::vector<JournalStroke>& strokes, const ReplayProgress& progress) {
  // Check every stroke's tool and parameters before changing anything.
  std::vector<ParamSet> params;
  for (const JournalStroke& s : strokes) params.push_back(session.params_for(s.tool, s.params));
  std::size_t total = 0, done = 0, finished = 0;
  for (const JournalStroke& s : strokes) total += s.events.size();
  // Strokes recorded on another clock start now where they began earlier, a time apart as they were.
  double shift = 0;
  if (!strokes.empty() && !strokes.front().events.empty())
    shift = std::max(0.0, session.time() - strokes.front().events.front().time);
  for (std::size_t i = 0; i < strokes.size(); ++i) {
    const JournalStroke& s = strokes[i];
    Tool& tool = session.tool(s.tool);
    for (ToolEvent e : s.events) {
      e.time += shift;
      session.apply(tool, e, &params[i]);
      ++done;
      bool go = true;
      try {
        go = !progress || progress(done, total);
      } catch (...) {  // e.g. the user interrupted: leave nothing half-applied
        cancel_strokes_in_progress(session);
        throw;
      }
      if (!go) {
        cancel_strokes_in_progress(session);
        return finished;
      }
      if (!session.stroke_active()) break;  // an End or Cancel closed it
    }
    if (session.stroke_active()) {  // a stroke that stops without End is finished, as in Session::run
      ToolEvent end = s.events.back();
      end.phase = Phase::End;
      end.time += shift;
      session.apply(tool, end, &params[i]);
    }
    ++finished;
  }
  return finished;
}

std::size_t replay(Session& session, const std::vector<Operation>& operations, const ReplayProgress& progress) {
  // The operations the session has applied already (a session set up the same way) are skipped.
  const auto& own = session.journal().operations();
  std::size_t first = 0;
  while (first < own.size() && first < operations.size() &&
         encode_operation(own[first]) == encode_operation(operations[first]))
    ++first;
  if (first < own.size())
    throw InputError("this session's own history differs from the journal's at operation " + std::to_string(first) +
                     " (" + operation_kind(own[first].data) +
                     "): replay a journal on a new session, or on one set up with the same operations");
  // Time is no operation: a session set up the same way whose clock then ran on has moved its cloth
  // since, and the journal's operations can no longer come at their steps.
  std::uint64_t step = session.steps();
  for (std::size_t i = first; i < operations.size(); ++i) {
    const Operation& op = operations[i];
    const auto* checkpoint = std::get_if<op::Checkpoint>(&op.data);
    if (checkpoint && checkpoint->state) break;  // a whole state sets the clock itself
    if (op.step < step) {
      if (i == first)
        throw InputError("the journal's operation " + std::to_string(i) + " (" + operation_kind(op.data) +
                         ") came at step " + std::to_string(op.step) + ", and this session's clock is at step " +
                         std::to_string(step) + ": time ran on after it was set up. Replay the journal on a new "
                         "session, whose clock has not run");
      throw InputError("the journal's operation " + std::to_string(i) + " (" + operation_kind(op.data) +
                       ") came at step " + std::to_string(op.step) + ", before the one ahead of it (step " +
                       std::to_string(step) + "): the journal is damaged");
    }
    step = op.step;
  }
  std::size_t done = first;
  for (std::size_t i = first; i < operations.size(); ++i) {
    const Operation& op = operations[i];
    session.perform(op);
    ++done;
    bool go = true;
    try {
      go = !progress || progress(done, operations.size());
    } catch (...) {
      cancel_strokes_in_progress(session);
      throw;
    }
    if (!go) {
      cancel_strokes_in_progress(session);
      break;
    }
  }
  return done;
}

std::size_t replay_file(Session& session, const std::string& path, const ReplayProgress& progress) {
  const JournalFile file = read_journal_file(path);
  return file.version >= 2 ? replay(session, file.operations, progress) : replay(session, file.strokes, progress);
}

}  // namespace kiji
