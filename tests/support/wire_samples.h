// One value of every peer message, ordered peer operation and session operation, each field set
// to something other than its default (and payloads as plain bytes, so that no value depends on
// the cloth code), named as in tests/fixtures/saved/. The saved files' tests encode these with
// this build and compare with what an earlier build wrote.
#pragma once

#include "kiji/operation.h"
#include "net/peer_messages.h"

#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace kiji::test {

struct WireSample {
  std::string name;
  std::string bytes;
};

// Bytes that stand for a garment, a body or a state: every byte value, so that none is lost on
// the way.
inline std::shared_ptr<const std::string> sample_payload(const std::string& what) {
  std::string s = what + ":";
  for (int i = 0; i < 256; ++i) s.push_back(static_cast<char>(i));
  return std::make_shared<const std::string>(s);
}

inline ToolEvent sample_event(Phase phase) {
  ToolEvent e;
  e.phase = phase;
  e.time = 1.25;
  e.position = Vec3(0.125, -0.5, 0.3);
  e.orientation = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2);
  e.buttons = 5;
  e.pressure = 0.75;
  e.ray = Vec3(0, -0.6, -0.8);
  return e;
}

inline std::vector<std::pair<std::string, Operation>> sample_operations() {
  std::vector<std::pair<std::string, Operation>> out;
  auto add = [&](const std::string& name, OperationData data) { out.push_back({name, {1000 + out.size(), 3, data}}); };
  op::ToolInput begin;
  begin.tool = "paint";
  begin.params = {{"flag", true}, {"count", -7LL}, {"size", 0.25}, {"mode", std::string("soft")},
                  {"color", Vec3(1, 0.5, 0.125)}};
  begin.event = sample_event(Phase::Begin);
  add("tool_begin", begin);
  for (Phase p : {Phase::Move, Phase::End, Phase::Cancel})
    add(std::string("tool_") + phase_name(p), op::ToolInput{"pinch", {}, sample_event(p)});
  add("add_garment", op::AddGarment{sample_payload("garment")});
  add("remove_garment", op::RemoveGarment{2});
  add("set_garment", op::SetGarment{1, sample_payload("edited garment")});
  add("set_body", op::SetBody{sample_payload("body")});
  add("set_body_none", op::SetBody{});
  SolverParams p;
  p.floor = false;  // the build that saved these had no floor: what it wrote reads as off
  p.held_substeps = 0;  // nor held substeps
  p.model = SolverModel::MassSpring;
  p.gravity = Vec3(0.5, -9.5, 0.25);
  p.substeps = 7;
  p.iterations = 3;
  p.body_collision = false;
  p.self_collision = true;
  p.strain_limit = 0.2;
  p.spring_k = 1234.5;
  p.spring_damping = 0.125;
  p.local_radius = 0.3;
  p.local_center = Vec3(0.1, 0.2, 0.3);
  p.sleep_after = 2.5;
  p.sleep_distance = 0.0005;
  add("set_solver_params", op::SetSolverParams{p});
  add("set_frame_rate", op::SetFrameRate{120});
  add("set_simulating", op::SetSimulating{false});
  add("set_pick_radius", op::SetPickRadius{0.03});
  add("undo", op::Undo{});
  add("redo", op::Redo{});
  add("advance", op::Advance{});
  add("checkpoint", op::Checkpoint{sample_payload("state")});
  add("checkpoint_own", op::Checkpoint{});
  return out;
}

// Every peer message body and ordered peer operation, encoded by this build.
inline std::vector<WireSample> peer_message_samples() {
  using namespace detail;
  std::vector<WireSample> out;
  Heartbeat h;
  h.name = "alice";
  h.sequencer = true;
  h.joined = true;
  h.step = 1234;
  h.received = 77;
  h.horizon = 1236;
  h.next = 80;
  h.stop = 9000;
  h.ordered = {{0, 5}, {101, 42}, {0x7fffffffu, 0x0102030405060708ull}};
  out.push_back({"heartbeat", encode(h)});
  Heartbeat joining;
  joining.name = "bob";
  joining.joined = true;
  joining.step = 3;
  joining.received = 1;
  joining.horizon = 4;
  joining.next = 2;
  out.push_back({"heartbeat_member", encode(joining)});
  Payload inline_payload;
  inline_payload.bytes = *sample_payload("operation");
  Payload blob;
  blob.blob = true;
  blob.hash = 0xdeadbeefcafef00dull;
  blob.size = 123456;
  out.push_back({"propose", encode(Propose{9, 1300, inline_payload})});
  out.push_back({"propose_blob", encode(Propose{10, 1301, blob})});
  out.push_back({"order", encode(Order{81, 1240, 101, 9, inline_payload})});
  out.push_back({"order_blob", encode(Order{82, 1241, 101, 10, blob})});
  out.push_back({"nack_order", encode(NackOrder{70, 80, 102})});
  BlobChunk middle;
  middle.hash = 0x1122334455667788ull;
  middle.size = 2500;
  middle.index = 1;
  middle.count = 3;
  for (int i = 0; i < 1000; ++i) middle.data.push_back(static_cast<char>(i * 7));
  out.push_back({"blob_chunk", encode(middle)});
  BlobChunk last = middle;
  last.index = 2;
  last.data.resize(500);
  out.push_back({"blob_chunk_last", encode(last)});
  out.push_back({"blob_nack", encode(BlobNack{0x1122334455667788ull, {0, 3, 17, 199}})});
  out.push_back({"hash", encode(HashReport{1230, 0x0123456789abcdefull})});
  PeerPresence pr;
  pr.pointer = Vec3(0.1, -0.2, 0.3);
  pr.orientation = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2);
  pr.buttons = 5;
  pr.eye = Vec3(0, 1.6, 2);
  pr.target = Vec3(0, 1, 0);
  pr.tool = "pinch";
  out.push_back({"presence", encode_presence(pr)});
  out.push_back({"claim", encode(Claim{3, 81})});
  out.push_back({"state_offer", encode(StateOffer{103, 82, 0x0f0e0d0c0b0a0908ull, 54321})});
  out.push_back({"join", encode_name("carol")});
  PeerOp session;
  session.operation = encode_operation(sample_operations().front().second);
  out.push_back({"peer_op_session", encode(session)});
  PeerOp lease;
  lease.kind = PeerOp::Lease;
  lease.garment = 1;
  lease.center = Vec3(0.25, 1.125, -0.5);
  lease.radius = 0.06;
  lease.seconds = 1.5;
  out.push_back({"peer_op_lease", encode(lease)});
  PeerOp release;
  release.kind = PeerOp::Release;
  out.push_back({"peer_op_release", encode(release)});
  PeerOp checkpoint;
  checkpoint.kind = PeerOp::Checkpoint;
  checkpoint.targets = {103, 104};
  out.push_back({"peer_op_checkpoint", encode(checkpoint)});
  PeerOp left;
  left.kind = PeerOp::PeerLeft;
  left.peer = 102;
  out.push_back({"peer_op_peer_left", encode(left)});
  return out;
}

inline std::vector<WireSample> operation_samples() {
  std::vector<WireSample> out;
  for (const auto& [name, op] : sample_operations()) out.push_back({name, encode_operation(op)});
  return out;
}

#ifdef KIJI_TEST_SAVED
// The samples of a file of tests/fixtures/saved/ ("name hex" a line), in its order.
inline std::vector<WireSample> read_samples(const std::string& file) {
  const std::string path = std::string(KIJI_TEST_SAVED) + "/" + file;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::vector<WireSample> out;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string name, hex;
    fields >> name >> hex;
    std::string bytes;
    for (std::size_t i = 0; i + 1 < hex.size(); i += 2) bytes.push_back(static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16)));
    out.push_back({name, bytes});
  }
  return out;
}
#endif

}  // namespace kiji::test
