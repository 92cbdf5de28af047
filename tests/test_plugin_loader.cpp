// ToolRegistry's plugin loading: a good plugin is found, described by its metadata and usable in a
// session; every broken one is refused with a message that says why, without crashing the host.
// The plugins are built in tests/plugins/; each test copies what it needs into a folder of its own.
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/plugin_loader.h"
#include "kiji/session.h"

#include <dlfcn.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using kiji::PluginReport;
using kiji::ToolRegistry;

const fs::path kGood = fs::path(KIJI_TEST_PLUGIN_DIR) / "good";
const fs::path kRaw = fs::path(KIJI_TEST_PLUGIN_DIR) / "raw";
const fs::path kGoodLibrary = kGood / "kiji_probe.so";
const fs::path kGoodMetadata = kGood / "kiji_probe.json";

#define EXPECT_CONTAINS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << "expected \"" << (part) << "\" in: " << (text)

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
}

json good_metadata() { return json::parse(read_text(kGoodMetadata)); }

// Whether the dynamic loader has this very file open (a refusal before loading leaves it closed).
bool is_loaded(const fs::path& library) {
  void* handle = dlopen(library.c_str(), RTLD_NOW | RTLD_NOLOAD);
  if (handle) dlclose(handle);
  return handle != nullptr;
}

// Sets an environment variable for one scope.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::optional<std::string>& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) setenv(name, value->c_str(), 1);
    else unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_) setenv(name_, old_->c_str(), 1);
    else unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

class PluginLoaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(KIJI_TEST_TMP) / "plugin_loader" / test->name();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }

  // Puts `library` into the test's folder as <name>.so, with the good plugin's metadata naming it,
  // changed by `change` if given. Returns the path of the copy.
  fs::path add_plugin(const std::string& name, const fs::path& library,
                      const std::function<void(json&)>& change = {}) {
    const fs::path copy = dir_ / (name + ".so");
    fs::copy_file(library, copy, fs::copy_options::overwrite_existing);
    json meta = good_metadata();
    meta["library"] = name + ".so";
    if (change) change(meta);
    write_text(dir_ / (name + ".json"), meta.dump(2));
    return copy;
  }

  // Loads one plugin into a fresh registry and expects it refused.
  PluginReport refused(const fs::path& path) {
    ToolRegistry registry;
    const PluginReport report = registry.load_plugin(path.string());
    EXPECT_FALSE(report.loaded);
    EXPECT_FALSE(report.message.empty());
    EXPECT_TRUE(registry.ids().empty());
    return report;
  }

  fs::path dir_;
};

// --- the good plugin ---

TEST_F(PluginLoaderTest, GoodPluginIsFoundOnASearchPathAndMatchesItsMetadata) {
  ToolRegistry registry;
  const auto reports = registry.load_plugins({kGood.string()});
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_TRUE(reports[0].loaded) << reports[0].message;
  EXPECT_EQ(reports[0].id, "probe");
  EXPECT_EQ(reports[0].path, kGoodLibrary.string());
  EXPECT_TRUE(reports[0].message.empty());
  ASSERT_EQ(registry.ids(), std::vector<std::string>{"probe"});
  EXPECT_EQ(registry.origin("probe"), kGoodLibrary.string());
  EXPECT_TRUE(is_loaded(kGoodLibrary));  // and so is_loaded() can tell

  // The metadata is what the library says of itself, generated at build time.
  const kiji::ToolInfo info = registry.info("probe");
  EXPECT_EQ(read_text(kGoodMetadata), kiji::tool_metadata_json(info, "kiji_probe.so"));
  const json meta = good_metadata();
  EXPECT_EQ(meta["interface"], KIJI_TOOL_INTERFACE);
  EXPECT_EQ(meta["abi"], kiji::abi_tag());
  EXPECT_EQ(meta["id"], info.id);
  EXPECT_EQ(meta["label"], "Probe");
  EXPECT_EQ(meta["label"], info.label);
  EXPECT_EQ(meta["description"], info.description);
  EXPECT_EQ(meta["library"], "kiji_probe.so");
  ASSERT_EQ(meta["parameters"].size(), info.parameters.size());
  ASSERT_EQ(info.parameters.size(), 6u);
  for (std::size_t i = 0; i < info.parameters.size(); ++i) {
    const kiji::ParamSpec& p = info.parameters[i];
    const json& j = meta["parameters"][i];
    SCOPED_TRACE(p.name);
    EXPECT_EQ(j["name"], p.name);
    EXPECT_EQ(j["type"], kiji::param_type_name(p.type));
    EXPECT_EQ(j["label"], p.label);
    EXPECT_EQ(j["help"], p.help);
    EXPECT_EQ(j["unit"], p.unit);
    switch (p.type) {
      case kiji::ParamType::Float:
        EXPECT_EQ(j["default"].get<double>(), std::get<double>(p.default_value));
        EXPECT_EQ(j["min"].get<double>(), p.min);
        EXPECT_EQ(j["max"].get<double>(), p.max);
        break;
      case kiji::ParamType::Int:
        EXPECT_EQ(j["default"].get<long long>(), std::get<long long>(p.default_value));
        EXPECT_EQ(j["min"].get<double>(), p.min);
        EXPECT_EQ(j["max"].get<double>(), p.max);
        break;
      case kiji::ParamType::Bool: EXPECT_EQ(j["default"].get<bool>(), std::get<bool>(p.default_value)); break;
      case kiji::ParamType::String: EXPECT_EQ(j["default"], std::get<std::string>(p.default_value)); break;
      case kiji::ParamType::Choice:
        EXPECT_EQ(j["default"], std::get<std::string>(p.default_value));
        EXPECT_EQ(j["choices"].get<std::vector<std::string>>(), p.choices);
        break;
      case kiji::ParamType::Color: {
        const kiji::Vec3 c = std::get<kiji::Vec3>(p.default_value);
        EXPECT_EQ(j["default"].get<std::vector<double>>(), (std::vector<double>{c.x(), c.y(), c.z()}));
        break;
      }
    }
  }
  EXPECT_EQ(meta["parameters"][0]["name"], "height");
  EXPECT_EQ(meta["parameters"][0]["unit"], "m");
  EXPECT_EQ(meta["parameters"][0]["default"], 0.05);
}

TEST_F(PluginLoaderTest, GoodPluginLoadsFromItsLibraryOrItsMetadataPath) {
  ToolRegistry by_library, by_metadata;
  EXPECT_TRUE(by_library.load_plugin(kGoodLibrary.string()).loaded);
  EXPECT_TRUE(by_metadata.load_plugin(kGoodMetadata.string()).loaded);
  EXPECT_TRUE(by_library.has("probe"));
  EXPECT_TRUE(by_metadata.has("probe"));
}

TEST_F(PluginLoaderTest, PluginExportsOnlyItsEntryPoint) {
  void* handle = dlopen(kGoodLibrary.c_str(), RTLD_NOW | RTLD_LOCAL);
  ASSERT_NE(handle, nullptr) << dlerror();
  EXPECT_NE(dlsym(handle, KIJI_TOOL_PLUGIN_SYMBOL), nullptr);
  EXPECT_EQ(dlsym(handle, "kiji_probe_hidden_marker"), nullptr) << "kiji_add_tool builds with hidden visibility";
  dlclose(handle);
}

TEST_F(PluginLoaderTest, GoodPluginRunsAStrokeThroughASession) {
  auto registry = std::make_shared<ToolRegistry>();
  ASSERT_TRUE(registry->load_plugin(kGoodLibrary.string()).loaded);
  kiji::Session session(registry);
  session.set_simulating(false);
  session.add_garment(kiji::make_rectangle(1.0, 1.0, 5, 5));
  const kiji::Vertex v(12);  // the middle of the 5 x 5 grid
  const kiji::Vec3 start = session.garment(0).position(v);

  kiji::ToolEvent e;
  e.position = start;
  e.phase = kiji::Phase::Begin;
  kiji::Stroke stroke{e};
  e.phase = kiji::Phase::Move;
  stroke.push_back(e);
  e.phase = kiji::Phase::End;
  stroke.push_back(e);

  const kiji::ParamSet params = session.params_for("probe", {{"height", 0.1}, {"repeat", 2LL}});
  session.run("probe", params, stroke);
  EXPECT_NEAR((session.garment(0).position(v) - (start + kiji::Vec3(0, 0.2, 0))).norm(), 0.0, 1e-12);
  ASSERT_EQ(session.journal().entries().size(), 2u) << "the garment added, then the stroke";
  EXPECT_EQ(session.journal().entries().back().tool, "probe");
  EXPECT_TRUE(session.undo());
  EXPECT_NEAR((session.garment(0).position(v) - start).norm(), 0.0, 1e-12);

  // Feedback comes back from the plugin through the session.
  const kiji::Feedback f = session.apply("probe", stroke[0], &params);
  EXPECT_NEAR(f.force.y(), -0.2, 1e-12);
  session.apply("probe", stroke[2]);
  EXPECT_FALSE(session.stroke_active());

  // An error thrown in the plugin reaches the host as the same type; nothing is half-applied.
  const kiji::Vec3 before = session.garment(0).position(v);
  const kiji::ParamSet failing = session.params_for("probe", {{"fail", true}});
  try {
    session.run("probe", failing, stroke);
    ADD_FAILURE() << "the probe did not throw";
  } catch (const kiji::InputError& error) {
    EXPECT_CONTAINS(error.what(), "probe was asked to fail");
  }
  EXPECT_FALSE(session.stroke_active());
  EXPECT_EQ(session.garment(0).position(v), before);
}

// --- where plugins are looked for ---

TEST_F(PluginLoaderTest, KijiPluginPathIsHonoured) {
  const std::string missing = (dir_ / "missing").string();
  ScopedEnv env("KIJI_PLUGIN_PATH", missing + ":" + kGood.string());
  const auto path = ToolRegistry::default_search_path();
  ASSERT_GE(path.size(), 2u);
  EXPECT_EQ(path[0], missing);
  EXPECT_EQ(path[1], kGood.string());

  ToolRegistry registry;
  const auto reports = registry.load_plugins();
  EXPECT_TRUE(registry.has("probe"));
  bool missing_reported = false;
  for (const auto& r : reports)
    if (r.path == missing) {
      missing_reported = true;
      EXPECT_FALSE(r.loaded);
      EXPECT_CONTAINS(r.message, "does not exist");
    }
  EXPECT_TRUE(missing_reported);

  // A session without a registry of its own loads from the same path.
  kiji::Session session;
  EXPECT_TRUE(session.tools().has("probe"));
  EXPECT_EQ(session.tools().origin("probe"), kGoodLibrary.string());
}

TEST_F(PluginLoaderTest, BuildTreePluginFolderIsOnTheDefaultSearchPath) {
  // libkiji lives in build/core; kiji_add_tool puts Kiji's own tools into build/plugins.
  ScopedEnv env("KIJI_PLUGIN_PATH", std::nullopt);
  const std::string build_plugins = fs::weakly_canonical(KIJI_BUILD_PLUGIN_DIR).string();
  const auto path = ToolRegistry::default_search_path();
  EXPECT_NE(std::find(path.begin(), path.end(), build_plugins), path.end()) << build_plugins;
}

// --- refusals: each says why, and none takes the host down ---

TEST_F(PluginLoaderTest, RefusesATextFileNamedLikeALibrary) {
  write_text(dir_ / "kiji_text.so", "this is not a shared library\n");
  json meta = good_metadata();
  meta["id"] = "text";
  meta["library"] = "kiji_text.so";
  write_text(dir_ / "kiji_text.json", meta.dump());
  const PluginReport r = refused(dir_ / "kiji_text.json");
  EXPECT_EQ(r.id, "text");
  EXPECT_CONTAINS(r.message, "kiji_text.so is not a loadable library");
}

TEST_F(PluginLoaderTest, RefusesALibraryWithoutTheEntryPoint) {
  const PluginReport r = refused(add_plugin("kiji_no_entry", kRaw / "kiji_test_no_entry.so"));
  EXPECT_CONTAINS(r.message, "has no entry point " KIJI_TOOL_PLUGIN_SYMBOL);
  EXPECT_CONTAINS(r.message, "KIJI_TOOL_PLUGIN");
}

TEST_F(PluginLoaderTest, RefusesAnotherAbiFromTheMetadataWithoutLoading) {
  const std::string other = "kiji0.1;gcc1;libstdc++0;cgal0.0;eigen0.0;float";
  const fs::path lib = add_plugin("kiji_old", kGoodLibrary, [&](json& j) { j["abi"] = other; });
  const PluginReport r = refused(lib);
  EXPECT_FALSE(is_loaded(lib)) << "refused from its metadata, the library must not be opened";
  EXPECT_EQ(r.id, "probe");
  EXPECT_CONTAINS(r.message, "was built for another ABI (" + other + ")");
  EXPECT_CONTAINS(r.message, kiji::abi_tag());
}

TEST_F(PluginLoaderTest, RefusesABinaryOfAnotherAbiWhoseMetadataClaimsThisOne) {
  const PluginReport r = refused(add_plugin("kiji_liar", kRaw / "kiji_test_other_abi.so"));
  EXPECT_CONTAINS(r.message, "kiji0.1;gcc1;libstdc++0;cgal0.0;eigen0.0;float");
  EXPECT_CONTAINS(r.message, "though its metadata says otherwise");
}

TEST_F(PluginLoaderTest, RefusesAnotherInterfaceVersionFromTheMetadataWithoutLoading) {
  const fs::path lib = add_plugin("kiji_v0", kGoodLibrary, [](json& j) { j["interface"] = "org.kiji.Tool/0"; });
  const PluginReport r = refused(lib);
  EXPECT_FALSE(is_loaded(lib));
  EXPECT_CONTAINS(r.message, "implements org.kiji.Tool/0 but this Kiji loads " KIJI_TOOL_INTERFACE);
}

TEST_F(PluginLoaderTest, RefusesABinaryOfAnotherInterfaceWhoseMetadataClaimsThisOne) {
  const PluginReport r = refused(add_plugin("kiji_v2", kRaw / "kiji_test_other_interface.so"));
  EXPECT_CONTAINS(r.message, "was built for org.kiji.Tool/2");
}

TEST_F(PluginLoaderTest, RefusesASecondPluginWithAnIdAlreadyTaken) {
  add_plugin("kiji_probe", kGoodLibrary);
  const fs::path again = add_plugin("kiji_probe_again", kGoodLibrary);
  ToolRegistry registry;
  const auto reports = registry.load_plugins({dir_.string()});
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_TRUE(reports[0].loaded) << reports[0].message;
  EXPECT_FALSE(reports[1].loaded);
  EXPECT_EQ(reports[1].id, "probe");
  EXPECT_CONTAINS(reports[1].message, "tool id 'probe' is already taken by " + (dir_ / "kiji_probe.so").string());
  EXPECT_FALSE(is_loaded(again));
  EXPECT_EQ(registry.origin("probe"), (dir_ / "kiji_probe.so").string());
}

TEST_F(PluginLoaderTest, RefusesAPluginWhoseIdABuiltInToolHas) {
  struct BuiltIn : kiji::Tool {
    kiji::ToolInfo info() const override { return {"probe", "Built-in probe", "", {}}; }
    kiji::Feedback begin(kiji::Session&, const kiji::ParamSet&, const kiji::ToolEvent&) override { return {}; }
    kiji::Feedback update(kiji::Session&, const kiji::ToolEvent&) override { return {}; }
    void end(kiji::Session&, const kiji::ToolEvent&) override {}
    void cancel(kiji::Session&) override {}
  };
  const fs::path lib = add_plugin("kiji_probe", kGoodLibrary);
  ToolRegistry registry;
  registry.add("probe", [] { return std::make_unique<BuiltIn>(); });
  const PluginReport r = registry.load_plugin(lib.string());
  EXPECT_FALSE(r.loaded);
  EXPECT_CONTAINS(r.message, "tool id 'probe' is already taken by built in");
  EXPECT_FALSE(is_loaded(lib));
  EXPECT_EQ(registry.info("probe").label, "Built-in probe");
}

TEST_F(PluginLoaderTest, RefusesMalformedMetadata) {
  const fs::path lib = add_plugin("kiji_bad_json", kGoodLibrary);
  write_text(dir_ / "kiji_bad_json.json", "{ \"id\": \"probe\", \"interface\": ");
  EXPECT_CONTAINS(refused(lib).message, "is not valid JSON");
  EXPECT_FALSE(is_loaded(lib));

  const fs::path lib2 = add_plugin("kiji_no_fields", kGoodLibrary, [](json& j) { j.erase("abi"); });
  EXPECT_CONTAINS(refused(lib2).message, "lacks the fields interface, id and abi");

  const fs::path lib3 = add_plugin("kiji_array", kGoodLibrary);
  write_text(dir_ / "kiji_array.json", "[1, 2, 3]");
  EXPECT_CONTAINS(refused(lib3).message, "lacks the fields interface, id and abi");
}

TEST_F(PluginLoaderTest, RefusesALibraryWithNoMetadataBesideIt) {
  const fs::path lonely = dir_ / "kiji_lonely.so";
  fs::copy_file(kGoodLibrary, lonely);
  ToolRegistry registry;
  const auto reports = registry.load_plugins({dir_.string()});
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_FALSE(reports[0].loaded);
  EXPECT_EQ(reports[0].path, lonely.string());
  EXPECT_CONTAINS(reports[0].message, "no metadata file kiji_lonely.json beside it");
  EXPECT_CONTAINS(reports[0].message, "kiji_add_tool()");
  EXPECT_CONTAINS(refused(lonely).message, "cannot read the plugin's metadata file");
  EXPECT_FALSE(is_loaded(lonely));
}

TEST_F(PluginLoaderTest, RefusesMetadataWhoseLibraryIsMissing) {
  json meta = good_metadata();
  meta["library"] = "kiji_gone.so";
  write_text(dir_ / "kiji_gone.json", meta.dump());
  EXPECT_CONTAINS(refused(dir_ / "kiji_gone.json").message, "kiji_gone.so named by");
}

TEST_F(PluginLoaderTest, RefusesMetadataThatNamesAnotherIdThanTheLibraryMakes) {
  const fs::path lib = add_plugin("kiji_renamed", kGoodLibrary, [](json& j) { j["id"] = "renamed"; });
  ToolRegistry registry;
  const PluginReport r = registry.load_plugin(lib.string());
  EXPECT_FALSE(r.loaded);
  EXPECT_CONTAINS(r.message, "makes a tool with id 'probe' but its metadata says 'renamed'");
  EXPECT_TRUE(registry.ids().empty());
}

TEST_F(PluginLoaderTest, AFolderOfBrokenPluginsLoadsTheGoodOneAndReportsTheRest) {
  add_plugin("kiji_a_good", kGoodLibrary);
  add_plugin("kiji_b_no_entry", kRaw / "kiji_test_no_entry.so");
  add_plugin("kiji_c_liar", kRaw / "kiji_test_other_abi.so");
  add_plugin("kiji_d_v2", kRaw / "kiji_test_other_interface.so");
  add_plugin("kiji_e_old", kGoodLibrary, [](json& j) { j["abi"] = "kiji0.0"; });
  write_text(dir_ / "kiji_f_text.so", "not a library");
  write_text(dir_ / "kiji_f_text.json", "not json");
  fs::copy_file(kRaw / "kiji_test_no_entry.so", dir_ / "kiji_g_lonely.so");
  write_text(dir_ / "notes.txt", "ignored: neither .json nor .so");

  ToolRegistry registry;
  const auto reports = registry.load_plugins({dir_.string()});
  ASSERT_EQ(reports.size(), 7u);
  int loaded = 0;
  for (const auto& r : reports) {
    loaded += r.loaded;
    if (!r.loaded) EXPECT_FALSE(r.message.empty()) << r.path;
  }
  EXPECT_EQ(loaded, 1);
  EXPECT_TRUE(reports[0].loaded) << reports[0].message;
  EXPECT_EQ(registry.ids(), std::vector<std::string>{"probe"});
}

}  // namespace
