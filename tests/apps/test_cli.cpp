// The kiji command line as a user runs it: exit codes, messages, files written.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace {

using json = nlohmann::json;

struct CliRun {
  int code = -1;
  std::string out;  // stdout and stderr together
};

CliRun run_program(const std::string& program, const std::string& args) {
  CliRun r;
  const std::string cmd = program + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

CliRun run(const std::string& args) { return run_program(KIJI_CLI, args); }

std::string tmp(const std::string& name) { return std::string(KIJI_TEST_TMP) + "/cli_" + name; }

void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

}  // namespace

TEST(Cli, HelpAndUnknownCommand) {
  EXPECT_EQ(run("--help").code, 0);
  CliRun r = run("drape --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("--garment rect:W,H,S"), std::string::npos);
  r = run("frobnicate");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("unknown command 'frobnicate'"), std::string::npos);
  r = run("drape --colour red");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("unknown option '--colour'"), std::string::npos);
}

TEST(Cli, BadInputIsAClearErrorAndANonZeroExit) {
  struct Case {
    std::string args, expect;
  };
  write(tmp("nan.obj"), "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
  write(tmp("lines.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n");
  write(tmp("garbage.xyzzy"), "this is not a mesh in any format\n");
  const Case cases[] = {
      {"drape --body /nonexistent/body.obj", "/nonexistent/body.obj"},
      {"drape --body " + tmp("garbage.xyzzy"), "garbage.xyzzy"},
      {"drape --body " + tmp("lines.obj"), "no triangles"},
      {"drape --body " + tmp("nan.obj"), "finite"},
      {"drape --garment rect:0,1,0.1", "width"},
      {"drape --garment rect:1,1,-0.1", "spacing"},
      {"drape --garment rect:1,1,2", "larger than the garment"},
      {"drape --garment square:1", "rect:WIDTH,HEIGHT,SPACING"},
      {"drape --seconds -1", "seconds"},
      {"drape --seconds abc", "expects a number"},
      {"drape --coarse 0.5", "coarse_ratio is 0.5: give 1"},
      {"drape --coarse-substeps 0", "coarse_substeps is 0"},
      {"drape --fine-seconds -2", "fine_seconds is -2"},
      {"drape --up w", "unknown axis"},
      {"drape --material velvet", "unknown material"},
      {"drape --model fem", "mass_spring"},
      {"drape --height -2", "height"},
      {"drape --out " + tmp("x.stl"), ".glb or .obj"},
      {"drape --import-memory 0", "--import-memory expects MiB"},
      {"drape --import-timeout 0", "--import-timeout expects seconds"},
      // A body that needs more memory than allowed: refused by the reading process, and said so.
      {"drape --import-memory 1 --body " + std::string(KIJI_TEST_MODELS) + "/Collada/human.zae",
       "more than 1 MiB of memory"},
  };
  for (const Case& c : cases) {
    CliRun r = run(c.args);
    EXPECT_NE(r.code, 0) << c.args;
    EXPECT_NE(r.code, -1) << c.args << " crashed";
    EXPECT_NE(r.out.find(c.expect), std::string::npos) << c.args << " said: " << r.out;
  }
}

TEST(Cli, DrapePrintsJsonAndWritesTheGarmentAndAPicture) {
  const std::string out = tmp("small.glb"), png = tmp("small.png");
  std::filesystem::remove(out);
  std::filesystem::remove(png);
  CliRun r = run("drape --garment rect:0.8,0.6,0.04 --seconds 0.5 --json --out " + out + " --picture " + png);
  ASSERT_EQ(r.code, 0) << r.out;
  // 336 vertices: too few for a coarse copy to be worth it, so the garment falls itself throughout.
  for (const char* field : {"\"vertices\": 336", "\"faces\":", "\"seconds_simulated\": 0.5", "\"wall_seconds\":",
                            "\"max_penetration\":", "\"max_strain\":", "\"kinetic_energy\":", "\"contacts\":",
                            "\"coarse_vertices\": 0", "\"steps\": 30"})
    EXPECT_NE(r.out.find(field), std::string::npos) << field << " missing from " << r.out;
  EXPECT_GT(std::filesystem::file_size(out), 1000u);
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
}

TEST(Cli, ToolsListsThePluginsWithTheirParameters) {
  CliRun r = run("tools --path " KIJI_PLUGIN_DIR);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("6 tools"), std::string::npos) << r.out;
  for (const char* text : {"cut — Cut", "paint — Paint", "pin — Pin", "pinch — Pinch", "sew — Sew", "tear — Tear",
                           "local_radius", "tear threshold", "hardness", "one of 'remove' 'split'"})
    EXPECT_NE(r.out.find(text), std::string::npos) << text;
  r = run("tools --path /nonexistent");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("0 tools"), std::string::npos);
  EXPECT_NE(r.out.find("/nonexistent: plugin folder does not exist"), std::string::npos) << r.out;
}

TEST(Cli, BenchPrintsEveryFigureAsJson) {
  CliRun r = run("bench --quick --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const json d = json::parse(r.out, nullptr, false);
  ASSERT_FALSE(d.is_discarded()) << "not one JSON document: " << r.out;
  EXPECT_EQ(r.out.find("null"), std::string::npos) << "every figure measured: " << r.out;
  auto positive = [](const json& v) { return v.is_number() && std::isfinite(v.get<double>()) && v.get<double>() > 0; };
  EXPECT_GE(d.at("threads").get<int>(), 1);

  // The paper's own figures, beside Kiji's: its three sizes, one rate for each.
  EXPECT_EQ(d.at("paper").at("sizes"), json({289, 400, 521}));
  for (const char* table : {"without_edges", "with_edges"})
    for (const char* tool : {"pinch", "tear", "cut", "sew", "paint"}) {
      const json& rates = d.at("paper").at(table).at(tool);
      ASSERT_EQ(rates.size(), 3u) << table << "." << tool;
      for (const json& v : rates) EXPECT_TRUE(positive(v)) << table << "." << tool;
    }

  // Kiji's rows: one a size asked for, every tool measured, every rate a positive number.
  ASSERT_FALSE(d.at("tool_rates").empty());
  EXPECT_EQ(d.at("tool_rates")[0].at("vertices"), 289);
  for (const json& row : d.at("tool_rates")) {
    const int vertices = row.at("vertices").get<int>();
    for (const char* tool : {"pinch", "pinch_local", "pinch_landing", "tear", "cut", "sew", "paint"}) {
      EXPECT_TRUE(positive(row.at(tool).at("steps_per_second"))) << vertices << " " << tool;
      EXPECT_TRUE(positive(row.at(tool).at("frames_per_second"))) << vertices << " " << tool;
    }
    // The local region moves some of the cloth, not all of it.
    const json& local = row.at("pinch_local");
    EXPECT_TRUE(positive(local.at("local_radius_m")));
    EXPECT_GT(local.at("moving_vertices").get<int>(), 0);
    EXPECT_LT(local.at("moving_vertices").get<int>(), vertices);
  }

  // Against Bullet: each speed-up is the ratio of the times printed beside it, and the matched
  // settings' strain is no worse than Bullet's (what "at equal strain" means).
  ASSERT_FALSE(d.at("versus_bullet").empty());
  for (const json& row : d.at("versus_bullet")) {
    SCOPED_TRACE(row.dump());
    for (const char* solver : {"xpbd", "mass_spring", "bullet", "xpbd_matched"}) {
      const json& s = row.at(solver);
      EXPECT_TRUE(positive(s.at("ms_per_step"))) << solver;
      EXPECT_TRUE(positive(s.at("sag_m"))) << solver << ": a cloth held by its top edge sags";
      EXPECT_GE(s.at("max_strain").get<double>(), s.at("mean_strain").get<double>()) << solver;
      EXPECT_GE(s.at("mean_strain").get<double>(), 0.0) << solver;
    }
    const double bullet_ms = row.at("bullet").at("ms_per_step").get<double>();
    EXPECT_NEAR(row.at("speedup_xpbd_over_bullet").get<double>(), bullet_ms / row.at("xpbd").at("ms_per_step").get<double>(),
                1e-3 * row.at("speedup_xpbd_over_bullet").get<double>());
    EXPECT_NEAR(row.at("speedup_at_equal_strain").get<double>(),
                bullet_ms / row.at("xpbd_matched").at("ms_per_step").get<double>(),
                1e-3 * row.at("speedup_at_equal_strain").get<double>());
    EXPECT_LE(row.at("xpbd_matched").at("max_strain").get<double>(), row.at("bullet").at("max_strain").get<double>());
    EXPECT_GE(row.at("matched_substeps").get<int>(), 1);
  }

  // The haptic loop: its rate is at most the 1 kHz it is paced at, and a median at most the 99th
  // percentile.
  const json& h = d.at("haptics");
  EXPECT_TRUE(positive(h.at("loop_hz")));
  EXPECT_LE(h.at("loop_hz").get<double>(), 1000.0 * 1.01);
  EXPECT_GT(h.at("ticks").get<int>(), 0);
  EXPECT_GE(h.at("jitter_us").get<double>(), 0.0);
  EXPECT_LE(h.at("force_median_us").get<double>(), h.at("force_p99_us").get<double>());
  EXPECT_TRUE(positive(h.at("simulation_ms_per_step")));

  // Scaling: per-vertex figures are the step's time over the vertices, shares are shares.
  EXPECT_EQ(d.at("scaling_substeps"), 10);
  ASSERT_GE(d.at("scaling").size(), 2u);
  for (const json& row : d.at("scaling")) {
    SCOPED_TRACE(row.dump());
    const double v = row.at("vertices").get<double>();
    EXPECT_NEAR(row.at("us_per_vertex").get<double>() * v / 1000, row.at("ms_per_step").get<double>(),
                1e-3 * row.at("ms_per_step").get<double>());
    for (const char* figure : {"falling_median_us_per_vertex", "landing_median_us_per_vertex", "bytes_per_vertex"})
      EXPECT_TRUE(positive(row.at(figure))) << figure;
    EXPECT_GE(row.at("landing_strain_limited_share").get<double>(), 0.0);
    EXPECT_LE(row.at("landing_strain_limited_share").get<double>(), 1.0);
    EXPECT_GE(row.at("landing_self_gathers_per_step").get<double>(), 0.0);
    EXPECT_GE(row.at("landing_self_pairs_per_vertex").get<double>(), 0.0);
    EXPECT_GE(row.at("landing_edges_moved_per_substep").get<double>(), 0.0);
  }
  for (const char* exponent : {"falling_exponent_all_sizes", "falling_exponent_largest_two", "landing_exponent_all_sizes",
                               "landing_exponent_largest_two"})
    EXPECT_TRUE(std::isfinite(d.at("scaling_growth").at(exponent).get<double>())) << exponent;

  r = run("bench --sizes 3,x");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--sizes expects vertex counts"), std::string::npos) << r.out;
  r = run("bench --quick --scaling-substeps 0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--scaling-substeps: solver parameter 'substeps' is 0: it must be between 1 and 1000"),
            std::string::npos)
      << r.out;
  r = run("bench --quick --tools pinch,tweak");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("'tweak' is not a row of the tables"), std::string::npos) << r.out;
}

TEST(Cli, BenchToolsPicksTheRowsOfThePapersTables) {
  CliRun r = run("bench --quick --json --sizes 289 --tools pinch_local,sew");
  ASSERT_EQ(r.code, 0) << r.out;
  // The measured rows (the paper's own figures, beside them, have every tool).
  // The measured rows (the paper's own figures, beside them, have every tool).
  const nlohmann::json rates = nlohmann::json::parse(r.out)["tool_rates"].at(0);
  EXPECT_TRUE(rates["pinch_local"]["steps_per_second"].is_number()) << rates;
  EXPECT_TRUE(rates["sew"]["steps_per_second"].is_number()) << rates;
  for (const char* absent : {"pinch", "pinch_landing", "tear", "cut", "paint"})
    EXPECT_FALSE(rates.contains(absent)) << absent << " was not asked for: " << rates;
}

// --scaling-substeps reaches the scaling section's solver: at twice the substeps the landing moves
// the cloth about half as many edges a substep (the same fall, in substeps half as long).
TEST(Cli, BenchScalingSubstepsSetsTheScalingSolversSubsteps) {
  auto edges_moved = [](const std::string& out) {
    std::vector<double> found;
    const nlohmann::json j = nlohmann::json::parse(out);
    for (const auto& size : j["scaling"]) found.push_back(size["landing_edges_moved_per_substep"]);
    return found;
  };
  const std::string rest = " --quick --json --sizes 289 --tools pinch --scaling-sizes 400";
  CliRun r10 = run("bench" + rest), r20 = run("bench --scaling-substeps 20" + rest);
  ASSERT_EQ(r10.code, 0) << r10.out;
  ASSERT_EQ(r20.code, 0) << r20.out;
  EXPECT_EQ(nlohmann::json::parse(r20.out)["scaling_substeps"], 20) << r20.out;
  const std::vector<double> at10 = edges_moved(r10.out), at20 = edges_moved(r20.out);
  ASSERT_EQ(at10.size(), 1u) << r10.out;
  ASSERT_EQ(at20.size(), 1u) << r20.out;
  EXPECT_GT(at10[0], 0.0);
  EXPECT_NEAR(at20[0] / at10[0], 0.5, 0.1) << at10[0] << " edges a substep at 10 substeps, " << at20[0] << " at 20";
}

// `kiji bench` runs the benchmark program built beside kiji, with its arguments and its exit code;
// a kiji without it says what is missing and how to build it.
TEST(Cli, BenchRunsTheBenchmarkProgramBesideKiji) {
  CliRun r = run("bench --help");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("usage: kiji bench [--json] [--quick]"), std::string::npos) << r.out;
  r = run("bench peers --help");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("usage: kiji bench peers"), std::string::npos) << r.out;
  r = run("bench peers --frames x");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("kiji bench: option --frames expects a number, not 'x'"), std::string::npos) << r.out;

  const std::filesystem::path alone = tmp("alone");
  std::filesystem::remove_all(alone);
  std::filesystem::create_directories(alone);
  std::filesystem::copy_file(KIJI_CLI, alone / "kiji");
  r = run_program((alone / "kiji").string(), "bench --quick");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("kiji bench: the benchmark program " + (alone / "kiji-bench").string() + " is missing"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("--target kiji_bench"), std::string::npos) << r.out;
}
