// Session files and autosave: a session saved and loaded is the same session; a process killed with
// kill -9 at any moment loses no operation whose call had returned, and its file always recovers.
#include "support/design_calls.h"
#include "kiji/error.h"
#include "kiji/journal_file.h"
#include "kiji/pattern.h"
#include "kiji/session.h"
#include "kiji/session_file.h"
#include "session/lcm_log.h"

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

using namespace kiji;

namespace {

using test::design_call;
using test::plugins;

std::string tmp(const std::string& name) { return std::string(KIJI_TEST_TMP) + "/" + name; }

std::string garments(const Session& s) {
  std::string out;
  for (std::size_t i = 0; i < s.garment_count(); ++i) out += encode_garment(s.garment(i));
  return out;
}

}  // namespace

TEST(SessionFile, AutosaveThenRecoverGivesTheSameSession) {
  const std::string path = tmp("autosave_same.kiji");
  std::filesystem::remove(path);
  Session a(plugins());
  {
    Autosave save(a, path);
    a.add_garment(make_rectangle(0.6, 0.4, 7, 5));
    for (int k = 0; k < 20; ++k) design_call(a, k);
    EXPECT_EQ(save.written(), a.journal().operations().size());
  }
  Recovered r = recover(path, plugins(), /*keep_saving=*/false);
  EXPECT_EQ(r.report.operations, a.journal().operations().size());
  EXPECT_TRUE(r.report.damage.empty()) << r.report.damage;
  EXPECT_EQ(garments(*r.session), garments(a));
  EXPECT_EQ(r.session->steps(), a.steps());
  // An autosave never overwrites a session file that holds a session.
  Session b(plugins());
  EXPECT_THROW(Autosave(b, path), InputError);
}

TEST(SessionFile, ACutOffOrDamagedEndIsLeftOutAndCutOffBeforeSavingGoesOn) {
  const std::string path = tmp("autosave_cut.kiji");
  std::filesystem::remove(path);
  Session a(plugins());
  {
    Autosave save(a, path);
    a.add_garment(make_rectangle(0.6, 0.4, 7, 5));
    for (int k = 0; k < 10; ++k) design_call(a, k);
  }
  const auto full = std::filesystem::file_size(path);
  const std::size_t ops = a.journal().operations().size();
  // Cut the file inside its last record.
  std::filesystem::resize_file(path, full - 7);
  Recovered r = recover(path, plugins());
  EXPECT_EQ(r.report.operations, ops - 1);
  EXPECT_NE(r.report.damage.find("cut off"), std::string::npos) << r.report.damage;
  // Saving goes on after the last whole record, and the file reads back whole.
  r.session->set_simulating(false);
  r.autosave.reset();
  SessionFileReport again;
  const auto back = load_session(path, &again);
  EXPECT_TRUE(again.damage.empty()) << again.damage;
  EXPECT_EQ(back.size(), r.session->journal().operations().size());
  // A flipped byte inside a record is found by its hash.
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(std::filesystem::file_size(path) / 2));
    char c;
    f.read(&c, 1);
    f.seekp(-1, std::ios::cur);
    c ^= 0x5a;
    f.write(&c, 1);
  }
  SessionFileReport damaged;
  const auto part = load_session(path, &damaged);
  EXPECT_LT(part.size(), back.size());
  EXPECT_FALSE(damaged.damage.empty());
  // Not a session file at all.
  std::ofstream(tmp("not_a_session.kiji")) << "hello, this is text";
  EXPECT_THROW(load_session(tmp("not_a_session.kiji")), InputError);
  EXPECT_THROW(load_session(tmp("no_such_file.kiji")), InputError);
}

// A process killed while it wrote its first operation (the garment, the longest record) leaves a
// file that ends inside that record: still its session file, holding no operation yet.
TEST(SessionFile, AFileCutOffInsideItsFirstRecordRecoversAnEmptySessionAndSavingGoesOn) {
  const std::string whole = tmp("first_cut_whole.kiji");
  std::filesystem::remove(whole);
  {
    Session a(plugins());
    Autosave save(a, whole);
    a.add_garment(make_rectangle(0.6, 0.4, 13, 9));
  }
  const auto size = std::filesystem::file_size(whole);
  for (std::uintmax_t keep : {std::uintmax_t(1), std::uintmax_t(4), std::uintmax_t(27), std::uintmax_t(30),
                              size / 2, size - 1}) {
    const std::string path = tmp("first_cut.kiji");
    std::filesystem::copy_file(whole, path, std::filesystem::copy_options::overwrite_existing);
    std::filesystem::resize_file(path, keep);
    Recovered r = recover(path, plugins());
    EXPECT_EQ(r.report.operations, 0u) << keep << " bytes";
    EXPECT_NE(r.report.damage.find("cut off"), std::string::npos) << keep << " bytes: " << r.report.damage;
    EXPECT_EQ(r.session->garment_count(), 0u);
    // The cut-off record is dropped and the session saves into the file again.
    r.session->add_garment(make_rectangle(0.3, 0.3, 4, 4));
    r.autosave.reset();
    SessionFileReport again;
    EXPECT_EQ(load_session(path, &again).size(), 1u) << keep << " bytes";
    EXPECT_TRUE(again.damage.empty()) << again.damage;
  }
  // A short file of something else is still not a session file.
  std::ofstream(tmp("short_text.kiji")) << "hi";
  EXPECT_THROW(load_session(tmp("short_text.kiji")), InputError);
}

// The user's promise: kill -9 at any moment loses nothing whose call had returned. A child process
// (tests/support/autosave_child.cpp) designs with autosave on and prints, after each call returns,
// how many operations the session has; the test kills it at a random moment and recovers the file.
TEST(SessionFile, KillNineAtRandomMomentsLosesNoOperationWhoseCallHadReturned) {
  std::mt19937 rng(2026);
  const int trials = 12;
  std::size_t recovered_total = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const std::string path = tmp("kill9_" + std::to_string(getpid()) + "_" + std::to_string(trial) + ".kiji");
    std::filesystem::remove(path);
    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      execl(KIJI_AUTOSAVE_CHILD, KIJI_AUTOSAVE_CHILD, path.c_str(), KIJI_PLUGIN_DIR, static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    // The random moment is counted from the child's first line (its session file made): a sanitizer
    // build can take longer than the shortest wait to start and load its plugins.
    std::string out;
    char buf[4096];
    for (ssize_t n; out.find('\n') == std::string::npos && (n = read(fds[0], buf, sizeof buf)) > 0;)
      out.append(buf, static_cast<std::size_t>(n));
    std::this_thread::sleep_for(std::chrono::milliseconds(rng() % 600));
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the child ended by itself (status " << status << ")";
    for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;) out.append(buf, static_cast<std::size_t>(n));
    close(fds[0]);
    std::size_t returned = 0;
    for (std::size_t at = 0, next; (next = out.find('\n', at)) != std::string::npos; at = next + 1)
      returned = std::stoul(out.substr(at, next - at));
    Recovered r = recover(path, plugins(), /*keep_saving=*/false);
    EXPECT_GE(r.report.operations, returned) << "trial " << trial << ": an operation whose call returned was lost ("
                                             << r.report.damage << ")";
    EXPECT_FALSE(r.session->stroke_active()) << "an unfinished stroke is cancelled";
    recovered_total += r.report.operations;
  }
  EXPECT_GT(recovered_total, std::size_t(trials)) << "the children got some work done before they were killed";
}

TEST(SessionFile, KijiRecoverOnTheCommandLineSaysWhatItFoundAndWritesTheGarment) {
  const std::string path = tmp("cli_recover.kiji");
  std::filesystem::remove(path);
  {
    Session a(plugins());
    Autosave save(a, path);
    a.add_garment(make_rectangle(0.6, 0.4, 7, 5));
    for (int k = 0; k < 6; ++k) design_call(a, k);
  }
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 3);
  const std::string glb = tmp("cli_recovered.glb");
  std::filesystem::remove(glb);
  const std::string cmd = std::string(KIJI_CLI) + " recover " + path + " --export " + glb + " --json 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  for (std::size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  EXPECT_EQ(pclose(p), 0) << out;
  EXPECT_NE(out.find("\"garments\":1"), std::string::npos) << out;
  EXPECT_NE(out.find("cut off"), std::string::npos) << out;
  EXPECT_TRUE(std::filesystem::is_regular_file(glb));
  const std::string missing = std::string(KIJI_CLI) + " recover " + tmp("no_such.kiji") + " >/dev/null 2>&1";
  EXPECT_EQ(WEXITSTATUS(std::system(missing.c_str())), 1) << "a missing file is an error, not a crash";
}

// A session file an earlier build saved (tests/fixtures/saved/session.kiji: a design session with
// every kind of operation): each record's operation, and the garments, bodies and states they
// carry, read back and encode again to the same bytes, and the session opens.
TEST(SessionFile, ASessionFileSavedByAnEarlierBuildReadsBackToTheSameBytesAndOpens) {
  const std::string path = std::string(KIJI_TEST_SAVED) + "/session.kiji";
  detail::LcmLog log(path, "r");
  ASSERT_TRUE(log.good());
  std::string channel, data, why;
  std::vector<Operation> ops;
  std::set<std::string> kinds;
  std::size_t garments = 0, bodies = 0, states = 0;
  while (log.next(channel, data, why) == detail::LcmLog::Read::Event) {
    ASSERT_EQ(channel, kSessionChannel);
    Operation op;
    ASSERT_TRUE(decode_session_record(data, op, why)) << why;
    // The operation follows the record's fingerprint, protocol, step, user, hash and size.
    EXPECT_EQ(data.substr(8 + 2 + 8 + 4 + 8 + 4), encode_operation(op)) << "operation " << ops.size();
    kinds.insert(operation_kind(op.data));
    const auto same_garment = [&](const std::shared_ptr<const std::string>& bytes) {
      ASSERT_TRUE(bytes);
      EXPECT_EQ(encode_garment(decode_garment(*bytes)), *bytes) << "operation " << ops.size();
      ++garments;
    };
    if (const auto* a = std::get_if<op::AddGarment>(&op.data)) same_garment(a->garment);
    if (const auto* s = std::get_if<op::SetGarment>(&op.data)) same_garment(s->garment);
    if (const auto* b = std::get_if<op::SetBody>(&op.data); b && b->body) {
      EXPECT_EQ(encode_body(decode_body(*b->body)), *b->body);
      ++bodies;
    }
    if (const auto* c = std::get_if<op::Checkpoint>(&op.data); c && c->state) {
      Session opened(plugins());
      opened.perform({0, 0, *c});
      EXPECT_EQ(opened.encode_state(), *c->state) << "a state opens as itself";
      ++states;
    }
    ops.push_back(std::move(op));
  }
  EXPECT_TRUE(why.empty()) << why;
  ASSERT_EQ(ops.size(), 28u);
  EXPECT_EQ(kinds.size(), std::variant_size_v<OperationData>) << "every kind of operation is in the file";
  EXPECT_EQ(garments, 4u);
  EXPECT_EQ(bodies, 1u);
  EXPECT_EQ(states, 1u);

  SessionFileReport report;
  EXPECT_EQ(load_session(path, &report).size(), ops.size());
  EXPECT_EQ(report.good_bytes, report.file_bytes);
  Recovered r = recover(path, plugins(), /*keep_saving=*/false);
  EXPECT_TRUE(r.report.damage.empty()) << r.report.damage;
  EXPECT_EQ(r.session->steps(), ops.back().step);
  EXPECT_EQ(r.session->garment_count(), 1u);
  EXPECT_EQ(r.session->garment(0).name, "edited");
  EXPECT_EQ(r.session->body(), nullptr);
  EXPECT_EQ(r.cancelled_strokes, 0u);
}

TEST(SessionFile, ASavedSessionOpensFromTheStateItCarriesWithoutReplayingItsSteps) {
  const std::string path = tmp("with_state.kiji");
  Session a(plugins());
  a.add_garment(make_rectangle(0.6, 0.4, 7, 5));
  for (int k = 0; k < 12; ++k) design_call(a, k);
  for (int i = 0; i < 30; ++i) a.step();
  save_session(a, path);
  SavedState state;
  const std::vector<Operation> ops = load_session(path, nullptr, &state);
  ASSERT_TRUE(state.found);
  EXPECT_EQ(ops.size(), operations_to_save(a).size());
  EXPECT_EQ(state.after, ops.size());
  // Opened from the state: the same garments, clock and settings, with one operation applied.
  Session b(plugins());
  EXPECT_EQ(open_operations(b, ops, state), 1u);
  EXPECT_EQ(b.encode_state(), a.encode_state());
  EXPECT_EQ(b.journal().operations().size(), 1u);
  // Saved again with the history it was opened from: the file holds all of it and opens the same.
  b.step();
  design_call(b, 3);
  save_session(b, tmp("saved_again.kiji"), std::vector<Operation>(ops.begin(), ops.begin() + std::ptrdiff_t(state.after)));
  SavedState again_state;
  const std::vector<Operation> again = load_session(tmp("saved_again.kiji"), nullptr, &again_state);
  EXPECT_GT(again.size(), ops.size());
  Session d(plugins());
  open_operations(d, again, again_state);
  EXPECT_EQ(d.encode_state(), b.encode_state());
}

TEST(SessionFile, TheOperationsOfAFileWithAStateReplayAsBeforeAndAFileWithoutOneOpensByReplay) {
  // A reader of the operations alone (an earlier Kiji, lcm-logplayer to a peer) gets what it got.
  const std::string path = tmp("state_and_operations.kiji");
  Session a(plugins());
  a.add_garment(make_rectangle(0.6, 0.4, 7, 5));
  for (int k = 0; k < 8; ++k) design_call(a, k);
  save_session(a, path);
  const std::vector<Operation> ops = load_session(path);
  for (const Operation& op : ops) EXPECT_STRNE(operation_kind(op.data), "checkpoint");
  Session b(plugins());
  replay(b, ops);
  EXPECT_EQ(b.encode_state(), a.encode_state());
  // A file as earlier builds wrote it (the operations alone: as an autosave writes them).
  const std::string old = tmp("without_state.kiji");
  std::filesystem::remove(old);
  Session c(plugins());
  {
    Autosave save(c, old);
    c.add_garment(make_rectangle(0.6, 0.4, 7, 5));
    for (int k = 0; k < 8; ++k) design_call(c, k);
  }
  SavedState state;
  const std::vector<Operation> old_ops = load_session(old, nullptr, &state);
  EXPECT_FALSE(state.found);
  Session d(plugins());
  EXPECT_EQ(open_operations(d, old_ops, state), old_ops.size());
  EXPECT_EQ(garments(d), garments(c));
}

TEST(SessionFile, RecoveryStartsFromTheStateAnAutosaveWrote) {
  const std::string path = tmp("autosave_state.kiji");
  std::filesystem::remove(path);
  Session a(plugins());
  a.add_garment(make_rectangle(0.6, 0.4, 7, 5));
  for (int k = 0; k < 6; ++k) design_call(a, k);
  {
    Autosave save(a, path);
    save.write_state();
    for (int k = 6; k < 10; ++k) design_call(a, k);
  }
  Recovered r = recover(path, plugins(), /*keep_saving=*/false);
  EXPECT_EQ(garments(*r.session), garments(a));
  EXPECT_EQ(r.session->steps(), a.steps());
}
