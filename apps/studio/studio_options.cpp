#include "studio_options.h"

#include "kiji/error.h"
#include "kiji/material.h"

#include <cmath>
#include <sstream>

namespace kiji::studio {

namespace {

double number(const std::string& option, const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  throw UsageError("option " + option + " expects a number, not '" + text + "'");
}

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::string part;
  std::istringstream s(text);
  while (std::getline(s, part, sep))
    if (!part.empty()) out.push_back(part);
  return out;
}

}  // namespace

std::string StudioOptions::usage() {
  return "usage: kiji-studio [options]\n"
         "\n"
         "The scene:\n"
         "  --body FILE             a body to drape on (any file assimp reads: .zae .dae .obj .fbx .glb ...)\n"
         "  --up AXIS               the body file's up axis (+y, -z, ...), when its metadata is wrong or missing\n"
         "  --front AXIS            the body file's axis the body faces (default: what the file says, else the\n"
         "                          way its feet point); the body is turned to face the camera\n"
         "  --no-smooth             keep a low-poly body's facets (by default it is rounded, as kiji drape does)\n"
         "  --scale M               metres per unit of the body file\n"
         "  --height M              scale the body to this height\n"
         "  --garment rect:W,H,S    a W x H m rectangle with vertices S m apart (repeat for more garments)\n"
         "  --material NAME         the garments' fabric: " +
         [] {
           std::string names;
           for (const auto& n : Material::preset_names()) names += (names.empty() ? "" : ", ") + n;
           return names;
         }() +
         "\n"
         "  --drape SECONDS         let the garments fall and settle on the body first\n"
         "  --open SESSION          open a saved session (.kiji) instead\n"
         "  --replay JOURNAL        run the strokes of a journal on the scene\n"
         "Work kept:\n"
         "  --autosave-dir DIR      where the session is autosaved as it changes [the app's data folder]\n"
         "  --no-autosave           no autosave\n"
         "  --recover               recover the newest session an earlier run left unsaved, without asking\n"
         "Designing together (docs/peers.md):\n"
         "  --host                  host a shared session of this scene\n"
         "  --join                  join a shared session (the host's scene replaces this one)\n"
         "  --key-file FILE         the session's key; a host makes a missing file (readable by its owner only),\n"
         "                          and without this option a new one, named in the status bar\n"
         "  --url URL               the LCM network [udpm://239.255.76.67:7667?ttl=0: this computer; ttl=1: the LAN]\n"
         "  --channel NAME          the LCM channel [KIJI_PEER]\n"
         "  --name NAME             your name as the others see it\n"
         "  --seconds S             (host) the shared clock stops at S simulated seconds; a scripted run then\n"
         "                          ends once every peer agrees there (or at --quit-after); so does a scripted\n"
         "                          joiner's run when its host set such a stop\n"
         "The device and the view:\n"
         "  --device mouse|phantom|none   the pointing device (default mouse; a Phantom that fails falls back to\n"
         "                          the mouse, with a message)\n"
         "  --hd-library PATH       OpenHaptics' libHD (default $KIJI_HD_LIBRARY, else libHD.so)\n"
         "  --hd-device NAME        the Phantom's configuration name (default HD_DEFAULT_DEVICE)\n"
         "  --tool ID               the tool of the left button\n"
         "  --edges all|local|none  the garments' edges and vertices: everywhere, around the pointer, or not\n"
         "  --paused                start with the simulation paused\n"
         "  --window WxH            the window's size in pixels (default 1280x800)\n"
         "  --python LINE           a line for the Python console, run once the window is up (repeatable)\n"
         "Scripted runs:\n"
         "  --quit-after SECONDS    run that long, write what is asked below, and exit (0, or 1 if anything failed)\n"
         "  --screenshot FILE       the viewport as a PNG\n"
         "  --window-screenshot FILE  the whole window as a PNG\n"
         "  --save-journal FILE     the session's strokes\n"
         "  --save-session FILE     the session (.kiji, with its journal and garments)\n"
         "  --export FILE           the first garment as .glb or .obj\n"
         "  --save-peers FILE       a shared session's peers as the Peers list shows them, as JSON\n"
         "  --benchmark             measure frames a second while each tool is used, at each size and edge display\n"
         "  --bench-sizes V,...     vertex counts for --benchmark (default 529,5041,19881)\n"
         "  --bench-tools ID,...    tools for --benchmark (default every tool)\n"
         "  --bench-seconds S       seconds a measurement (default 3)\n"
         "  --help, --version\n";
}

StudioOptions StudioOptions::parse(const std::vector<std::string>& args) {
  StudioOptions o;
  std::optional<std::string> material;
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string name = args[i], value;
    bool inline_value = false;
    const auto eq = name.find('=');
    if (name.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
      inline_value = true;
    }
    auto flag = [&] {
      if (inline_value) throw UsageError("option " + name + " takes no value");
    };
    auto take = [&]() -> std::string {
      if (inline_value) return value;
      if (i + 1 >= args.size()) throw UsageError("option " + name + " needs a value");
      return args[++i];
    };
    try {
      if (name == "--help" || name == "-h") flag(), o.help = true;
      else if (name == "--version") flag(), o.version = true;
      else if (name == "--body") o.body = take();
      else if (name == "--up") o.body_options.up = parse_axis(take());
      else if (name == "--front") o.body_options.front = parse_axis(take());
      else if (name == "--no-smooth") flag(), o.body_options.smooth = false;
      else if (name == "--scale") {
        const double s = number(name, take());
        if (s <= 0) throw UsageError("option --scale must be a positive number of metres a unit");
        o.body_options.scale = s;
      } else if (name == "--height") {
        const double h = number(name, take());
        if (h <= 0 || h > 100) throw UsageError("option --height must be between 0 and 100 metres");
        o.body_options.height = h;
      } else if (name == "--garment") {
        o.garments.push_back(GarmentSpec::rectangle(take()));
      } else if (name == "--material") {
        material = take();
        Material::preset(*material);
      } else if (name == "--drape") {
        o.drape_seconds = number(name, take());
        if (o.drape_seconds <= 0 || o.drape_seconds > 3600) throw UsageError("option --drape must be 0 to 3600 seconds");
      } else if (name == "--open") o.open_session = take();
      else if (name == "--replay") o.replay = take();
      else if (name == "--autosave-dir") {
        o.autosave_dir = take();
        if (o.autosave_dir->empty()) throw UsageError("option --autosave-dir needs a folder");
      } else if (name == "--no-autosave") flag(), o.no_autosave = true;
      else if (name == "--recover") flag(), o.recover = true;
      else if (name == "--device") {
        o.device = take();
        if (o.device != "mouse" && o.device != "phantom" && o.device != "none")
          throw UsageError("option --device is 'mouse', 'phantom' or 'none', not '" + o.device + "'");
      } else if (name == "--hd-library") o.hd_library = take();
      else if (name == "--hd-device") o.hd_device = take();
      else if (name == "--tool") o.tool = take();
      else if (name == "--edges") {
        o.edges = take();
        if (*o.edges != "all" && *o.edges != "local" && *o.edges != "none")
          throw UsageError("option --edges is 'all', 'local' or 'none', not '" + *o.edges + "'");
      } else if (name == "--paused") flag(), o.paused = true;
      else if (name == "--window") {
        const std::string v = take();
        const auto x = v.find('x');
        if (x == std::string::npos) throw UsageError("option --window is WIDTHxHEIGHT in pixels, not '" + v + "'");
        const double w = number(name, v.substr(0, x)), h = number(name, v.substr(x + 1));
        if (w < 160 || h < 120 || w > 8192 || h > 8192 || w != std::floor(w) || h != std::floor(h))
          throw UsageError("option --window must be whole pixels, 160x120 to 8192x8192");
        o.width = int(w);
        o.height = int(h);
      } else if (name == "--python") o.python.push_back(take());
      else if (name == "--quit-after") {
        const double s = number(name, take());
        if (s < 0 || s > 86400) throw UsageError("option --quit-after must be 0 to 86400 seconds");
        o.quit_after = s;
      } else if (name == "--screenshot") o.screenshot = take();
      else if (name == "--window-screenshot") o.window_screenshot = take();
      else if (name == "--save-journal") o.save_journal = take();
      else if (name == "--save-session") o.save_session = take();
      else if (name == "--export") o.export_garment = take();
      else if (name == "--host") flag(), o.host = true;
      else if (name == "--join") flag(), o.join = true;
      else if (name == "--url") o.url = take();
      else if (name == "--channel") o.channel = take();
      else if (name == "--name") o.name = take();
      else if (name == "--key-file") o.key_file = take();
      else if (name == "--save-peers") o.save_peers = take();
      else if (name == "--seconds") {
        o.seconds = number(name, take());
        if (o.seconds <= 0 || o.seconds > 1e6) throw UsageError("option --seconds must be more than 0 and at most 1e6");
      }
      else if (name == "--benchmark") flag(), o.benchmark = true;
      else if (name == "--bench-sizes") {
        o.bench_sizes.clear();
        for (const std::string& s : split(take(), ',')) {
          const double v = number(name, s);
          if (v < 4 || v > 2e6 || v != std::floor(v)) throw UsageError("option --bench-sizes takes whole vertex counts, 4 to 2,000,000");
          o.bench_sizes.push_back(int(v));
        }
        if (o.bench_sizes.empty()) throw UsageError("option --bench-sizes needs at least one size");
      } else if (name == "--bench-tools") o.bench_tools = split(take(), ',');
      else if (name == "--bench-seconds") {
        o.bench_seconds = number(name, take());
        if (o.bench_seconds <= 0 || o.bench_seconds > 600) throw UsageError("option --bench-seconds must be 0 to 600");
      } else {
        throw UsageError("unknown option '" + args[i] + "' (see kiji-studio --help)");
      }
    } catch (const InputError& e) {
      throw UsageError("option " + name + ": " + e.what());
    }
  }
  if (material)
    for (GarmentSpec& g : o.garments) g.material = *material;
  if ((o.body_options.up || o.body_options.front || o.body_options.scale || o.body_options.height ||
       !o.body_options.smooth) && !o.body)
    throw UsageError("options --up, --front, --scale, --height and --no-smooth describe a body: give it with --body FILE");
  if (o.host && o.join) throw UsageError("options --host and --join exclude each other: host a session or join one");
  if (o.join && !o.key_file) throw UsageError("option --join needs the session's key: --key-file FILE (the host has it)");
  if (!o.host && !o.join && (o.url || o.channel || o.name || o.key_file || o.seconds > 0 || o.save_peers))
    throw UsageError("options --url, --channel, --name, --key-file, --seconds and --save-peers are for a shared "
                     "session: add --host or --join");
  if (o.join && o.seconds > 0) throw UsageError("option --seconds is the host's: a joiner's clock is the host's");
  if (o.channel && o.channel->empty()) throw UsageError("option --channel needs a name");
  if (o.no_autosave && (o.autosave_dir || o.recover))
    throw UsageError("option --no-autosave leaves out --autosave-dir and --recover");
  if (o.open_session && (o.body || !o.garments.empty()))
    throw UsageError("option --open opens a whole session: leave out --body and --garment");
  return o;
}

}  // namespace kiji::studio
