// How a studio session's scene was set up (the body and its import options, each garment's pattern
// and material, the drape before the first stroke), and the session file that keeps it with the
// journal: opening one sets the scene up again and replays the strokes, which gives the same
// garments, as the solver and the tools are deterministic.
#pragma once

#include "kiji/body.h"
#include "kiji/garment.h"
#include "kiji/journal_file.h"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace kiji {
class Session;
}

namespace kiji::studio {

struct BodySpec {
  std::string path;
  BodyImportOptions options;
};

struct GarmentSpec {
  enum class Kind { Rectangle, Panel };
  Kind kind = Kind::Rectangle;
  double width = 1.0, height = 1.0;  // a rectangle, metres
  std::vector<Vec2> outline;        // a panel's outline, metres
  double spacing = 0.02;            // vertex spacing (rectangle) or edge length (panel), metres
  std::string material = "cotton";  // a preset: Material::preset_names()
  // Without a body the cloth hangs from its two top corners (it would fall forever otherwise);
  // with one it is laid flat over it.
  // Throws InputError for a size, spacing or material a garment cannot be made of.
  Garment make() const;
  std::string describe() const;  // "rectangle 1 x 1.2 m, 0.02 m apart, cotton"
  // "rect:W,H,SPACING" as on the command line.
  static GarmentSpec rectangle(const std::string& spec);
};

struct SceneSetup {
  std::optional<BodySpec> body;
  std::vector<GarmentSpec> garments;
  double drape_seconds = 0;  // simulated after the garments were laid over the body, before any stroke

  // Loads the body (outside any session: it takes seconds for a large file).
  std::optional<Body> load_body() const;
  // Puts a garment into the session: over the body if there is one, else hanging at head height
  // from its top corners. Returns its index.
  static std::size_t add(Session& session, const GarmentSpec& spec);
  // The whole scene into an empty session: body, garments, drape. `progress(fraction)` may stop the
  // drape early by returning false.
  void build(Session& session, const std::optional<Body>& body,
             const std::function<bool(double)>& progress = {}) const;
};

// Simulates `seconds` with the drape's solver settings (more substeps), then puts the session's
// own settings back.
void drape_session(Session& session, double seconds, const std::function<bool(double)>& progress = {});

// A session file: NAME.kiji (JSON: the setup and the journal's file name) beside NAME.journal (the
// strokes, a journal any Kiji session can replay) and NAME.glb (each garment as it is now; NAME-2.glb
// for a second one, ...).
struct SessionFile {
  SceneSetup setup;
  std::vector<JournalStroke> strokes;
};
// Writes the three; throws InputError if a file cannot be written.
void save_session_file(const std::string& path, const SceneSetup& setup, const Session& session);
// Throws InputError naming the file and the field for a file that is not a session, or a later version.
SessionFile load_session_file(const std::string& path);

}  // namespace kiji::studio
