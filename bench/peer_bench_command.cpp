// kiji bench peers: figures for a design session shared over LCM, measured on this machine with
// every peer a real PeerRunner on real sockets in this process. The paper's table 3 (user 2's rate
// with each tool while user 1 cuts), a remote stroke's latency and the time to converge after it at
// each loss, a late join on a large garment, and the bytes a second a peer sends.
#include "args.h"
#include "bench_commands.h"
#include "kiji/body.h"
#include "kiji/drape.h"
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/peer_runner.h"
#include "kiji/session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace kiji::cli {

namespace {

using Json = nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;

double now_seconds() { return std::chrono::duration<double>(Clock::now().time_since_epoch()).count(); }
void nap() { std::this_thread::sleep_for(std::chrono::microseconds(200)); }

const char* kHelp =
    "usage: kiji bench peers [--json] [--quick] [--sizes V,V,...] [--tools T,T,...] [--frames N]\n"
    "                        [--loss P,P,...] [--join-vertices V] [--lookahead N] [--url URL]\n\n"
    "A design session shared over LCM, measured: every peer is a real peer on real sockets in this\n"
    "process, so the figures include the network stack and the peers share this machine's cores.\n\n"
    "  table 3    steps/s of user 2's every tool while user 1 cuts, at each size (the paper's table 3);\n"
    "             the shared clock runs in real time, so no row exceeds the session's 60 steps/s\n"
    "  latency    a remote stroke (three peers in real time: the sequencer, the user, a viewer): from\n"
    "             the user's event to the viewer applying it, p50 and p99, at each loss; then the time\n"
    "             until every peer reports the same state after the stroke's last event\n"
    "  late join  a peer joining a session with a garment of --join-vertices vertices: until it has the\n"
    "             shared state\n"
    "  bytes/s    what each peer sends a second, from the latency runs\n\n"
    "--loss drops that percentage of the messages each peer receives (default 0,10). --url is the LCM\n"
    "provider (default udpm on this host only, ttl=0). --quick uses tiny sizes (a check that everything\n"
    "runs, not figures to quote). --lookahead sets the steps the sequencer looks ahead (see docs/peers.md).\n";

std::vector<double> list_of(const Args& args, const std::string& name, std::vector<double> fallback) {
  if (!args.has(name)) return fallback;
  std::vector<double> out;
  std::stringstream ss(args.get(name, ""));
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      out.push_back(std::stod(item));
    } catch (const std::exception&) {
      throw UsageError(name + " expects numbers separated by commas, not '" + args.get(name, "") + "'");
    }
  }
  if (out.empty()) throw UsageError(name + " expects one or more numbers");
  return out;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t i = std::min(v.size() - 1, static_cast<std::size_t>(std::ceil(p * v.size())) - (p > 0 ? 1 : 0));
  return v[i];
}

// One peer of a bench: its own session (the machine of one user), run by its own PeerRunner.
struct BenchPeer {
  Session session;
  std::unique_ptr<PeerRunner> runner;
  template <class F>
  auto with(F&& f) {
    std::lock_guard<std::recursive_mutex> lock(session.mutex());
    return f(session);
  }
  bool joined() const { return runner->joined(); }
  PeerStats stats() { return runner->with_peer([](Peer& p) { return p.stats(); }); }
};

struct Network {
  PeerNetwork network;
  std::string key;
};

// A fresh key and channel for each session measured, so that one run's stragglers never reach the next.
Network fresh_network(const std::string& url, double loss) {
  static std::mt19937_64 random(std::random_device{}());
  Network n;
  n.network.url = url;
  n.network.channel = "KIJI_BENCH_" + std::to_string(random() % 1000000000);
  n.network.loss = loss;
  for (int i = 0; i < 32; ++i) n.key.push_back(static_cast<char>('a' + random() % 26));
  return n;
}

// Steps the sequencer looks ahead (PeerOptions::lookahead_steps), as --lookahead sets it.
int g_lookahead = PeerOptions{}.lookahead_steps;

PeerOptions options_for(const Network& n, const std::string& name, bool host, bool real_time) {
  PeerOptions o;
  o.lookahead_steps = g_lookahead;
  o.name = name;
  o.key = n.key;
  o.host = host;
  o.real_time = real_time;
  return o;
}

// The host: a session with the default body and a 1 m square of about `vertices` vertices placed over
// it as kiji drape places it, let fall for a few frames (not timed) so that it is in motion on the body.
std::unique_ptr<BenchPeer> host(const Body& body, int vertices, const Network& n, bool real_time) {
  auto p = std::make_unique<BenchPeer>();
  p->session.set_body(body);
  const int side = std::max(2, static_cast<int>(std::lround(std::sqrt(double(vertices)))));
  Garment g = make_rectangle(1.0, 1.0, side, side);
  place_over_body(g, body);
  p->session.add_garment(std::move(g));
  for (int i = 0; i < 10; ++i) p->session.step();
  p->runner = std::make_unique<PeerRunner>(p->session, options_for(n, "user 1", true, real_time), n.network);
  return p;
}

// A peer joining: returns once it has the shared state, with the seconds that took.
std::unique_ptr<BenchPeer> join(const Network& n, const std::string& name, bool real_time, double& seconds) {
  auto p = std::make_unique<BenchPeer>();
  const double t0 = now_seconds();
  p->runner = std::make_unique<PeerRunner>(p->session, options_for(n, name, false, real_time), n.network);
  while (!p->joined()) {
    if (!p->runner->running()) throw Error(name + " stopped before joining: " + p->runner->error());
    if (now_seconds() - t0 > 60) throw Error(name + " did not join the bench's session within 60 s");
    nap();
  }
  seconds = now_seconds() - t0;
  return p;
}

// A stroke drawn over the cloth from above, from `a` to `z`, as kiji bench draws its strokes: each
// event on the cloth where it is at that moment (the pen a millimetre above it, pointing down).
struct StrokePath {
  std::string tool;
  Vec3 a, z;
  Vec3 last;
  ParamSet params;
  int refused = 0;
  void event(Session& s, int f, int frames) {
    ToolEvent e;
    e.phase = f == 0 ? Phase::Begin : (f == frames ? Phase::End : Phase::Move);
    e.time = s.time() + 2.0 / s.frame_rate();
    const Vec3 down(0, -1, 0);
    const Vec3 above = a + (z - a) * (double(f) / frames);
    const SurfaceHit under = s.pick(above, down);
    if (f == 0) last = under.hit ? under.point : above;
    e.position = under.hit ? Vec3(under.point - 0.001 * down) : Vec3(above.x(), last.y(), above.z());
    e.ray = down;
    last = e.position;
    try {
      s.apply(tool, e, &params);
    } catch (const Error&) {
      ++refused;  // a region another user holds: the bench's strokes are apart, so this is counted, not expected
    }
  }
};

// Both users' strokes lie across the garment seen from above, apart by more than two lease radii.
void place_strokes(Session& s, StrokePath& user1, StrokePath& user2) {
  const Box3 b = s.garment(0).bounds();
  const double y = b.max().y() + 0.1, cz = b.center().z(), cx = b.center().x();
  user1.a = Vec3(cx - 0.45, y, cz), user1.z = Vec3(cx - 0.15, y, cz);
  user2.a = Vec3(cx + 0.05, y, cz), user2.z = Vec3(cx + 0.40, y, cz);
}

struct Table3Row {
  int vertices = 0;
  std::string tool;
  double steps_per_second = 0, join_seconds = 0;
  int refused = 0;
};

Table3Row table3_row(const Body& body, int vertices, const std::string& tool, int frames, const std::string& url) {
  const Network n = fresh_network(url, 0);
  Table3Row row{vertices, tool};
  auto one = host(body, vertices, n, true);
  auto two = join(n, "user 2", true, row.join_seconds);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // both clocks in their stride
  StrokePath cut{"cut"}, other{tool};
  one->with([&](Session& s) {
    place_strokes(s, cut, other);
    cut.params = s.params_for("cut");
  });
  two->with([&](Session& s) { other.params = s.params_for(tool); });
  std::uint64_t last = two->with([](Session& s) { return s.steps(); });
  const std::uint64_t first_step = last;
  const double t0 = now_seconds();
  for (int f = 0; f <= frames; ++f) {
    // One event of each user's stroke a frame, as their pens move.
    while (two->with([](Session& s) { return s.steps(); }) <= last) nap();
    one->with([&](Session& s) { cut.event(s, f, frames); });
    last = two->with([&](Session& s) {
      other.event(s, f, frames);
      return s.steps();
    });
  }
  // Until both strokes are applied everywhere.
  auto pending = [](BenchPeer& p) { return p.runner->with_peer([](Peer& peer) { return peer.pending(); }); };
  while (pending(*one) + pending(*two) > 0) {
    if (!one->runner->running() || !two->runner->running())
      throw Error("a peer stopped during the bench: " + one->runner->error() + two->runner->error());
    nap();
  }
  const double seconds = now_seconds() - t0;
  row.steps_per_second = static_cast<double>(two->with([](Session& s) { return s.steps(); }) - first_step) / seconds;
  row.refused = cut.refused + other.refused;
  return row;
}

struct LatencyRun {
  double loss = 0;
  int events = 0;
  std::vector<double> remote_ms, own_ms;
  double converge_seconds = NAN;
  double seconds = 0;
  std::vector<double> bytes_per_second;  // sequencer, user, viewer
  std::uint64_t nacks = 0, resent = 0;
};

// Three peers in real time at the session's frame rate: a sequencer (the host), a user whose pinch
// drags the cloth for `frames` frames, and a viewer. Latency is from the user's event (its call to
// apply) to the viewer applying it, and to the user's own session applying it in the shared order.
LatencyRun latency_run(const Body& body, int vertices, int frames, double loss, const std::string& url) {
  const Network n = fresh_network(url, loss);
  LatencyRun run;
  run.loss = loss;
  // Declared before the peers: their threads' listeners write here until the peers are gone.
  std::vector<double> sent;
  std::vector<double> seen_by_seq, seen_by_viewer, seen_by_user;
  std::vector<std::uint64_t> end_steps(3, 0);
  auto seq = host(body, vertices, n, true);
  double ignored = 0;
  auto user = join(n, "user 2", true, ignored);
  auto viewer = join(n, "viewer", true, ignored);
  const std::uint32_t user_id = user->runner->with_peer([](Peer& p) { return p.id(); });

  // Listeners run on each peer's thread, as it applies the shared order.
  auto listen = [&](BenchPeer& p, std::vector<double>& seen, std::uint64_t& end_step) {
    return p.with([&](Session& s) {
      return s.add_listener([&seen, &end_step, user_id](const Operation& op) {
        const auto* input = std::get_if<op::ToolInput>(&op.data);
        if (!input || op.user != user_id) return;
        seen.push_back(now_seconds());
        if (input->event.phase == Phase::End) end_step = op.step;
      });
    });
  };
  listen(*seq, seen_by_seq, end_steps[0]);
  listen(*user, seen_by_user, end_steps[1]);
  listen(*viewer, seen_by_viewer, end_steps[2]);

  BenchPeer* peers[3] = {seq.get(), user.get(), viewer.get()};
  std::vector<PeerStats> before;
  for (BenchPeer* p : peers) before.push_back(p->stats());
  StrokePath pinch{"pinch"};
  user->with([&](Session& s) {
    StrokePath unused{"cut"};
    place_strokes(s, unused, pinch);
    pinch.z = pinch.a + Vec3(0.3, 0.3, 0);  // lifted up and to the side: the whole pull is felt
    pinch.params = s.params_for("pinch");
  });
  const double t0 = now_seconds();
  std::uint64_t last = user->with([](Session& s) { return s.steps(); });
  sent.reserve(frames + 1);
  for (int f = 0; f <= frames; ++f) {
    while (user->with([](Session& s) { return s.steps(); }) <= last) nap();
    last = user->with([&](Session& s) {
      sent.push_back(now_seconds());
      pinch.event(s, f, frames);
      return s.steps();
    });
  }
  const double end_sent = sent.back();
  // Every event applied everywhere, then every peer reporting the same state at a hash step after it.
  const int interval = seq->runner->with_peer([](Peer& p) { return p.options().hash_interval; });
  bool converged = false;
  while (now_seconds() - end_sent < 30) {
    for (BenchPeer* p : peers)
      if (!p->runner->running()) throw Error("a peer stopped during the bench: " + p->runner->error());
    std::uint64_t end_step = 0;
    auto applied = [&](BenchPeer& p, const std::vector<double>& seen, const std::uint64_t& step) {
      return p.with([&](Session&) {
        end_step = std::max(end_step, step);
        return seen.size() == sent.size();
      });
    };
    if (applied(*user, seen_by_user, end_steps[1]) && applied(*viewer, seen_by_viewer, end_steps[2]) &&
        applied(*seq, seen_by_seq, end_steps[0])) {
      const std::uint64_t hash_step = (end_step / interval + 1) * interval;
      bool all = true;
      for (BenchPeer* p : peers)
        all = all && p->runner->with_peer([&](Peer& peer) {
          return peer.converged() && p->session.steps() >= hash_step + 1;
        });
      if (all) {
        converged = true;
        break;
      }
    }
    nap();
  }
  run.converge_seconds = converged ? now_seconds() - end_sent : NAN;
  run.seconds = now_seconds() - t0;
  for (int i = 0; i < 3; ++i) {
    const PeerStats after = peers[i]->stats();
    run.bytes_per_second.push_back(static_cast<double>(after.bytes_sent - before[i].bytes_sent) / run.seconds);
    run.nacks += after.nacks_sent - before[i].nacks_sent;
    run.resent += after.resent - before[i].resent;
  }
  run.events = static_cast<int>(sent.size());
  for (std::size_t i = 0; i < sent.size() && i < seen_by_viewer.size(); ++i)
    run.remote_ms.push_back(1000 * (seen_by_viewer[i] - sent[i]));
  for (std::size_t i = 0; i < sent.size() && i < seen_by_user.size(); ++i)
    run.own_ms.push_back(1000 * (seen_by_user[i] - sent[i]));
  for (BenchPeer* p : peers) p->runner->stop();
  return run;
}

double late_join_seconds(const Body& body, int vertices, const std::string& url) {
  const Network n = fresh_network(url, 0);
  auto first = host(body, vertices, n, true);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the session under way
  double seconds = 0;
  join(n, "late", true, seconds)->runner->stop();
  return seconds;
}

Json finite_or_null(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

}  // namespace

int peer_bench_command(const std::vector<std::string>& argv) {
  const Args args(argv, {"--sizes", "--tools", "--frames", "--loss", "--join-vertices", "--lookahead", "--url"},
                  {"--json", "--quick", "--help", "-h"});
  if (args.has("--help") || args.has("-h")) {
    std::fputs(kHelp, stdout);
    return 0;
  }
  const bool quick = args.has("--quick"), json = args.has("--json");
  std::vector<int> sizes;
  for (double v : list_of(args, "--sizes", quick ? std::vector<double>{121, 400} : std::vector<double>{521, 5000, 20000})) {
    if (!(v >= 4 && v <= 1e6)) throw UsageError("--sizes: each size must be between 4 and 1,000,000 vertices");
    sizes.push_back(static_cast<int>(v));
  }
  std::vector<std::string> tools = {"pinch", "tear", "cut", "sew", "paint"};
  if (args.has("--tools")) {
    tools.clear();
    std::stringstream ss(args.get("--tools", ""));
    std::string t;
    while (std::getline(ss, t, ',')) tools.push_back(t);
  }
  const int frames = args.integer("--frames", quick ? 5 : 30);
  if (frames < 2 || frames > 10000) throw UsageError("--frames must be between 2 and 10,000");
  std::vector<double> losses;
  for (double p : list_of(args, "--loss", {0, 10})) {
    if (!(p >= 0 && p <= 90)) throw UsageError("--loss: each percentage must be between 0 and 90");
    losses.push_back(p / 100);
  }
  const int join_vertices = args.integer("--join-vertices", quick ? 400 : 20000);
  if (join_vertices < 4 || join_vertices > 1000000) throw UsageError("--join-vertices must be between 4 and 1,000,000");
  const std::string url = args.get("--url", PeerNetwork{}.url);
  g_lookahead = args.integer("--lookahead", g_lookahead);
  if (g_lookahead < 1 || g_lookahead > 60) throw UsageError("--lookahead must be 1 to 60 steps");

  const Body body = Body::load(Body::default_path());
  {
    Session check;
    for (const std::string& t : tools)
      if (!check.tools().has(t)) throw UsageError("--tools: no tool '" + t + "' was found (see 'kiji tools')");
  }
  auto say = [&](const char* fmt, auto... a) {
    if (!json) std::printf(fmt, a...), std::fflush(stdout);
  };

  Json report;
  report["threads"] = std::thread::hardware_concurrency();
  report["url"] = url;
  report["lookahead_steps"] = g_lookahead;
  say("kiji bench peers: every peer is a real peer on %s, in this process (%u hardware threads)\n\n", url.c_str(),
      std::thread::hardware_concurrency());

  say("The paper's table 3: user 2's steps/s with each tool while user 1 cuts (real time: 60 at most)\n");
  say("%-10s", "vertices");
  for (const std::string& t : tools) say("%10s", t.c_str());
  say("%14s\n", "join (s)");
  Json rows = Json::array();
  for (int v : sizes) {
    say("%-10d", v);
    double join = 0;
    for (const std::string& t : tools) {
      const Table3Row r = table3_row(body, v, t, frames, url);
      join = std::max(join, r.join_seconds);
      say("%10.1f", r.steps_per_second);
      rows.push_back({{"vertices", v}, {"tool", t}, {"steps_per_second", r.steps_per_second},
                      {"join_seconds", r.join_seconds}, {"refused_events", r.refused}});
    }
    say("%14.2f\n", join);
  }
  report["table3"] = rows;

  say("\nA remote stroke: a pinch dragged for %d frames, three peers in real time on %d vertices\n", 4 * frames, sizes.front());
  say("%-8s%12s%12s%12s%12s%14s%16s%10s\n", "loss", "remote p50", "remote p99", "own p50", "own p99", "converge (s)",
      "bytes/s a peer", "nacks");
  Json latency = Json::array();
  for (double loss : losses) {
    const LatencyRun r = latency_run(body, sizes.front(), 4 * frames, loss, url);
    double mean_bytes = 0;
    for (double b : r.bytes_per_second) mean_bytes += b / r.bytes_per_second.size();
    say("%-8s%10.1f ms%9.1f ms%9.1f ms%9.1f ms%14.2f%16.0f%10llu\n", (std::to_string(int(std::lround(loss * 100))) + " %").c_str(),
        percentile(r.remote_ms, 0.5), percentile(r.remote_ms, 0.99), percentile(r.own_ms, 0.5), percentile(r.own_ms, 0.99),
        r.converge_seconds, mean_bytes, static_cast<unsigned long long>(r.nacks));
    latency.push_back({{"loss", loss},
                       {"vertices", sizes.front()},
                       {"events", r.events},
                       {"remote_ms_p50", finite_or_null(percentile(r.remote_ms, 0.5))},
                       {"remote_ms_p99", finite_or_null(percentile(r.remote_ms, 0.99))},
                       {"own_ms_p50", finite_or_null(percentile(r.own_ms, 0.5))},
                       {"own_ms_p99", finite_or_null(percentile(r.own_ms, 0.99))},
                       {"events_seen_remote", r.remote_ms.size()},
                       {"converge_seconds", finite_or_null(r.converge_seconds)},
                       {"bytes_per_second", {{"sequencer", r.bytes_per_second[0]}, {"user", r.bytes_per_second[1]},
                                             {"viewer", r.bytes_per_second[2]}}},
                       {"nacks", r.nacks},
                       {"resent", r.resent}});
  }
  report["latency"] = latency;

  const double join = late_join_seconds(body, join_vertices, url);
  say("\nA late join: %.2f s to have the shared state of a session with %d vertices under way\n", join, join_vertices);
  report["late_join"] = {{"vertices", join_vertices}, {"seconds", join}};
  if (json) std::printf("%s\n", report.dump(2).c_str());
  return 0;
}

}  // namespace kiji::cli
