// kiji-plugin-meta, the program kiji_add_tool() runs after each link: it writes a good plugin's
// metadata exactly as the loader expects it, and refuses (exit 1, no file) what the host would refuse.
#include "kiji/plugin_loader.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace {

namespace fs = std::filesystem;

const fs::path kGood = fs::path(KIJI_TEST_PLUGIN_DIR) / "good";
const fs::path kRaw = fs::path(KIJI_TEST_PLUGIN_DIR) / "raw";

#define EXPECT_CONTAINS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << "expected \"" << (part) << "\" in: " << (text)

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct Result {
  int status = -1;
  std::string output;  // stdout and stderr
};

Result plugin_meta(const std::string& args) {
  Result r;
  const std::string command = std::string("'") + KIJI_PLUGIN_META + "' " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return r;
  char buffer[4096];
  std::size_t n;
  while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) r.output.append(buffer, n);
  const int raw = pclose(pipe);
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return r;
}

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

class PluginMetaTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(KIJI_TEST_TMP) / "plugin_meta" / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    out_ = dir_ / "out.json";
  }
  // Runs it on `library` and expects a refusal that leaves no metadata behind, even a stale one.
  std::string refusal(const fs::path& library, const std::string& extra = "") {
    std::ofstream(out_) << "stale";
    const Result r = plugin_meta(extra + quoted(library) + " " + quoted(out_));
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_CONTAINS(r.output, "kiji-plugin-meta: " + library.string() + ": ");
    EXPECT_FALSE(fs::exists(out_)) << "a refused plugin must not keep a metadata file";
    return r.output;
  }
  fs::path dir_, out_;
};

TEST_F(PluginMetaTest, WritesTheMetadataTheBuildPutBesideTheGoodPlugin) {
  const Result r = plugin_meta("--id probe " + quoted(kGood / "kiji_probe.so") + " " + quoted(out_));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(read_text(out_), read_text(kGood / "kiji_probe.json"));
  EXPECT_FALSE(fs::exists(dir_ / "out.json.partial"));

  kiji::ToolRegistry registry;
  EXPECT_TRUE(registry.load_plugin((kGood / "kiji_probe.json").string()).loaded);
  EXPECT_EQ(read_text(out_), kiji::tool_metadata_json(registry.info("probe"), "kiji_probe.so"));
}

TEST_F(PluginMetaTest, RefusesAToolWhoseIdIsNotTheOneItIsBuiltAs) {
  const std::string out = refusal(kGood / "kiji_probe.so", "--id poke ");
  EXPECT_CONTAINS(out, "its tool says its id is 'probe' but it is built as 'poke'");
}

TEST_F(PluginMetaTest, RefusesABinaryOfAnotherAbi) {
  const std::string out = refusal(kRaw / "kiji_test_other_abi.so");
  EXPECT_CONTAINS(out, "built for ABI kiji=0.1;compiler=gcc1;stdlib=libstdc++0;cgal=0.0;eigen=0.0.0;scalar=float");
  EXPECT_CONTAINS(out, kiji::abi_tag());
  EXPECT_CONTAINS(out, "compiler differs (plugin gcc1");
}

TEST_F(PluginMetaTest, RefusesAToolBuiltWithAvx) {
#if !defined(KIJI_TEST_AVX) || EIGEN_MAX_STATIC_ALIGN_BYTES >= 32
  GTEST_SKIP() << "cannot run in this build: -mavx exists only on x86-64, and where Kiji itself is built with "
                  "AVX a plugin built with -mavx lays events out as the host does (nothing to refuse)";
#else
  // kiji_add_tool() runs this after the link: the build of such a tool fails, saying why.
  const std::string out = refusal(kRaw / "kiji_test_avx.so");
  EXPECT_CONTAINS(out, "eigen_align differs (plugin 32/32, this Kiji 16/16)");
  EXPECT_CONTAINS(out, "-mavx");
#endif
}

TEST_F(PluginMetaTest, RefusesAToolThatCannotBeMadeOrDescribed) {
  EXPECT_CONTAINS(refusal(kRaw / "kiji_test_create_null.so"), "its create() returned no tool (a null pointer)");
  EXPECT_CONTAINS(refusal(kRaw / "kiji_test_create_throws_int.so"), "threw something that is not a std::exception");
  EXPECT_CONTAINS(refusal(kRaw / "kiji_test_create_throws_own.so"), "the plugin's own exception, thrown by create()");
  EXPECT_CONTAINS(refusal(kRaw / "kiji_test_info_throws.so"), "threw something that is not a std::exception");
}

TEST_F(PluginMetaTest, RefusesABinaryOfAnotherInterface) {
  const std::string out = refusal(kRaw / "kiji_test_other_interface.so");
  EXPECT_CONTAINS(out, "built for interface org.kiji.Tool/3, but this Kiji loads " KIJI_TOOL_INTERFACE);
  EXPECT_CONTAINS(out, "rebuild it against this version of Kiji");
}

// A tool of the first interface, built again against this Kiji without changing its code: the build
// stops here, saying what its code must change.
TEST_F(PluginMetaTest, RefusesABinaryOfTheFirstInterfaceSayingWhatChanged) {
  const std::string out = refusal(kRaw / "kiji_test_interface_1.so");
  EXPECT_CONTAINS(out, "built for interface org.kiji.Tool/1, but this Kiji loads org.kiji.Tool/2");
  EXPECT_CONTAINS(out, "take a kiji::ToolContext& in place of kiji::Session&");
}

TEST_F(PluginMetaTest, RefusesALibraryWithoutTheEntryPoint) {
  EXPECT_CONTAINS(refusal(kRaw / "kiji_test_no_entry.so"), "no entry point " KIJI_TOOL_PLUGIN_SYMBOL);
}

TEST_F(PluginMetaTest, RefusesAFileThatIsNotALibrary) {
  const fs::path text = dir_ / "kiji_text.so";
  std::ofstream(text) << "not a library";
  EXPECT_CONTAINS(refusal(text), "not a loadable library");
}

TEST_F(PluginMetaTest, ExplainsItsUsage) {
  const Result r = plugin_meta("");
  EXPECT_EQ(r.status, 2);
  EXPECT_CONTAINS(r.output, "usage: kiji-plugin-meta [--id ID] <library> <output.json>");
}

}  // namespace
