// kiji peer: takes part in a shared design session over LCM, hosting it or joining it. A script's
// strokes (a journal) can be played as this peer's user; at the end it can write the garment and
// print what it saw (the state hash every peer must agree on, the peers, the network's figures).
#include "args.h"
#include "commands.h"
#include "kiji/body.h"
#include "kiji/drape.h"
#include "kiji/error.h"
#include "kiji/io.h"
#include "kiji/journal_file.h"
#include "kiji/pattern.h"
#include "kiji/peer_runner.h"
#include "kiji/session.h"
#include "kiji/session_key.h"

#include <nlohmann/json.hpp>


#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <map>
#include <thread>

namespace kiji::cli {

namespace {

constexpr const char* kPeerHelp =
    "usage: kiji peer --key-file FILE [--host] [options]\n\n"
    "Takes part in a shared design session: every peer holds the whole session and simulates it; the\n"
    "changes each user makes are put in one order and applied by all at the same step, and state hashes\n"
    "prove the peers agree. See docs/peers.md.\n\n"
    "  --key-file FILE     the session's shared secret; with --host a missing file is made (a fresh random\n"
    "                      key, readable by its owner only): give it to the others\n"
    "  --host              start the shared session (the default body; --journal for a saved one)\n"
    "  --journal FILE      (host) the session to start from: a saved journal or session file\n"
    "  --garment rect:W,H,S  add a W x H m rectangle (vertices S m apart) over the body once in the\n"
    "                      session [a host with neither: rect:0.6,0.6,0.02]\n"
    "  --name NAME         this user's name as the others see it\n"
    "  --url URL           the LCM network [udpm://239.255.76.67:7667?ttl=0: this host only; ttl=1: the LAN]\n"
    "  --channel NAME      the LCM channel [KIJI_PEER]\n"
    "  --replay FILE       play a journal's strokes as this peer's user, at their times on the shared clock\n"
    "  --play-channel NAME propose the recorded operations that arrive on this LCM channel as this peer's\n"
    "                      user's: 'lcm-logplayer SESSION_FILE' plays a saved session (channel KIJI_OPS) to\n"
    "                      the running session; not authenticated, so only on a network you trust\n"
    "  --loss P            drop P % of the messages this peer receives, at random (to try a lossy network)\n"
    "  --seconds S         run until the shared clock reaches S simulated seconds (the host stops it there)\n"
    "                      and every peer has the same state hash, then leave [default: until Ctrl-C]\n"
    "  --timeout T         give up after T seconds of wall time, saying so [60 + 3 S]\n"
    "  --out FILE          write garment 0 (.glb or .obj) when leaving\n"
    "  --json              print {state_hash, peers, time, ...} when leaving\n";

volatile std::sig_atomic_t g_interrupted = 0;
void on_interrupt(int) { g_interrupted = 1; }

struct ReplayEvent {
  double at = 0;  // seconds after the replay starts
  const JournalStroke* stroke = nullptr;
  std::size_t index = 0;
};

}  // namespace

int peer_command(const std::vector<std::string>& argv) {
  const Args args(argv,
                  {"--key-file", "--journal", "--garment", "--name", "--url", "--channel", "--replay", "--seconds",
                   "--timeout", "--out", "--play-channel", "--loss"},
                  {"--host", "--json", "--help", "-h"});
  if (args.has("--help") || args.has("-h")) {
    std::fputs(kPeerHelp, stdout);
    return 0;
  }
  if (!args.has("--key-file")) throw UsageError("give the session's key with --key-file FILE (see --help)");
  const bool host = args.has("--host");
  if (!host && args.has("--journal")) throw UsageError("--journal is the host's: a joiner gets the host's session");
  const std::string out = args.get("--out", "");
  if (!out.empty()) {
    const std::string ext = std::filesystem::path(out).extension().string();
    if (ext != ".glb" && ext != ".obj") throw InputError("--out '" + out + "' must end in .glb or .obj");
  }
  const double seconds = args.number("--seconds", 0);
  if (!(seconds >= 0 && seconds <= 1e6)) throw UsageError("--seconds must be between 0 (until Ctrl-C) and 1e6");
  const double timeout = args.number("--timeout", 60 + 3 * seconds);
  if (!(timeout > 0)) throw UsageError("--timeout must be more than 0 seconds");
  std::optional<RectSpec> garment_spec;
  if (args.has("--garment")) garment_spec = RectSpec::parse(args.get("--garment", ""));
  else if (host && !args.has("--journal")) garment_spec = RectSpec::parse("rect:0.6,0.6,0.02");

  PeerOptions options;
  bool made_key = false;
  options.key = read_session_key(args.get("--key-file", ""), host, &made_key);
  if (made_key)
    std::fprintf(stderr, "kiji peer: made a new session key in %s: give it to the peers who join\n",
                 args.get("--key-file", "").c_str());
  options.host = host;
  options.name = args.get("--name", host ? "host" : "peer");
  PeerNetwork network;
  network.url = args.get("--url", network.url);
  network.channel = args.get("--channel", network.channel);
  network.play_channel = args.get("--play-channel", "");
  const double loss = args.number("--loss", 0);
  if (!(loss >= 0 && loss <= 90)) throw UsageError("--loss must be a percentage from 0 to 90");
  network.loss = loss / 100;

  std::vector<JournalStroke> replay;
  if (args.has("--replay")) replay = load_journal(args.get("--replay", ""));
  std::vector<ReplayEvent> events;
  for (const JournalStroke& s : replay)
    for (std::size_t i = 0; i < s.events.size(); ++i) events.push_back({s.events[i].time, &s, i});
  const double first = events.empty() ? 0 : events.front().at;
  for (ReplayEvent& e : events) e.at -= first;

  Session session;
  if (host) {
    if (args.has("--journal")) replay_file(session, args.get("--journal", ""));
    else session.set_body(Body::load(Body::default_path()));
    // The shared clock stops at --seconds (a whole step at or after it).
    if (seconds > 0) options.stop_step = static_cast<std::uint64_t>(std::ceil(seconds * session.frame_rate() - 1e-9));
  }
  auto add_garment = [&] {  // placed over the body as kiji drape places it
    Garment garment = make_rectangle_spaced(garment_spec->width, garment_spec->height, garment_spec->spacing);
    garment.name = args.get("--name", host ? "host" : "peer");
    if (session.body()) place_over_body(garment, *session.body());
    session.add_garment(garment);
  };
  if (host && garment_spec) add_garment();
  bool garment_added = host || !garment_spec;

  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  PeerRunner runner(session, options, network);
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  std::size_t next = 0;
  double replay_start = -1;
  std::uint64_t stop_step = 0;
  bool agreed = false;
  if (!args.has("--json"))
    std::fprintf(stderr, "kiji peer: %s the session on %s (Ctrl-C leaves)\n", host ? "hosting" : "joining",
                 network.url.c_str());
  bool timed_out = false;
  while (!g_interrupted && runner.running()) {
    if (elapsed() >= timeout && (seconds > 0 || args.has("--timeout"))) {
      timed_out = true;
      break;
    }
    const bool done = runner.with_peer([&](Peer& peer) {
      if (!peer.joined()) return false;
      if (!garment_added) {
        garment_added = true;
        add_garment();
      }
      if (stop_step == 0 && seconds > 0)
        stop_step = peer.stop_step() ? peer.stop_step()
                                     : static_cast<std::uint64_t>(std::ceil(seconds * session.frame_rate() - 1e-9));
      // The strokes, each event when its time comes, a little ahead of the shared clock.
      if (replay_start < 0 && next < events.size()) replay_start = session.time() + 0.1;
      while (next < events.size() && replay_start + events[next].at <= session.time() + 0.05) {
        const ReplayEvent& e = events[next++];
        ToolEvent event = e.stroke->events[e.index];
        // Its time on the shared clock, or now if the clock passed it while this loop waited: an
        // event before the clock is refused.
        event.time = std::max(replay_start + e.at, session.time());
        const ParamSet params = session.params_for(e.stroke->tool, e.stroke->params);
        try {
          session.apply(e.stroke->tool, event, &params);
        } catch (const InputError& error) {
          std::fprintf(stderr, "kiji peer: a replayed event was refused: %s\n", error.what());
        }
        // The others see where this user's pen is, as they would a person's.
        PeerPresence presence;
        presence.pointer = event.position;
        presence.orientation = event.orientation;
        presence.buttons = event.buttons;
        presence.tool = e.stroke->tool;
        peer.set_presence(presence);
      }
      // With a stop step: done once the strokes are all sent and every peer agrees there.
      agreed = peer.converged() && session.steps() >= stop_step && stop_step > 0 && next == events.size() &&
               peer.pending() == 0;
      return agreed;
    });
    if (done) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const std::string failure = runner.error();
  nlohmann::json summary;
  runner.with_peer([&](Peer& peer) {
    const PeerStats& st = peer.stats();
    nlohmann::json peers = nlohmann::json::array();
    for (const PeerInfo& p : peer.peers())
      peers.push_back({{"id", p.id}, {"name", p.name}, {"self", p.self}, {"sequencer", p.sequencer}, {"step", p.step}});
    std::map<std::string, int> refusals;
    for (const PeerRefusal& r : peer.refusals()) ++refusals[r.reason];
    summary = {{"id", peer.id()},
               {"joined", peer.joined()},
               {"steps", session.steps()},
               {"time", session.time()},
               {"state_hash", peer.state_hash()},
               {"converged", peer.converged()},
               {"agreed_at_stop", agreed},
               {"timed_out", timed_out},
               {"applied", peer.applied()},
               {"sequencer", peer.sequencer()},
               {"epoch", peer.epoch()},
               {"peers", peers},
               {"refusals", refusals},
               {"divergences", peer.divergences().size()},
               {"replayed_events", next},
               {"garments", session.garment_count()},
               {"played", runner.played()},
               {"play_dropped", runner.play_dropped()},
               {"play_error", runner.play_error()},
               {"messages_sent", st.sent},
               {"messages_received", st.received},
               {"bytes_sent", st.bytes_sent},
               {"bytes_received", st.bytes_received},
               {"nacks_sent", st.nacks_sent},
               {"resent", st.resent},
               {"chunks_asked", st.chunks_asked},
               {"chunks_resent", st.chunks_resent},
               {"heals", st.heals},
               {"elections", st.elections},
               {"dropped", st.dropped},
               {"error", failure}};
  });
  runner.stop();
  if (!out.empty()) {
    if (session.garment_count() == 0) throw InputError("the session has no garment to write (never joined?)");
    export_garment(session.garment(0), out);
  }
  if (args.has("--json")) {
    std::printf("%s\n", summary.dump().c_str());
  } else {
    std::printf("peer %u: step %llu, state %016llx, %s; %zu peer(s); %llu operations applied; %llu messages sent, "
                "%llu received\n",
                unsigned(summary["id"]), static_cast<unsigned long long>(session.steps()),
                static_cast<unsigned long long>(summary["state_hash"].get<std::uint64_t>()),
                summary["converged"].get<bool>() ? "all agree" : "not yet confirmed by all",
                summary["peers"].size(), static_cast<unsigned long long>(summary["applied"].get<std::uint64_t>()),
                static_cast<unsigned long long>(summary["messages_sent"].get<std::uint64_t>()),
                static_cast<unsigned long long>(summary["messages_received"].get<std::uint64_t>()));
  }
  if (timed_out)
    std::fprintf(stderr, "kiji peer: timed out after %.0f s before the peers agreed at the stop\n", timeout);
  if (!failure.empty()) {
    std::fprintf(stderr, "kiji peer: stopped: %s\n", failure.c_str());
    return 1;
  }
  return timed_out ? 3 : 0;
}

}  // namespace kiji::cli
