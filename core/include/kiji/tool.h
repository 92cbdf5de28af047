// The tool interface: what a fabric tool (pinch, tear, cut, sew, paint, or your own) implements.
//
// A tool sees only device-agnostic ToolEvents and answers with Feedback. Interactive use calls
// begin / update / end / cancel as the user moves; scripts, tests, replay and peers call run(),
// which feeds a recorded stroke through the very same calls. Each call gets a ToolContext: what a
// stroke may do (kiji/tool_context.h). Parameters are declared once in info() and reach the command
// line, Python and the app's panels from there.
//
// A plugin is a MODULE library that defines a Tool subclass and names it with KIJI_TOOL_PLUGIN;
// `kiji_add_tool()` in CMake builds it and writes the JSON metadata the host reads before loading.
#pragma once

#include "kiji/params.h"
#include "kiji/tool_context.h"
#include "kiji/tool_event.h"
#include "kiji/version.h"

#include <cstddef>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

// The interface id and its version: a host loads only plugins of the version it implements.
#define KIJI_TOOL_INTERFACE "org.kiji.Tool/2"

namespace kiji {

class Session;
struct HapticSnapshot;

struct ToolInfo {
  std::string id;           // the verb: "cut" -> plugins/cut/ -> session.cut(...)
  std::string label;        // "Cut"
  std::string description;  // one or two sentences for menus, help() and docs
  std::vector<ParamSpec> parameters;
};

class Tool {
 public:
  virtual ~Tool() = default;

  virtual ToolInfo info() const = 0;

  // The stroke starts: the user pressed the button (phase Begin). `params` are checked values
  // for every declared parameter, fixed for the whole stroke. `context` is valid for the call only.
  virtual Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) = 0;
  // The pointer moved with the button held (phase Move).
  virtual Feedback update(ToolContext& context, const ToolEvent& event) = 0;
  // The button was released (phase End): finish the edit, and let go of what the tool holds.
  virtual void end(ToolContext& context, const ToolEvent& event) = 0;
  // The stroke was abandoned (phase Cancel): leave nothing half-done. The session restores the
  // garments as they were before the stroke; release the hands and the local region the tool holds.
  virtual void cancel(ToolContext& context) = 0;

  // The force on the user's hand for a pointer position between solver steps, asked by the 1 kHz
  // haptic loop on its own thread. It may read only the snapshot (the cloth near the pointer after
  // the last step), the event and the tool's own stroke settings, and must return in microseconds.
  // The default is no force. kiji/haptic_force.h has the snapshot and the force models to use.
  virtual Feedback haptic_force(const HapticSnapshot& snapshot, const ToolEvent& event) const { return {}; }

  // Feeds a recorded stroke through begin / update / end / cancel, through the session (which
  // advances the simulation to each event's time, fills in the surface hit and journals it).
  void run(Session& session, const ParamSet& params, const Stroke& stroke);
};

// The entry point a plugin library exports (see KIJI_TOOL_PLUGIN). The host makes tools with
// `create` and gives each back to the same library's `destroy`: the library that allocated a tool
// frees it.
struct ToolPluginEntry {
  const char* interface_id;  // KIJI_TOOL_INTERFACE the plugin was built against
  const char* abi_tag;       // KIJI_ABI_TAG the plugin was built with, and its layout field
  Tool* (*create)();
  void (*destroy)(Tool*);
};

namespace detail {

constexpr std::size_t kAbiTagCapacity = 1024;

// Writes `base` (KIJI_ABI_TAG) and the layout field: the size and alignment of the types that cross
// the plugin boundary, as the compiler of the binary that includes this lays them out. `static`, so
// that every binary (libkiji, each plugin) measures with its own copy, never borrowing the host's.
static inline const char* write_abi_tag(char* out, std::size_t capacity, const char* base) {
  std::snprintf(out, capacity, "%s;layout=ToolEvent:%zu/%zu,SurfaceHit:%zu/%zu,Feedback:%zu/%zu,Quaterniond:%zu/%zu,Vec2:%zu/%zu",
                base, sizeof(ToolEvent), alignof(ToolEvent), sizeof(SurfaceHit), alignof(SurfaceHit),
                sizeof(Feedback), alignof(Feedback), sizeof(Eigen::Quaterniond), alignof(Eigen::Quaterniond),
                sizeof(Vec2), alignof(Vec2));
  return out;
}

}  // namespace detail

}  // namespace kiji

// The entry point keeps its name and layout across interface versions, so that a host can read the
// interface id of a plugin built for any of them and say why it refuses it.
#define KIJI_TOOL_PLUGIN_SYMBOL "kiji_tool_plugin_v1"

// Exports the factory of ToolClass from a plugin library, with the ABI tag as this plugin's
// compiler sees it.
#define KIJI_TOOL_PLUGIN(ToolClass)                                                                    \
  extern "C" __attribute__((visibility("default"))) const ::kiji::ToolPluginEntry*                    \
  kiji_tool_plugin_v1() {                                                                             \
    static char abi[::kiji::detail::kAbiTagCapacity];                                                 \
    static const ::kiji::ToolPluginEntry entry{                                                       \
        KIJI_TOOL_INTERFACE, ::kiji::detail::write_abi_tag(abi, sizeof abi, KIJI_ABI_TAG),           \
        []() -> ::kiji::Tool* { return new ToolClass(); }, [](::kiji::Tool* tool) { delete tool; }}; \
    return &entry;                                                                                    \
  }
