#include "kiji/journal_file.h"

#include "kiji/error.h"
#include "kiji/session.h"
#include "kiji/version.h"

#include <nlohmann/json.hpp>

#include <fstream>

namespace kiji {

using json = nlohmann::json;

namespace {

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

json event_json(const ToolEvent& e) {
  const auto& q = e.orientation;
  return {{"phase", phase_name(e.phase)},     {"time", e.time},
          {"position", vec_json(e.position)}, {"orientation", json::array({q.w(), q.x(), q.y(), q.z()})},
          {"buttons", e.buttons},             {"pressure", e.pressure},
          {"ray", vec_json(e.ray)}};
}

// Reads fields of one stroke, saying where a malformed one is.
struct Reader {
  std::string where;
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError("journal " + where + ": " + what);
  }
  double number(const json& j, const char* key) const {
    if (!j.contains(key) || !j[key].is_number()) fail(std::string("'") + key + "' is missing or not a number");
    return j[key].get<double>();
  }
  Vec3 vec3(const json& j, const char* key) const {
    if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3)
      fail(std::string("'") + key + "' is missing or not a list of 3 numbers");
    Vec3 v;
    for (int i = 0; i < 3; ++i) {
      if (!j[key][i].is_number()) fail(std::string("'") + key + "' is not a list of 3 numbers");
      v[i] = j[key][i].get<double>();
    }
    return v;
  }
};

Phase parse_phase(const std::string& name, const Reader& r) {
  for (Phase p : {Phase::Begin, Phase::Move, Phase::End, Phase::Cancel})
    if (name == phase_name(p)) return p;
  r.fail("unknown phase '" + name + "' (begin, move, end or cancel)");
}

ParamValue parse_value(const json& j, const Reader& r, const std::string& name) {
  if (j.is_boolean()) return j.get<bool>();
  if (j.is_number_integer()) return j.get<long long>();
  if (j.is_number()) return j.get<double>();
  if (j.is_string()) return j.get<std::string>();
  if (j.is_array() && j.size() == 3 && j[0].is_number() && j[1].is_number() && j[2].is_number())
    return Vec3(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  r.fail("parameter '" + name + "' is not a boolean, number, string or [r, g, b]");
}

ToolEvent cancel_event(double time) {
  ToolEvent e;
  e.phase = Phase::Cancel;
  e.time = time;
  return e;
}

}  // namespace

std::vector<JournalStroke> journal_strokes(const Journal& journal) {
  std::vector<JournalStroke> out;
  for (std::size_t i = 0; i < journal.cursor(); ++i) {
    const JournalEntry& e = journal.entries()[i];
    out.push_back({e.tool, e.params, e.events});
  }
  return out;
}

void save_journal(const Journal& journal, const std::string& path) { save_journal(journal_strokes(journal), path); }

void save_journal(const std::vector<JournalStroke>& strokes, const std::string& path) {
  json doc = {{"format", "kiji-journal"}, {"version", kJournalFileVersion}, {"kiji", version()}};
  json list = json::array();
  for (const JournalStroke& s : strokes) {
    json params = json::object();
    for (const auto& [name, value] : s.params) params[name] = value_json(value);
    json events = json::array();
    for (const ToolEvent& e : s.events) events.push_back(event_json(e));
    list.push_back({{"tool", s.tool}, {"params", params}, {"events", events}});
  }
  doc["strokes"] = list;
  std::ofstream out(path);
  if (!out) throw InputError("cannot write the journal file '" + path + "': check that its folder exists and is writable");
  out << doc.dump(1) << "\n";
  if (!out) throw InputError("writing the journal file '" + path + "' failed");
}

std::vector<JournalStroke> load_journal(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError("cannot read the journal file '" + path + "': it does not exist or is not readable");
  json doc;
  try {
    doc = json::parse(in);
  } catch (const std::exception& e) {
    throw InputError("journal file '" + path + "' is not valid JSON: " + e.what());
  }
  if (!doc.is_object() || doc.value("format", "") != "kiji-journal")
    throw InputError("'" + path + "' is not a Kiji journal (no \"format\": \"kiji-journal\")");
  if (!doc.contains("version") || !doc["version"].is_number_integer())
    throw InputError("journal file '" + path + "' has no version");
  const int v = doc["version"].get<int>();
  if (v < 1 || v > kJournalFileVersion)
    throw InputError("journal file '" + path + "' is version " + std::to_string(v) + "; this Kiji reads version " +
                     std::to_string(kJournalFileVersion) + ": use a newer Kiji");
  if (!doc.contains("strokes") || !doc["strokes"].is_array())
    throw InputError("journal file '" + path + "' has no list of strokes");
  std::vector<JournalStroke> out;
  for (std::size_t i = 0; i < doc["strokes"].size(); ++i) {
    const json& js = doc["strokes"][i];
    Reader r{"'" + path + "', stroke " + std::to_string(i)};
    if (!js.is_object() || !js.contains("tool") || !js["tool"].is_string()) r.fail("has no tool id");
    JournalStroke s;
    s.tool = js["tool"].get<std::string>();
    if (js.contains("params")) {
      if (!js["params"].is_object()) r.fail("'params' is not an object");
      for (const auto& [name, value] : js["params"].items()) s.params[name] = parse_value(value, r, name);
    }
    if (!js.contains("events") || !js["events"].is_array() || js["events"].empty()) r.fail("has no events");
    for (std::size_t k = 0; k < js["events"].size(); ++k) {
      const json& je = js["events"][k];
      Reader re{r.where + ", event " + std::to_string(k)};
      if (!je.is_object() || !je.contains("phase") || !je["phase"].is_string()) re.fail("has no phase");
      ToolEvent e;
      e.phase = parse_phase(je["phase"].get<std::string>(), re);
      e.time = re.number(je, "time");
      e.position = re.vec3(je, "position");
      if (je.contains("orientation")) {
        const json& q = je["orientation"];
        if (!q.is_array() || q.size() != 4) re.fail("'orientation' is not [w, x, y, z]");
        e.orientation = Eigen::Quaterniond(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>());
      }
      if (je.contains("buttons")) e.buttons = static_cast<std::uint32_t>(re.number(je, "buttons"));
      if (je.contains("pressure")) e.pressure = re.number(je, "pressure");
      if (je.contains("ray")) e.ray = re.vec3(je, "ray");
      s.events.push_back(e);
    }
    if (s.events.front().phase != Phase::Begin) r.fail("does not start with a begin event");
    out.push_back(std::move(s));
  }
  return out;
}

std::size_t replay(Session& session, const std::vector<JournalStroke>& strokes, const ReplayProgress& progress) {
  // Check every stroke's tool and parameters before changing anything.
  std::vector<ParamSet> params;
  for (const JournalStroke& s : strokes) params.push_back(session.params_for(s.tool, s.params));
  std::size_t total = 0, done = 0, finished = 0;
  for (const JournalStroke& s : strokes) total += s.events.size();
  for (std::size_t i = 0; i < strokes.size(); ++i) {
    const JournalStroke& s = strokes[i];
    Tool& tool = session.tool(s.tool);
    for (const ToolEvent& e : s.events) {
      session.apply(tool, e, &params[i]);
      ++done;
      bool go = true;
      try {
        go = !progress || progress(done, total);
      } catch (...) {  // e.g. the user interrupted: leave nothing half-applied
        if (session.stroke_active()) session.apply(tool, cancel_event(session.time()));
        throw;
      }
      if (!go) {
        if (session.stroke_active()) session.apply(tool, cancel_event(session.time()));
        return finished;
      }
      if (!session.stroke_active()) break;  // an End or Cancel closed it
    }
    if (session.stroke_active()) {  // a stroke that stops without End is finished, as in Session::run
      ToolEvent end = s.events.back();
      end.phase = Phase::End;
      session.apply(tool, end, &params[i]);
    }
    ++finished;
  }
  return finished;
}

}  // namespace kiji
