#include "scene_setup.h"

#include "kiji/drape.h"
#include "kiji/error.h"
#include "kiji/io.h"
#include "kiji/pattern.h"
#include "kiji/session.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <sstream>

namespace kiji::studio {

using json = nlohmann::json;

namespace {

constexpr int kSessionFileVersion = 1;

std::string stem(const std::string& path) {
  const auto dot = path.rfind('.');
  const auto slash = path.find_last_of('/');
  return dot != std::string::npos && (slash == std::string::npos || dot > slash) ? path.substr(0, dot) : path;
}

std::string file_name(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string folder(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

}  // namespace

Garment GarmentSpec::make() const {
  const Material m = Material::preset(material);
  Garment g;
  if (kind == Kind::Rectangle) {
    RectSpec r{width, height, spacing};
    r.validate();
    g = make_rectangle_spaced(width, height, spacing, m);
  } else {
    g = make_panel(outline, spacing, m);
  }
  g.name = kind == Kind::Rectangle ? "rectangle" : "panel";
  return g;
}

std::string GarmentSpec::describe() const {
  std::ostringstream s;
  if (kind == Kind::Rectangle) s << "rectangle " << width << " x " << height << " m";
  else s << "panel of " << outline.size() << " corners";
  s << ", " << spacing << " m apart, " << material;
  return s.str();
}

GarmentSpec GarmentSpec::rectangle(const std::string& text) {
  const RectSpec r = RectSpec::parse(text);
  GarmentSpec g;
  g.width = r.width;
  g.height = r.height;
  g.spacing = r.spacing;
  return g;
}

std::optional<Body> SceneSetup::load_body() const {
  if (!body) return std::nullopt;
  return Body::load(body->path, body->options);
}

std::size_t SceneSetup::add(Session& session, const GarmentSpec& spec) {
  Garment g = spec.make();
  if (session.body()) {
    place_over_body(g, *session.body());
  } else {
    // Hanging in front of the origin at head height, from its two top corners.
    const Box3 b = g.bounds();
    Eigen::Affine3d t(Eigen::Translation3d(Vec3(-b.center().x(), 1.7 - b.max().y(), 0)));
    g.transform(t);
    const Box3 placed = g.bounds();
    Vertex left, right;
    double best_left = 1e300, best_right = 1e300;
    for (Vertex v : g.mesh().vertices()) {
      const Vec3 p = g.position(v);
      const double dl = (p - Vec3(placed.min().x(), placed.max().y(), 0)).squaredNorm();
      const double dr = (p - Vec3(placed.max().x(), placed.max().y(), 0)).squaredNorm();
      if (dl < best_left) best_left = dl, left = v;
      if (dr < best_right) best_right = dr, right = v;
    }
    g.set_pinned(left, true);
    g.set_pinned(right, true);
  }
  return session.add_garment(std::move(g));
}

void SceneSetup::build(Session& session, const std::optional<Body>& loaded, const std::function<bool(double)>& progress) const {
  if (loaded) session.set_body(*loaded);
  for (const GarmentSpec& g : garments) add(session, g);
  if (drape_seconds > 0) drape_session(session, drape_seconds, progress);
}

void drape_session(Session& session, double seconds, const std::function<bool(double)>& progress) {
  DrapeOptions options;
  options.seconds = seconds;
  options.validate();
  const SolverParams own = session.solver_params();
  SolverParams p = options.solver;
  p.model = own.model;
  session.set_solver_params(p);
  try {
    const auto steps = static_cast<long>(std::llround(seconds * session.frame_rate()));
    for (long i = 0; i < steps; ++i) {
      session.step();
      if (progress && !progress(double(i + 1) / double(steps))) break;
    }
  } catch (...) {
    session.set_solver_params(own);
    throw;
  }
  session.set_solver_params(own);
}

namespace {

json garment_json(const GarmentSpec& g) {
  json j = {{"material", g.material}, {"spacing", g.spacing}};
  if (g.kind == GarmentSpec::Kind::Rectangle) {
    j["kind"] = "rectangle";
    j["width"] = g.width;
    j["height"] = g.height;
  } else {
    j["kind"] = "panel";
    json outline = json::array();
    for (const Vec2& p : g.outline) outline.push_back({p.x(), p.y()});
    j["outline"] = outline;
  }
  return j;
}

struct Reader {
  std::string where;
  [[noreturn]] void fail(const std::string& what) const { throw InputError(where + ": " + what); }
  double number(const json& j, const char* key) const {
    if (!j.contains(key) || !j[key].is_number()) fail(std::string("'") + key + "' is missing or not a number");
    return j[key].get<double>();
  }
  std::string text(const json& j, const char* key) const {
    if (!j.contains(key) || !j[key].is_string()) fail(std::string("'") + key + "' is missing or not a string");
    return j[key].get<std::string>();
  }
};

GarmentSpec garment_from(const json& j, const Reader& r) {
  if (!j.is_object()) r.fail("a garment is not an object");
  GarmentSpec g;
  const std::string kind = r.text(j, "kind");
  g.material = r.text(j, "material");
  g.spacing = r.number(j, "spacing");
  if (kind == "rectangle") {
    g.width = r.number(j, "width");
    g.height = r.number(j, "height");
  } else if (kind == "panel") {
    g.kind = GarmentSpec::Kind::Panel;
    if (!j.contains("outline") || !j["outline"].is_array()) r.fail("'outline' is missing or not a list");
    for (const json& p : j["outline"]) {
      if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number())
        r.fail("'outline' has a point that is not [x, y]");
      g.outline.emplace_back(p[0].get<double>(), p[1].get<double>());
    }
  } else {
    r.fail("garment kind '" + kind + "' is unknown: 'rectangle' or 'panel'");
  }
  return g;
}

}  // namespace

void save_session_file(const std::string& path, const SceneSetup& setup, const Session& session) {
  const std::string base = stem(path);
  const std::string journal = base + ".journal";
  json j = {{"format", "kiji-studio-session"}, {"version", kSessionFileVersion}};
  if (setup.body) {
    const BodyImportOptions& o = setup.body->options;
    json b = {{"path", setup.body->path}};
    if (o.up) b["up"] = axis_name(*o.up);
    if (o.scale) b["scale"] = *o.scale;
    if (o.height) b["height"] = *o.height;
    j["body"] = b;
  } else {
    j["body"] = nullptr;
  }
  json garments = json::array();
  for (const GarmentSpec& g : setup.garments) garments.push_back(garment_json(g));
  j["garments"] = garments;
  j["drape_seconds"] = setup.drape_seconds;
  j["journal"] = file_name(journal);
  save_journal(session.journal(), journal);
  for (std::size_t i = 0; i < session.garment_count(); ++i)
    export_garment(session.garment(i), base + (i == 0 ? "" : "-" + std::to_string(i + 1)) + ".glb");
  std::ofstream out(path);
  if (!out) throw InputError("cannot write the session file '" + path + "': check the folder exists and is writable");
  out << j.dump(2) << "\n";
  if (!out) throw InputError("writing the session file '" + path + "' failed: is the disk full?");
}

SessionFile load_session_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError("cannot open the session file '" + path + "': check the path");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError("'" + path + "' is not a Kiji Studio session (not JSON: " + e.what() + ")");
  }
  const Reader r{"session file '" + path + "'"};
  if (!j.is_object() || !j.contains("format") || j["format"] != "kiji-studio-session")
    r.fail("it is not a Kiji Studio session (no \"format\": \"kiji-studio-session\")");
  const double version = r.number(j, "version");
  if (version > kSessionFileVersion)
    r.fail("it is version " + std::to_string(int(version)) + ", written by a later Kiji Studio; this one reads version " +
           std::to_string(kSessionFileVersion));
  SessionFile f;
  if (j.contains("body") && !j["body"].is_null()) {
    const json& b = j["body"];
    BodySpec spec;
    spec.path = r.text(b, "path");
    if (!spec.path.empty() && spec.path[0] != '/') spec.path = folder(path) + spec.path;
    if (b.contains("up")) spec.options.up = parse_axis(r.text(b, "up"));
    if (b.contains("scale")) spec.options.scale = r.number(b, "scale");
    if (b.contains("height")) spec.options.height = r.number(b, "height");
    f.setup.body = spec;
  }
  if (!j.contains("garments") || !j["garments"].is_array()) r.fail("'garments' is missing or not a list");
  for (std::size_t i = 0; i < j["garments"].size(); ++i)
    f.setup.garments.push_back(garment_from(j["garments"][i], Reader{r.where + ", garment " + std::to_string(i + 1)}));
  f.setup.drape_seconds = j.contains("drape_seconds") ? r.number(j, "drape_seconds") : 0.0;
  const std::string journal = folder(path) + r.text(j, "journal");
  f.strokes = load_journal(journal);
  return f;
}

}  // namespace kiji::studio
