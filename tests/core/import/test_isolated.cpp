// Reading mesh files in a child process: a file that crashes assimp, or needs more memory or time
// than the limits allow, is refused with a clear error and the calling process goes on.
#include "import/isolated.h"
#include "kiji/body.h"
#include "kiji/error.h"
#include "kiji/io.h"
#include "kiji/operation.h"
#include "kiji/pattern.h"
#include "support/test_errors.h"

#include <dirent.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <vector>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace kiji {
namespace {

std::string tmp_path(const std::string& name) {
  std::filesystem::create_directories(KIJI_TEST_TMP);
  return std::string(KIJI_TEST_TMP) + "/isolation_" + name;
}

// Written beside and renamed into place: ctest runs this file's tests in parallel processes, and two
// that share a file (the grid) must never read it half written by the other.
std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = tmp_path(name);
  const std::string part = path + ".part" + std::to_string(::getpid());
  std::ofstream(part, std::ios::binary) << text;
  std::filesystem::rename(part, path);
  return path;
}

// An FBX text file whose objects nest 200,000 deep: assimp 5.2's FBX parser recurses once a level
// and runs off the end of its stack.
std::string deep_fbx() {
  std::string s = "; FBX 7.4.0 project file\nFBXHeaderExtension:  {\n\tFBXHeaderVersion: 1003\n\tFBXVersion: 7400\n}\n"
                  "Objects:  {\n";
  constexpr int kDepth = 200000;
  for (int i = 0; i < kDepth; ++i) s += "A: {\n";
  for (int i = 0; i < kDepth; ++i) s += "}\n";
  s += "}\n";
  return write_file("deep.fbx", s);
}

// A flat grid of n x n vertices as OBJ (two triangles a cell): a large, valid body file.
std::string grid_obj(int n) {
  std::ostringstream s;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) s << "v " << i * 0.001 << " " << j * 0.001 << " " << 0.0001 * ((i * j) % 7) << "\n";
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i + 1, b = a + 1, c = a + n, d = c + 1;
      s << "f " << a << " " << b << " " << d << "\nf " << a << " " << d << " " << c << "\n";
    }
  return write_file("grid" + std::to_string(n) + ".obj", s.str());
}

BodyImportOptions in_process() {
  BodyImportOptions o;
  o.limits.isolate = false;
  return o;
}

TEST(ImportIsolation, AFileThatCrashesAssimpInProcessIsRefusedAndThisProcessGoesOn) {
  const std::string path = deep_fbx();
  // The file really does crash the reader when it runs in this process...
  const std::string style = GTEST_FLAG_GET(death_test_style);
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH((void)Body::load(path, in_process()), "");
  GTEST_FLAG_SET(death_test_style, style);
  // ...and isolated, the same file is an error that says what happened and what to do.
  const std::string msg = test::input_error([&] { (void)Body::load(path); });
  EXPECT_NE(msg.find("cannot load body '" + path + "'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("assimp crashed while reading it"), std::string::npos) << msg;
  EXPECT_NE(msg.find("this session is unharmed"), std::string::npos) << msg;
  EXPECT_NE(msg.find("export it again"), std::string::npos) << msg;
  // This process reads the next file as if nothing had happened.
  const Body human = Body::load(Body::default_path());
  EXPECT_GT(human.triangles().size(), 1000u);
}

TEST(ImportIsolation, TheBodyReadInAChildProcessIsTheBodyReadHere) {
  BodyImportOptions here = in_process();
  BodyImportOptions isolated;
  for (BodyImportOptions* o : {&here, &isolated}) {
    o->find_front = true;
    o->smooth = true;
    o->height = 1.7;
  }
  const Body a = Body::load(Body::default_path(), here);
  const Body b = Body::load(Body::default_path(), isolated);
  // Bit for bit, report included: the child's answer loses nothing.
  EXPECT_EQ(encode_body(a), encode_body(b));
  EXPECT_EQ(a.name(), b.name());
  EXPECT_EQ(a.report().front_source, b.report().front_source);
  EXPECT_EQ(a.report().front, b.report().front);
  EXPECT_EQ(a.report().smoothing, b.report().smoothing);
  EXPECT_EQ(a.report().vertices_before_weld, b.report().vertices_before_weld);
}

TEST(ImportIsolation, TheGarmentReadInAChildProcessIsTheGarmentReadHere) {
  Garment g = make_rectangle(1.0, 0.5, 9, 5);
  g.texture() = Texture::filled(8, 4, 200, 30, 40);
  g.color = Vec3(0.25, 0.5, 0.75);
  const std::string path = tmp_path("garment.glb");
  export_garment(g, path);
  ImportLimits here;
  here.isolate = false;
  const Garment a = import_garment(path, {}, here);
  const Garment b = import_garment(path);
  EXPECT_EQ(encode_garment(a), encode_garment(b));
  EXPECT_EQ(b.texture().width, 8);
  EXPECT_EQ(b.mesh().number_of_vertices(), 45u);
}

TEST(ImportIsolation, TheReadersOwnRefusalsKeepTheirMessages) {
  const std::string path = write_file("nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
  const std::string here = test::input_error([&] { (void)Body::load(path, in_process()); });
  const std::string isolated = test::input_error([&] { (void)Body::load(path); });
  EXPECT_FALSE(here.empty());
  EXPECT_EQ(here, isolated);
  const std::string garment_here = test::input_error([&] {
    ImportLimits l;
    l.isolate = false;
    (void)import_garment(path, {}, l);
  });
  EXPECT_EQ(garment_here, test::input_error([&] { (void)import_garment(path); }));
}

TEST(ImportIsolation, AReaderThatTakesMoreMemoryThanTheLimitIsStopped) {
  const std::string path = grid_obj(400);  // 160,000 vertices, 318,402 triangles
  BodyImportOptions tight;
  tight.limits.memory_mb = 8;
  const std::string msg = test::input_error([&] { (void)Body::load(path, tight); });
  EXPECT_NE(msg.find("more than 8 MiB of memory"), std::string::npos) << msg;
  EXPECT_NE(msg.find("raise the limit"), std::string::npos) << msg;
  // Within the default limit the same file is a body.
  const Body b = Body::load(path);
  EXPECT_EQ(b.vertices().size(), 160000u);
  EXPECT_EQ(b.triangles().size(), 2u * 399 * 399);
}

TEST(ImportIsolation, AReaderThatTakesLongerThanTheLimitIsStopped) {
  const std::string path = grid_obj(400);
  BodyImportOptions quick;
  quick.limits.seconds = 0.001;  // far less than parsing 9 MB takes
  const std::string msg = test::input_error([&] { (void)Body::load(path, quick); });
  EXPECT_NE(msg.find("took longer than 0.001 s"), std::string::npos) << msg;
  ImportLimits garment_quick;
  garment_quick.seconds = 0.001;
  const std::string garment = write_file("grid_garment.obj", [&] {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }());
  const std::string msg2 = test::input_error([&] { (void)import_garment(garment, {}, garment_quick); });
  EXPECT_NE(msg2.find("cannot import garment"), std::string::npos) << msg2;
  EXPECT_NE(msg2.find("took longer than"), std::string::npos) << msg2;
}

TEST(ImportIsolation, AMaterialColourThatIsNotANumberLeavesTheGarmentsOwn) {
  write_file("nan.mtl", "newmtl cloth\nKd nan 0.5 0.5\n");
  const std::string path =
      write_file("nan_colour.obj", "mtllib isolation_nan.mtl\nusemtl cloth\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const Garment g = import_garment(path);
  EXPECT_TRUE(g.color.allFinite());
  EXPECT_EQ(g.mesh().number_of_faces(), 1u);
}

// The mechanism itself, with work that stands for a reader gone wrong.

// The child's open descriptors, less the one listing them.
std::string open_descriptors() {
  std::string out;
  DIR* d = opendir("/proc/self/fd");
  if (!d) return "unreadable";
  const int own = dirfd(d);
  while (dirent* e = readdir(d)) {
    if (e->d_name[0] == '.' || std::atoi(e->d_name) == own) continue;
    out += std::string(e->d_name) + " ";
  }
  closedir(d);
  return out;
}

char* volatile kept = nullptr;

int live_children() {
  int n = 0;
  while (waitpid(-1, nullptr, WNOHANG) > 0) ++n;  // a child left unreaped would show here
  return n;
}

TEST(ImportIsolation, AReaderThatNeverEndsIsKilledAtTheLimitAndReaped) {
  ImportLimits limits;
  limits.seconds = 0.3;
  const auto start = std::chrono::steady_clock::now();
  const std::string msg = test::input_error([&] {
    (void)detail::run_isolated([] {
      for (;;) pause();
      return std::string();
    }, limits, "cannot load body 'x'");
  });
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_NE(msg.find("took longer than 0.3 s"), std::string::npos) << msg;
  EXPECT_GE(elapsed, 0.3);
  EXPECT_LT(elapsed, 10.0) << "stopped at its limit, not later";
  EXPECT_EQ(live_children(), 0);
  errno = 0;
  EXPECT_EQ(waitpid(-1, nullptr, WNOHANG), -1);
  EXPECT_EQ(errno, ECHILD) << "no child is left behind";
}

TEST(ImportIsolation, TheReaderHoldsNoDescriptorOfThisProcess) {
  // Another import's pipe (or a peer's socket) held open by a child would keep its owner waiting.
  int spare[2];
  ASSERT_EQ(pipe(spare), 0);
  const std::string open = detail::run_isolated(open_descriptors, {}, "x");
  close(spare[0]);
  close(spare[1]);
  EXPECT_EQ(open, "0 1 2 3 ");
}

TEST(ImportIsolation, EachWayAReaderCanEndIsSaidAsItIs) {
  const ImportLimits limits;
  auto run = [&](std::string (*work)()) {
    return test::input_error([&] { (void)detail::run_isolated(work, limits, "cannot load body 'b.fbx'"); });
  };
  const std::string aborted = run([]() -> std::string { std::abort(); });
  EXPECT_NE(aborted.find("cannot load body 'b.fbx': assimp crashed while reading it"), std::string::npos) << aborted;
  const std::string stopped = run([]() -> std::string {
    raise(SIGTERM);
    return "";
  });
  EXPECT_NE(stopped.find("stopped from outside (signal 15"), std::string::npos) << stopped;
  const std::string failed = run([]() -> std::string { throw std::runtime_error("a reader's own words"); });
  EXPECT_NE(failed.find("reading it failed (a reader's own words)"), std::string::npos) << failed;
  const std::string refused = run([]() -> std::string { throw InputError("cannot load body 'b.fbx': no triangles"); });
  EXPECT_EQ(refused, "cannot load body 'b.fbx': no triangles");
  EXPECT_EQ(detail::run_isolated([] { return std::string("a\0b", 3); }, limits, "x"), std::string("a\0b", 3));
}

TEST(ImportIsolation, AnAllocationThatFailedIsTheMemoryLimitEvenWhenTheReaderCarriedOn) {
  // assimp catches std::bad_alloc in places and goes on without the object: a result that lost part
  // of the file to the limit is not a result.
  ImportLimits limits;
  limits.memory_mb = 64;
  const std::string msg = test::input_error([&] {
    (void)detail::run_isolated([] {
      constexpr std::size_t kBytes = std::size_t{512} << 20;
      try {
        kept = new char[kBytes];  // kept: an allocation not used can be left out by the compiler
        std::memset(kept, 1, kBytes);
      } catch (const std::bad_alloc&) {
      }
      return std::string("a body without the part that did not fit");
    }, limits, "cannot load body 'big.obj'");
  });
  EXPECT_NE(msg.find("needed more than 64 MiB of memory"), std::string::npos) << msg;
}

TEST(ImportIsolation, LimitsOutOfRangeAreRefused) {
  // Huge limits mean no practical limit, not an overflow.
  ImportLimits huge;
  huge.seconds = 1e300;
  huge.memory_mb = ~std::size_t{0};
  EXPECT_EQ(detail::run_isolated([] { return std::string("read"); }, huge, "x"), "read");
  for (double seconds : {0.0, -1.0, std::nan("")}) {
    BodyImportOptions o;
    o.limits.seconds = seconds;
    const std::string msg = test::input_error([&] { (void)Body::load(Body::default_path(), o); });
    EXPECT_NE(msg.find("time limit"), std::string::npos) << msg;
  }
  BodyImportOptions o;
  o.limits.memory_mb = 0;
  const std::string msg = test::input_error([&] { (void)Body::load(Body::default_path(), o); });
  EXPECT_NE(msg.find("memory limit"), std::string::npos) << msg;
}

}  // namespace
}  // namespace kiji
