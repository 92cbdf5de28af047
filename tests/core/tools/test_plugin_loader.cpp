// ToolRegistry's plugin loading: a good plugin is found, described by its metadata and usable in a
// session; every broken one is refused with a message that says why, without crashing the host.
// The plugins are built in tests/fixtures/plugins/; each test copies what it needs into a folder of its own.
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/plugin_loader.h"
#include "kiji/session.h"

#include <dlfcn.h>
#include <sys/stat.h>
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
// The tag probe_tool.cpp claims when built with KIJI_TEST_OTHER_ABI.
const std::string kOtherAbi = "kiji=0.1;compiler=gcc1;stdlib=libstdc++0;cgal=0.0;eigen=0.0.0;scalar=float";

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

  // Metadata changes for the broken tool's builds (they describe the probe otherwise).
  static void broken_id(json& j) { j["id"] = "broken"; }

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
  const std::string other = kOtherAbi + ";layout=ToolEvent:1/1";
  const fs::path lib = add_plugin("kiji_old", kGoodLibrary, [&](json& j) { j["abi"] = other; });
  const PluginReport r = refused(lib);
  EXPECT_FALSE(is_loaded(lib)) << "refused from its metadata, the library must not be opened";
  EXPECT_EQ(r.id, "probe");
  EXPECT_CONTAINS(r.message, "was built for another ABI (" + other + ")");
  EXPECT_CONTAINS(r.message, kiji::abi_tag());
  // Each part that differs is named, with what to do.
  EXPECT_CONTAINS(r.message, "compiler differs (plugin gcc1, this Kiji " KIJI_COMPILER_TAG ")");
  EXPECT_CONTAINS(r.message, "scalar differs (plugin float, this Kiji double)");
  EXPECT_CONTAINS(r.message, "build it with the compiler Kiji was built with");
}

TEST_F(PluginLoaderTest, RefusesABinaryOfAnotherAbiWhoseMetadataClaimsThisOne) {
  const PluginReport r = refused(add_plugin("kiji_liar", kRaw / "kiji_test_other_abi.so"));
  EXPECT_CONTAINS(r.message, kOtherAbi);
  EXPECT_CONTAINS(r.message, "though its metadata says otherwise");
  EXPECT_CONTAINS(r.message, "cgal differs (plugin 0.0, this Kiji " CGAL_VERSION_STR ")");
}

TEST_F(PluginLoaderTest, RefusesAToolBuiltWithAvxWhoseEventsAreLaidOutOtherwise) {
#if !defined(KIJI_TEST_AVX) || EIGEN_MAX_STATIC_ALIGN_BYTES >= 32
  GTEST_SKIP() << "cannot run in this build: -mavx exists only on x86-64, and where Kiji itself is built with "
                  "AVX a plugin built with -mavx lays events out as the host does (nothing to refuse)";
#else
  // With AVX Eigen aligns Quaterniond to 32 bytes, so ToolEvent::orientation and every member after
  // it move: the plugin would read the host's events at the wrong offsets. Its metadata says
  // nothing of it (it claims this Kiji's tag); its binary tells.
  const PluginReport r = refused(add_plugin("kiji_avx", kRaw / "kiji_test_avx.so"));
  EXPECT_CONTAINS(r.message, "though its metadata says otherwise");
  EXPECT_CONTAINS(r.message, "eigen_align differs (plugin 32/32, this Kiji 16/16)");
  EXPECT_CONTAINS(r.message, "-mavx");
  EXPECT_CONTAINS(r.message, "layout differs (plugin ToolEvent:");
  EXPECT_CONTAINS(r.message, "ToolEvent:" + std::to_string(sizeof(kiji::ToolEvent)) + "/16");
#endif
}

TEST(AbiTag, NamesEveryPartThatDecidesTheLayoutOfWhatToolsReceive) {
  const std::string tag = kiji::abi_tag();
  for (const char* field : {"kiji=", ";compiler=", ";stdlib=", ";stl_debug=", ";cgal=", ";eigen=", ";eigen_align=",
                            ";eigen_index=", ";eigen_order=", ";scalar=double", ";layout="})
    EXPECT_CONTAINS(tag, field);
  EXPECT_CONTAINS(tag, "eigen_align=" + std::to_string(EIGEN_MAX_STATIC_ALIGN_BYTES) + "/" +
                           std::to_string(EIGEN_MAX_ALIGN_BYTES));
  EXPECT_CONTAINS(tag, "ToolEvent:" + std::to_string(sizeof(kiji::ToolEvent)) + "/" +
                           std::to_string(alignof(kiji::ToolEvent)));
  EXPECT_CONTAINS(tag, "Quaterniond:" + std::to_string(sizeof(Eigen::Quaterniond)) + "/" +
                           std::to_string(alignof(Eigen::Quaterniond)));
  EXPECT_EQ(kiji::abi_difference(tag, tag), "");
}

TEST(AbiTag, ADifferenceSaysWhichPartDiffersAndWhatToDo) {
  const std::string host = "kiji=0.2;eigen_align=16/16;layout=ToolEvent:168/16";
  EXPECT_EQ(kiji::abi_difference(host, host), "");
  const std::string diff = kiji::abi_difference("kiji=0.2;eigen_align=32/32;layout=ToolEvent:192/32", host);
  EXPECT_CONTAINS(diff, "eigen_align differs (plugin 32/32, this Kiji 16/16)");
  EXPECT_CONTAINS(diff, "layout differs (plugin ToolEvent:192/32, this Kiji ToolEvent:168/16)");
  EXPECT_EQ(diff.find("kiji differs"), std::string::npos) << diff;
  EXPECT_CONTAINS(kiji::abi_difference("kiji=0.2;eigen_align=16/16", host), "layout differs (plugin (none)");
  EXPECT_CONTAINS(kiji::abi_difference(host + ";extra=1", host), "extra differs (plugin 1, this Kiji (none))");
  EXPECT_CONTAINS(kiji::abi_difference("kiji0.1;gcc12;double", host), "built against an older Kiji");
  EXPECT_CONTAINS(kiji::abi_difference("eigen_align=16/16;kiji=0.2;layout=ToolEvent:168/16", host),
                  "is not one this Kiji writes");
}

TEST_F(PluginLoaderTest, RefusesAnotherInterfaceVersionFromTheMetadataWithoutLoading) {
  const fs::path lib = add_plugin("kiji_v0", kGoodLibrary, [](json& j) { j["interface"] = "org.kiji.Tool/0"; });
  const PluginReport r = refused(lib);
  EXPECT_FALSE(is_loaded(lib));
  EXPECT_CONTAINS(r.message, "implements org.kiji.Tool/0 but this Kiji loads " KIJI_TOOL_INTERFACE);
}

TEST_F(PluginLoaderTest, RefusesABinaryOfAnotherInterfaceWhoseMetadataClaimsThisOne) {
  const PluginReport r = refused(add_plugin("kiji_v3", kRaw / "kiji_test_other_interface.so"));
  EXPECT_CONTAINS(r.message, "was built for org.kiji.Tool/3");
}

// A plugin built against a Kiji of the first tool interface, whose tools were given the whole
// Session: refused before it is loaded, with what changed and what its author must do.
TEST_F(PluginLoaderTest, RefusesAPluginBuiltForTheFirstInterfaceSayingWhatChanged) {
  const fs::path lib =
      add_plugin("kiji_probe_v1", kRaw / "kiji_test_interface_1.so", [](json& j) { j["interface"] = "org.kiji.Tool/1"; });
  const PluginReport r = refused(lib);
  EXPECT_FALSE(is_loaded(lib));
  EXPECT_EQ(r.id, "probe");
  EXPECT_CONTAINS(r.message, "plugin 'probe' implements org.kiji.Tool/1 but this Kiji loads org.kiji.Tool/2");
  EXPECT_CONTAINS(r.message, "a kiji::ToolContext (kiji/tool_context.h");
  EXPECT_CONTAINS(r.message, "take a kiji::ToolContext& in place of kiji::Session&, and rebuild it against this Kiji");

  // Its binary says the same where its metadata was rewritten for this Kiji by hand.
  const PluginReport r2 = refused(add_plugin("kiji_probe_v1_relabelled", kRaw / "kiji_test_interface_1.so"));
  EXPECT_CONTAINS(r2.message, "was built for org.kiji.Tool/1, not for this Kiji's org.kiji.Tool/2");
  EXPECT_CONTAINS(r2.message, "in place of kiji::Session&");
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
    kiji::Feedback begin(kiji::ToolContext&, const kiji::ParamSet&, const kiji::ToolEvent&) override { return {}; }
    kiji::Feedback update(kiji::ToolContext&, const kiji::ToolEvent&) override { return {}; }
    void end(kiji::ToolContext&, const kiji::ToolEvent&) override {}
    void cancel(kiji::ToolContext&) override {}
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

// --- plugins whose code misbehaves: each is a refused plugin or a failed stroke, never a crash ---

TEST_F(PluginLoaderTest, RefusesAPluginWhoseCreateReturnsNoTool) {
  const PluginReport r = refused(add_plugin("kiji_null", kRaw / "kiji_test_create_null.so", broken_id));
  EXPECT_EQ(r.id, "broken");
  EXPECT_CONTAINS(r.message, "kiji_null.so cannot make its tool: its create() returned no tool (a null pointer)");
}

TEST_F(PluginLoaderTest, RefusesAPluginWhoseCreateThrowsSomethingNotAnException) {
  const PluginReport r = refused(add_plugin("kiji_int", kRaw / "kiji_test_create_throws_int.so", broken_id));
  EXPECT_CONTAINS(r.message, "its create() threw something that is not a std::exception");
}

TEST_F(PluginLoaderTest, RefusesAPluginWhoseCreateThrowsAnExceptionOfItsOwn) {
  // The exception's what() and destructor are the plugin's code: the message is copied out and the
  // exception gone before the library is closed.
  const fs::path lib = add_plugin("kiji_own", kRaw / "kiji_test_create_throws_own.so", broken_id);
  const PluginReport r = refused(lib);
  EXPECT_CONTAINS(r.message, "its create() threw: the plugin's own exception, thrown by create()");
  EXPECT_FALSE(is_loaded(lib)) << "a refused library is closed";
}

TEST_F(PluginLoaderTest, RefusesAPluginWhoseToolCannotDescribeItself) {
  const PluginReport r = refused(add_plugin("kiji_info", kRaw / "kiji_test_info_throws.so", broken_id));
  EXPECT_CONTAINS(r.message, "cannot describe its tool: its tool's info() threw something that is not a std::exception");
}

TEST_F(PluginLoaderTest, APluginThatStopsMakingToolsIsAnErrorWhenATaskNeedsOne) {
  ToolRegistry registry;
  const PluginReport r = registry.load_plugin(add_plugin("kiji_later", kRaw / "kiji_test_create_null_later.so", broken_id).string());
  ASSERT_TRUE(r.loaded) << r.message << " (its first tool, the loader's probe, was made)";
  try {
    registry.create("broken");
    ADD_FAILURE() << "a null tool was handed out";
  } catch (const kiji::Error& e) {
    EXPECT_CONTAINS(e.what(), "tool 'broken' from " + (dir_ / "kiji_later.so").string() + " cannot be created");
    EXPECT_CONTAINS(e.what(), "its create() returned no tool");
  }
}

TEST_F(PluginLoaderTest, AToolThrowingSomethingNotAnExceptionFailsItsStrokeAndLosesNothing) {
  auto registry = std::make_shared<ToolRegistry>();
  const PluginReport r = registry->load_plugin(add_plugin("kiji_begin", kRaw / "kiji_test_begin_throws_int.so", broken_id).string());
  ASSERT_TRUE(r.loaded) << r.message;
  kiji::Session session(registry);
  session.set_simulating(false);
  session.add_garment(kiji::make_rectangle(1.0, 1.0, 5, 5));
  const kiji::Garment before = session.garment(0);
  const std::size_t entries = session.journal().entries().size();  // the garment's, the settings'
  kiji::ToolEvent e;
  e.position = before.position(kiji::Vertex(12));
  e.phase = kiji::Phase::Begin;
  kiji::Stroke stroke{e};
  e.phase = kiji::Phase::End;
  stroke.push_back(e);
  try {
    session.run("broken", session.params_for("broken"), stroke);
    ADD_FAILURE() << "the stroke did not fail";
  } catch (const kiji::Error& error) {
    EXPECT_CONTAINS(error.what(), "tool 'broken'");
    EXPECT_CONTAINS(error.what(), "threw something that is not a std::exception from begin()");
  }
  EXPECT_FALSE(session.stroke_active());
  EXPECT_EQ(session.journal().entries().size(), entries) << "the failed stroke is not in the journal";
  for (kiji::Vertex v : before.mesh().vertices()) EXPECT_EQ(session.garment(0).position(v), before.position(v));
  // The session goes on: the next stroke runs (and fails the same way, cleanly).
  EXPECT_THROW(session.run("broken", session.params_for("broken"), stroke), kiji::Error);
  EXPECT_FALSE(session.stroke_active());
}

TEST_F(PluginLoaderTest, ToolsAreGivenBackToThePluginsOwnDestroy) {
  // The pool plugin makes its tools in memory of its own: freed with the host's delete, the process
  // would abort; only its destroy can take them back.
  const fs::path lib = add_plugin("kiji_pool", kRaw / "kiji_test_pool.so", [](json& j) { j["id"] = "pool"; });
  auto registry = std::make_shared<ToolRegistry>();
  ASSERT_TRUE(registry->load_plugin(lib.string()).loaded);
  void* handle = dlopen(lib.c_str(), RTLD_NOW | RTLD_NOLOAD);
  ASSERT_NE(handle, nullptr);
  auto made = reinterpret_cast<int (*)()>(dlsym(handle, "kiji_test_pool_made"));
  auto destroyed = reinterpret_cast<int (*)()>(dlsym(handle, "kiji_test_pool_destroyed"));
  ASSERT_TRUE(made && destroyed);
  EXPECT_EQ(made(), 1) << "the loader's probe";
  EXPECT_EQ(destroyed(), 1) << "the probe went back to the plugin";
  {
    std::unique_ptr<kiji::Tool> a = registry->create("pool"), b = registry->create("pool");
    EXPECT_EQ(a->info().id, "pool");
    EXPECT_EQ(made(), 3);
    EXPECT_EQ(destroyed(), 1);
  }
  EXPECT_EQ(destroyed(), 3);
  {
    kiji::Session session(registry);
    session.tool("pool");
  }
  EXPECT_EQ(made(), 4);
  EXPECT_EQ(destroyed(), 4) << "a session's tools go back to the plugin too";
  dlclose(handle);
}

TEST_F(PluginLoaderTest, RefusesMetadataThatNamesALibraryElsewhere) {
  for (const std::string& name : std::vector<std::string>{"../kiji_probe.so", kGoodLibrary.string(), "..", ""}) {
    SCOPED_TRACE(name);
    write_text(dir_ / "kiji_elsewhere.json", [&] {
      json meta = good_metadata();
      meta["library"] = name;
      return meta.dump();
    }());
    const PluginReport r = refused(dir_ / "kiji_elsewhere.json");
    EXPECT_CONTAINS(r.message, "not the file name of a library beside it");
  }
  write_text(dir_ / "kiji_elsewhere.json", [&] {
    json meta = good_metadata();
    meta["library"] = 3;
    return meta.dump();
  }());
  EXPECT_CONTAINS(refused(dir_ / "kiji_elsewhere.json").message, "its field 'library' is not a string");
}

TEST_F(PluginLoaderTest, RefusesMetadataThatIsNotARegularFileOrIsHuge) {
  // A FIFO would block the host forever on open; a directory or a huge file is not metadata.
  ASSERT_EQ(mkfifo((dir_ / "kiji_fifo.json").c_str(), 0600), 0);
  EXPECT_CONTAINS(refused(dir_ / "kiji_fifo.json").message, "it is not a regular file");
  fs::create_directory(dir_ / "kiji_dir.json");
  EXPECT_CONTAINS(refused(dir_ / "kiji_dir.json").message, "it is not a regular file");
  write_text(dir_ / "kiji_huge.json", std::string(2 << 20, ' '));
  EXPECT_CONTAINS(refused(dir_ / "kiji_huge.json").message, "2097152 bytes, not metadata (at most 1048576 bytes)");
  // A library that is a FIFO is refused before dlopen would block on it.
  ASSERT_EQ(mkfifo((dir_ / "kiji_fifo_lib.so").c_str(), 0600), 0);
  write_text(dir_ / "kiji_fifo_lib.json", [&] {
    json meta = good_metadata();
    meta["library"] = "kiji_fifo_lib.so";
    return meta.dump();
  }());
  EXPECT_CONTAINS(refused(dir_ / "kiji_fifo_lib.json").message, "kiji_fifo_lib.so is not a regular file");
}

TEST_F(PluginLoaderTest, RefusesAToolWhoseDescriptionWouldNotWorkInAHost) {
  // kiji-plugin-meta refuses these at build time; a library built otherwise meets the same check.
  struct Described : kiji::Tool {
    explicit Described(kiji::ToolInfo info) : info_(std::move(info)) {}
    kiji::ToolInfo info() const override { return info_; }
    kiji::Feedback begin(kiji::ToolContext&, const kiji::ParamSet&, const kiji::ToolEvent&) override { return {}; }
    kiji::Feedback update(kiji::ToolContext&, const kiji::ToolEvent&) override { return {}; }
    void end(kiji::ToolContext&, const kiji::ToolEvent&) override {}
    void cancel(kiji::ToolContext&) override {}
    kiji::ToolInfo info_;
  };
  auto refusal = [](const std::string& id, kiji::ToolInfo info) {
    ToolRegistry registry;
    try {
      registry.add(id, [info] { return std::make_unique<Described>(info); });
    } catch (const kiji::InputError& e) {
      EXPECT_FALSE(registry.has(id));
      return std::string(e.what());
    }
    ADD_FAILURE() << "accepted " << id;
    return std::string();
  };
  using kiji::ParamSpec;
  EXPECT_CONTAINS(refusal("my-tool", {"my-tool", "Mine", "", {}}), "not a verb usable as a Python name");
  EXPECT_CONTAINS(refusal("mine", {"mine", "", "", {}}), "tool 'mine' has no label");
  // Declared field by field, as a plugin built without the builders' checks could.
  auto spec = [](const std::string& name, double value, double min, double max) {
    ParamSpec p;
    p.name = name;
    p.default_value = value;
    p.min = min;
    p.max = max;
    return p;
  };
  EXPECT_CONTAINS(refusal("mine", {"mine", "Mine", "", {spec("bad name", 1, 0, 2)}}),
                  "parameter name 'bad name' is not an identifier");
  EXPECT_CONTAINS(refusal("mine", {"mine", "Mine", "", {spec("a", 1, 0, 2), spec("a", 1, 0, 2)}}),
                  "parameter 'a' is declared twice");
  EXPECT_CONTAINS(refusal("mine", {"mine", "Mine", "", {spec("r", 5, 0, 1)}}), "tool 'mine': the default of");
  ToolRegistry registry;
  EXPECT_THROW(registry.add("none", [] { return std::unique_ptr<kiji::Tool>(); }), kiji::InputError);
}

TEST_F(PluginLoaderTest, AFolderOfBrokenPluginsLoadsTheGoodOneAndReportsTheRest) {
  add_plugin("kiji_a_good", kGoodLibrary);
  add_plugin("kiji_b_no_entry", kRaw / "kiji_test_no_entry.so");
  add_plugin("kiji_c_liar", kRaw / "kiji_test_other_abi.so");
  add_plugin("kiji_d_v3", kRaw / "kiji_test_other_interface.so");
  add_plugin("kiji_e_old", kGoodLibrary, [](json& j) { j["abi"] = "kiji0.0"; });
  write_text(dir_ / "kiji_f_text.so", "not a library");
  write_text(dir_ / "kiji_f_text.json", "not json");
  fs::copy_file(kRaw / "kiji_test_no_entry.so", dir_ / "kiji_g_lonely.so");
  write_text(dir_ / "notes.txt", "ignored: neither .json nor .so");
  add_plugin("kiji_h_null", kRaw / "kiji_test_create_null.so", broken_id);
  add_plugin("kiji_i_int", kRaw / "kiji_test_create_throws_int.so", broken_id);
  add_plugin("kiji_j_own", kRaw / "kiji_test_create_throws_own.so", broken_id);
  add_plugin("kiji_k_info", kRaw / "kiji_test_info_throws.so", broken_id);
  std::size_t expected = 11;
#ifdef KIJI_TEST_AVX
  add_plugin("kiji_l_avx", kRaw / "kiji_test_avx.so", [](json& j) { j["id"] = "probe_avx"; });
  ++expected;
#endif

  ToolRegistry registry;
  const auto reports = registry.load_plugins({dir_.string()});
  ASSERT_EQ(reports.size(), expected);
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
