#include "kiji/session_file.h"

#include "kiji/error.h"
#include "kiji/journal_file.h"
#include "kiji/session.h"

#include "session/lcm_log.h"

#include <kiji_lcm/op_record_t.hpp>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <system_error>

namespace kiji {

namespace {

namespace fs = std::filesystem;

// The record's fields before its data: fingerprint, protocol, step, user, hash, size.
constexpr std::size_t kRecordHeader = 8 + 2 + 8 + 4 + 8 + 4;

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}

std::string encode_record(const Operation& op) {
  kiji_lcm::op_record_t r;
  const std::string bytes = encode_operation(op);
  r.protocol = kSessionFileProtocol;
  r.step = static_cast<std::int64_t>(op.step);
  r.user = static_cast<std::int32_t>(op.user);
  r.hash = static_cast<std::int64_t>(hash_bytes(bytes));
  r.size = static_cast<std::int32_t>(bytes.size());
  r.data.assign(bytes.begin(), bytes.end());
  std::string out(static_cast<std::size_t>(r.getEncodedSize()), '\0');
  r.encode(out.data(), 0, static_cast<int>(out.size()));
  return out;
}

// Decodes one record, checking every length before LCM's decoder sees it (its decoders trust the
// array length they read). Returns false for a record that is not whole and intact.
bool decode_record(const void* data, std::size_t size, Operation& out, std::string& why) {
  if (size < kRecordHeader) {
    why = "a record is shorter than its header";
    return false;
  }
  const auto* p = static_cast<const unsigned char*>(data);
  const std::uint32_t declared = be32(p + kRecordHeader - 4);
  if (declared > size - kRecordHeader || kRecordHeader + declared != size) {
    why = "a record's size does not match its length";
    return false;
  }
  kiji_lcm::op_record_t r;
  if (r.decode(data, 0, static_cast<int>(size)) < 0) {
    why = "a record is not an op_record_t (another protocol, or damaged)";
    return false;
  }
  if (r.protocol < 1 || r.protocol > kSessionFileProtocol) {
    why = "a record is of session-file protocol " + std::to_string(r.protocol) + "; this Kiji reads 1 to " +
          std::to_string(kSessionFileProtocol) + ": use a newer Kiji";
    return false;
  }
  const std::string_view bytes(reinterpret_cast<const char*>(r.data.data()), r.data.size());
  if (static_cast<std::uint64_t>(r.hash) != hash_bytes(bytes)) {
    why = "a record's bytes do not match its hash (damaged)";
    return false;
  }
  try {
    out = decode_operation(bytes);
  } catch (const InputError& e) {
    why = e.what();
    return false;
  }
  return true;
}

std::int64_t now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

struct Autosave::Log {
  detail::LcmLog file;
  Log(const std::string& path, const char* mode) : file(path, mode) {}
};

std::vector<Operation> load_session(const std::string& path, SessionFileReport* report, SavedState* state) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    throw InputError("cannot read the session file '" + path + "': it does not exist or is not a file");
  detail::LcmLog log(path, "r");
  if (!log.good()) throw InputError("cannot open the session file '" + path + "': check its permissions");
  SessionFileReport rep;
  rep.file_bytes = log.file_size();
  std::vector<Operation> ops;
  std::string channel, data;
  detail::LcmLog::Read read;
  for (;;) {
    read = log.next(channel, data, rep.damage);
    if (read != detail::LcmLog::Read::Event) break;
    if (channel == kSessionChannel) {
      Operation op;
      if (!decode_record(data.data(), data.size(), op, rep.damage)) break;
      ops.push_back(std::move(op));
    } else if (channel == kSessionStateChannel && state) {
      // A state that does not read is passed over: the operations give the session all the same.
      Operation op;
      std::string why;
      const auto* checkpoint = decode_record(data.data(), data.size(), op, why) ? std::get_if<op::Checkpoint>(&op.data) : nullptr;
      if (checkpoint && checkpoint->state) *state = {std::move(op), ops.size(), true};
    }
    rep.good_bytes = log.position();
  }
  rep.operations = ops.size();
  // A session killed while it wrote its first operation: the file ends inside that record.
  const bool first_cut_off = read == detail::LcmLog::Read::CutOff && ops.empty() &&
                             std::string_view(kSessionChannel).substr(0, channel.size()) == channel;
  if (ops.empty() && !rep.damage.empty() && !first_cut_off)
    throw InputError("'" + path + "' is not a Kiji session file: " + rep.damage);
  if (report) *report = rep;
  return ops;
}

void save_session(const Session& session, const std::string& path, const std::vector<Operation>& before) {
  detail::LcmLog log(path, "w");
  if (!log.good())
    throw InputError("cannot write the session file '" + path + "': check that its folder exists and is writable");
  auto write = [&](const Operation& op, const char* channel) {
    if (!log.write(channel, encode_record(op), now_us()))
      throw InputError("writing the session file '" + path + "' failed (is the disk full?)");
  };
  for (const Operation& op : before) write(op, kSessionChannel);
  for (const Operation& op : operations_to_save(session)) write(op, kSessionChannel);
  write({session.steps(), 0, op::Checkpoint{std::make_shared<const std::string>(session.encode_state())}},
        kSessionStateChannel);
}

std::size_t open_operations(Session& session, const std::vector<Operation>& operations, const SavedState& state) {
  if (!state.found) return replay(session, operations);
  session.perform(state.checkpoint);
  std::size_t applied = 1;
  for (std::size_t i = state.after; i < operations.size(); ++i, ++applied) session.perform(operations[i]);
  return applied;
}

Autosave::Autosave(Session& session, const std::string& path, bool append) : session_(session), path_(path) {
  std::error_code ec;
  if (!append && fs::exists(path, ec) && fs::file_size(path, ec) > 0)
    throw InputError("the autosave file '" + path + "' already holds a session: recover it (kiji recover " + path +
                     ") or choose another file");
  log_ = std::make_unique<Log>(path, append ? "a" : "w");
  if (!log_->file.good())
    throw InputError("cannot write the autosave file '" + path + "': check that its folder exists and is writable");
  listener_ = session_.add_listener([this](const Operation& op) { write(op); });
}

Autosave::~Autosave() { session_.remove_listener(listener_); }

void Autosave::write_state() {
  write({session_.steps(), 0, op::Checkpoint{std::make_shared<const std::string>(session_.encode_state())}},
        kSessionStateChannel);
}

void Autosave::write(const Operation& op, const char* channel) {
  if (!log_->file.write(channel, encode_record(op), now_us()))
    throw InputError("autosave to '" + path_ + "' failed (is the disk full?): the operation was applied, but is not "
                     "saved");
  if (channel != kSessionChannel) {
    log_->file.sync();
    return;
  }
  ++written_;
  // Moves and begins are many and short-lived: the operating system has them, which a killed
  // process cannot lose. A finished stroke and every other operation go to the disk itself.
  const auto* tool = std::get_if<op::ToolInput>(&op.data);
  if (!tool || tool->event.phase == Phase::End || tool->event.phase == Phase::Cancel) log_->file.sync();
}

Recovered recover(const std::string& path, std::shared_ptr<ToolRegistry> registry, bool keep_saving) {
  Recovered out;
  SavedState state;
  std::vector<Operation> ops = load_session(path, &out.report, &state);
  out.session = std::make_unique<Session>(std::move(registry));
  Session& s = *out.session;
  if (state.found) s.perform(state.checkpoint);
  for (std::size_t i = state.found ? state.after : 0; i < ops.size(); ++i) s.perform(ops[i]);
  if (keep_saving) {
    if (out.report.good_bytes < out.report.file_bytes) {
      std::error_code ec;
      fs::resize_file(path, out.report.good_bytes, ec);
      if (ec) throw InputError("cannot cut the damaged end off '" + path + "': " + ec.message());
    }
    out.autosave = std::make_unique<Autosave>(s, path, /*append=*/true);
  }
  // Strokes the crash left unfinished are cancelled, as a dropped pen would be (and saved so).
  for (UserId user : s.active_users()) {
    ToolEvent cancel;
    cancel.phase = Phase::Cancel;
    cancel.time = s.time();
    const std::string tool = s.active_tool(user);
    s.apply(tool, cancel, nullptr, user);
    ++out.cancelled_strokes;
  }
  return out;
}

bool decode_session_record(std::string_view bytes, Operation& out, std::string& why) {
  return decode_record(bytes.data(), bytes.size(), out, why);
}

}  // namespace kiji
