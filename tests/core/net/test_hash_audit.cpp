// The hash audit (net/hash_audit.h) on the simulated network: peers that step alike report the same
// hashes and know they agree; a peer whose state differs from the sequencer's finds it, records it
// and asks to be healed, at most once a second; a silent peer is not waited for; at the shared stop
// the hash is reported again and again.
#include "kiji/pattern.h"
#include "kiji/session.h"
#include "net/hash_audit.h"
#include "support/peer_sim.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace kiji;
using namespace kiji::detail;
using test::SimNetwork;
using test::SimParts;

namespace {

// Three peers, each a session with the same cloth, stepping together every 10 ms and recording
// their hash every fifth step; peer 0 (id 100) is the sequencer.
struct Audits {
  SimParts parts;
  std::vector<std::unique_ptr<Session>> sessions;
  std::vector<Members> members;
  std::vector<std::unique_ptr<HashAudit>> audit;
  std::vector<std::size_t> heals_heard;
  bool stepping = true;

  explicit Audits(SimNetwork::Faults faults = {}) : parts(5, faults, 3, options()), members(3), heals_heard(3, 0) {
    for (int i = 0; i < 3; ++i) {
      sessions.push_back(std::make_unique<Session>());
      sessions.back()->add_garment(make_rectangle(0.3, 0.3, 5, 5));
      audit.push_back(std::make_unique<HashAudit>(parts.core(i), *sessions.back(), members[i]));
      parts[i].receive = [this, i](const PeerEnvelope& env) {
        members[i].all[env.sender].heard = parts.now();
        if (env.type == kHash) audit[i]->on_report(env.sender, decode_hash(env.body), true, 100);
        if (env.type == kHeal) ++heals_heard[i];
      };
      parts[i].tick = [this, i] {
        if (!stepping || std::fmod(parts.now() + 1e-9, 0.01) > 0.0005) return;
        sessions[i]->step();
        if (sessions[i]->steps() % 5 == 0) audit[i]->record(true, 100);
      };
    }
  }
  static PeerOptions options() {
    PeerOptions o;
    o.silence_seconds = 0.3;
    return o;
  }
};

}  // namespace

TEST(HashAudit, PeersThatStepAlikeAgreeAndKnowIt) {
  Audits a;
  a.parts.run_until(0.3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(a.audit[i]->converged()) << "peer " << i;
    EXPECT_TRUE(a.audit[i]->agree_at(25)) << "peer " << i;
    EXPECT_TRUE(a.audit[i]->divergences().empty()) << "peer " << i;
    for (std::uint32_t other : {100u, 101u, 102u})
      if (other != 100u + i) EXPECT_EQ(a.audit[i]->agrees_with(other), true) << i << " with " << other;
  }
  EXPECT_FALSE(a.audit[0]->agrees_with(555).has_value()) << "a peer never heard";
  EXPECT_FALSE(a.audit[0]->agree_at(26)) << "no hash at a step between reports";
}

TEST(HashAudit, AStateThatDiffersFromTheSequencersIsFoundAndHealingIsAskedOnceASecond) {
  Audits a;
  a.parts.run_until(0.1);
  ASSERT_TRUE(a.audit[2]->converged());
  Garment& wrong = a.sessions[2]->garment(0);
  const Vertex v = *wrong.mesh().vertices().begin();
  wrong.set_position(v, wrong.position(v) + Vec3(0, 0, 0.01));
  a.parts.run_until(0.9);
  ASSERT_FALSE(a.audit[2]->divergences().empty());
  const PeerDivergence& d = a.audit[2]->divergences().front();
  EXPECT_GT(d.step, 10u);
  EXPECT_NE(d.own, d.reference);
  EXPECT_EQ(d.reference_peer, 100u);
  EXPECT_EQ(a.parts.core(2).stats.heals, 1u) << "one request within the first second";
  EXPECT_EQ(a.heals_heard[0], 1u) << "the sequencer heard it";
  EXPECT_FALSE(a.audit[2]->converged());
  EXPECT_FALSE(a.audit[0]->converged()) << "the sequencer sees it disagree too";
  EXPECT_EQ(a.audit[0]->agrees_with(102), false);
  EXPECT_TRUE(a.audit[1]->divergences().empty()) << "the peer in step finds nothing";
  a.parts.run_until(1.3);
  EXPECT_EQ(a.parts.core(2).stats.heals, 2u) << "not healed: asked again after a second";
}

TEST(HashAudit, ASilentPeerIsNotWaitedFor) {
  Audits a;
  a.parts.run_until(0.1);
  a.parts.net().crash(2);
  a.parts.run_until(0.2);
  EXPECT_FALSE(a.audit[0]->agree_at(15)) << "peer 2 has not reported step 15, and is not silent for long enough";
  EXPECT_TRUE(a.audit[0]->agree_at(10));
  a.parts.run_until(0.5);
  EXPECT_TRUE(a.audit[0]->agree_at(45)) << "peer 2 is silent: the others agree without it";
  EXPECT_TRUE(a.audit[1]->agree_at(45));
  EXPECT_TRUE(a.audit[0]->converged());
}

TEST(HashAudit, AtTheStopTheHashIsReportedAgainEveryTenthOfASecond) {
  Audits a;
  a.parts.run_until(0.1);
  a.stepping = false;
  std::size_t reports = 0;
  a.parts[0].receive = [&](const PeerEnvelope& env) {
    if (env.type == kHash && env.sender == 101) ++reports;
  };
  a.parts[1].tick = [&] { a.audit[1]->report_at_stop(true, 100); };
  a.parts.run_until(0.6);
  // The one of step 10 as it was recorded, then at 0.101, 0.202, 0.303, 0.404 and 0.505 s.
  EXPECT_EQ(reports, 6u);
}
