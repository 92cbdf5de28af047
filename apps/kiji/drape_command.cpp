// kiji drape: a flat garment dropped on a body, settled, written to a file with a picture.
#include "args.h"
#include "commands.h"
#include "kiji/body.h"
#include "kiji/drape.h"
#include "kiji/error.h"
#include "kiji/io.h"
#include "kiji/pattern.h"
#include "kiji/render.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

namespace kiji::cli {

namespace {

const char* kDrapeHelp =
    "usage: kiji drape [options]\n"
    "\n"
    "Places a flat garment above the body's shoulders, lets it fall and settle under gravity,\n"
    "writes the result and a picture, and prints a summary.\n"
    "\n"
    "options:\n"
    "  --body FILE              body mesh, any format assimp reads (default: human.zae)\n"
    "  --up x|y|z|-x|-y|-z      the body file's up axis, if its metadata is missing or wrong\n"
    "  --front x|y|z|-x|-y|-z   the body file's axis the body faces (default: what the file says,\n"
    "                           else the way its feet point); the body is turned to face the camera\n"
    "  --scale S                metres per unit of the body file, if its metadata is missing or wrong\n"
    "  --height METRES          scale the body to this height\n"
    "  --no-smooth              keep a low-poly body's facets (by default it is rounded: Loop\n"
    "                           subdivision to 1 cm triangles, so its points do not spike the cloth)\n"
    "  --import-memory MB       memory the process reading the body may take (default 4096)\n"
    "  --import-timeout S       seconds it may take (default 120); raise both for a very large scan\n"
    "  --garment rect:W,H,S     a W x H metre rectangle with vertices S metres apart\n"
    "                           (default rect:1.4,1.0,0.01: 14,241 vertices)\n"
    "  --material NAME          cotton, silk, denim, rubber or tissue (default cotton)\n"
    "  --model xpbd|mass_spring the solver model (default xpbd; mass_spring is the 2006 paper's)\n"
    "  --seconds S              simulated time (default 3)\n"
    "  --substeps N             solver substeps per 1/60 s step (default 40)\n"
    "  --coarse R               first drape a copy remeshed with edges R times as long, then the\n"
    "                           garment itself for the last --fine-seconds (default 3; 1: the\n"
    "                           garment itself throughout, about four times as long)\n"
    "  --coarse-substeps N      the coarse copy's substeps per step (default 15)\n"
    "  --fine-seconds S         the garment's own settle after the copy's drape (default 0.5)\n"
    "  --fine-damping D         its damping meanwhile, at least D per second (default 8)\n"
    "  --out FILE               garment file, .glb or .obj (default out/drape.glb)\n"
    "  --picture FILE           a PNG of the result (default: the --out path with .png)\n"
    "  --no-picture             do not write a picture\n"
    "  --json                   print the summary as one JSON object\n";

void make_parent(const std::string& path) {
  const auto parent = std::filesystem::path(path).parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(parent, ec);
  if (ec) throw InputError("cannot create the folder '" + parent.string() + "': " + ec.message());
}

}  // namespace

int drape_command(const std::vector<std::string>& argv) {
  const Args args(argv,
                  {"--body", "--up", "--front", "--scale", "--height", "--import-memory", "--import-timeout", "--garment", "--material", "--model", "--seconds", "--substeps",
                   "--coarse", "--coarse-substeps", "--fine-seconds", "--fine-damping",
                   "--out", "--picture"},
                  {"--json", "--no-picture", "--no-smooth", "--help", "-h"});
  if (args.has("--help") || args.has("-h")) {
    std::fputs(kDrapeHelp, stdout);
    return 0;
  }
  BodyImportOptions import;
  if (args.has("--up")) import.up = parse_axis(args.get("--up", "y"));
  if (args.has("--front")) import.front = parse_axis(args.get("--front", "z"));
  import.find_front = true;
  import.smooth = !args.has("--no-smooth");
  if (args.has("--scale")) import.scale = args.number("--scale", 1.0);
  if (args.has("--height")) import.height = args.number("--height", 1.0);
  if (args.has("--import-memory")) {
    const double mb = args.number("--import-memory", 4096);
    if (!(mb >= 1 && mb <= 1e9)) throw UsageError("option --import-memory expects MiB from 1 to 1e9, not '" +
                                                  args.get("--import-memory", "") + "'");
    import.limits.memory_mb = static_cast<std::size_t>(mb);
  }
  if (args.has("--import-timeout")) {
    import.limits.seconds = args.number("--import-timeout", 120);
    if (!(import.limits.seconds > 0)) throw UsageError("option --import-timeout expects seconds above 0");
  }
  const std::string body_path = args.get("--body", Body::default_path());
  const RectSpec spec = RectSpec::parse(args.get("--garment", "rect:1.4,1.0,0.01"));
  const Material material = Material::preset(args.get("--material", "cotton"));
  DrapeOptions options;
  options.seconds = args.number("--seconds", 3.0);
  options.solver.model = parse_solver_model(args.get("--model", "xpbd"));
  if (args.has("--substeps")) options.solver.substeps = args.integer("--substeps", 40);
  options.coarse_ratio = args.number("--coarse", options.coarse_ratio);
  options.coarse_substeps = args.integer("--coarse-substeps", options.coarse_substeps);
  options.fine_seconds = args.number("--fine-seconds", options.fine_seconds);
  options.fine_damping = args.number("--fine-damping", options.fine_damping);
  options.validate();
  const std::string out = args.get("--out", "out/drape.glb");
  const std::string ext = std::filesystem::path(out).extension().string();
  if (ext != ".glb" && ext != ".obj")
    throw InputError("--out '" + out + "' must end in .glb or .obj");
  std::string picture;
  if (!args.has("--no-picture"))
    picture = args.get("--picture", std::filesystem::path(out).replace_extension(".png").string());

  const Body body = Body::load(body_path, import);
  Garment garment = make_rectangle_spaced(spec.width, spec.height, spec.spacing, material);
  garment.name = "drape";
  place_over_body(garment, body);
  const DrapeResult result = drape(garment, body, options);

  make_parent(out);
  export_garment(garment, out);
  if (!picture.empty()) {
    make_parent(picture);
    Box3 frame = body.bounds();
    frame.extend(garment.bounds());
    const Image image = render({&garment}, &body, Camera::framing(frame), 1024, 768);
    write_png(image, picture);
  }

  const ClothMeasures& m = result.measures;
  if (args.has("--json")) {
    // Numbers that are not finite (a blown-up cloth) are written as null, as JSON has no NaN.
    auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
    const BodyImportReport& br = body.report();
    const nlohmann::json j = {
        {"body", body_path},
        {"body_height", number(body.height())},
        {"body_triangles", body.triangles().size()},
        {"body_up", axis_name(br.up)},
        {"body_front", axis_name(br.front)},
        {"body_front_source", br.front_source},
        {"body_smoothing", br.smoothing},
        {"model", solver_model_name(options.solver.model)},
        {"material", material.name},
        {"vertices", garment.mesh().number_of_vertices()},
        {"faces", garment.mesh().number_of_faces()},
        // The sum of the steps' dt, rounded to the microsecond: 30 steps of 1/60 s are 0.5 s, not 0.49999999999999994.
        {"seconds_simulated", number(std::round(result.seconds_simulated * 1e6) / 1e6)},
        {"steps", result.steps},
        {"substeps", options.solver.substeps},
        {"coarse_vertices", result.coarse_vertices},
        {"coarse_steps", result.coarse_steps},
        {"coarse_substeps", options.coarse_substeps},
        {"coarse_wall_seconds", number(result.coarse_wall_seconds)},
        {"wall_seconds", number(result.wall_seconds)},
        {"ms_per_step", number(1000.0 * (result.wall_seconds - result.coarse_wall_seconds) /
                               std::max<std::size_t>(1, result.steps))},
        {"max_penetration", number(m.max_penetration)},
        {"thickness", number(material.thickness)},
        {"max_strain", number(m.max_strain)},
        {"mean_strain", number(m.mean_strain)},
        {"kinetic_energy", number(m.kinetic_energy)},
        {"contacts", m.contacts},
        {"out", out},
        {"picture", picture.empty() ? nlohmann::json(nullptr) : nlohmann::json(picture)}};
    std::puts(j.dump(2).c_str());
  } else {
    std::printf("draped %zu vertices / %zu faces of %s on %s (%.2f m tall)\n",
                garment.mesh().number_of_vertices(), garment.mesh().number_of_faces(), material.name.c_str(),
                body_path.c_str(), body.height());
    const BodyImportReport& br = body.report();
    std::printf("  body           up %s (%s), facing %s (%s)%s\n", axis_name(br.up).c_str(), br.up_source.c_str(),
                axis_name(br.front).c_str(), br.front_source.c_str(),
                br.smoothing ? (", rounded by " + std::to_string(br.smoothing) + " subdivisions to " +
                                std::to_string(body.triangles().size()) + " triangles").c_str()
                             : "");
    std::printf("  simulated      %.2f s in %zu steps (%s)\n", result.seconds_simulated,
                result.coarse_steps + result.steps, solver_model_name(options.solver.model).c_str());
    if (result.coarse_vertices)
      std::printf("  coarse first   %zu steps of a %zu-vertex copy at %d substeps (%.2f s wall), then %zu of the\n"
                  "                 garment at %d\n",
                  result.coarse_steps, result.coarse_vertices, options.coarse_substeps, result.coarse_wall_seconds,
                  result.steps, options.solver.substeps);
    std::printf("  wall time      %.2f s (%.2f ms a step of the garment)\n", result.wall_seconds,
                1000.0 * (result.wall_seconds - result.coarse_wall_seconds) / std::max<std::size_t>(1, result.steps));
    std::printf("  penetration    %.2f mm at most (cloth thickness %.1f mm)\n", 1000 * m.max_penetration,
                1000 * material.thickness);
    std::printf("  edge strain    %.2f %% at most, %.2f %% on average\n", 100 * m.max_strain, 100 * m.mean_strain);
    std::printf("  kinetic energy %.3g J at the end\n", m.kinetic_energy);
    std::printf("  contacts       %zu vertices touch the body\n", m.contacts);
    std::printf("wrote %s%s%s\n", out.c_str(), picture.empty() ? "" : " and ", picture.c_str());
  }
  return 0;
}

}  // namespace kiji::cli
