#include "session/lcm_log.h"

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <sys/stat.h>
#include <unistd.h>

namespace kiji::detail {

namespace {
// An LCM log event's header: sync word, event number, timestamp, channel and data lengths.
constexpr std::size_t kEventHeader = 4 + 8 + 8 + 4 + 4;
constexpr std::uint32_t kLogSync = 0xEDA1DA01u;
constexpr std::uint32_t kMaxEventData = 1u << 30;

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}
}  // namespace

struct LcmLog::Impl {
  lcm::LogFile file;
  std::size_t position = 0;
  Impl(const std::string& path, const char* mode) : file(path, mode) {}
};

LcmLog::LcmLog(const std::string& path, const char* mode) : impl_(std::make_unique<Impl>(path, mode)) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) file_size_ = static_cast<std::size_t>(st.st_size);
}

LcmLog::~LcmLog() = default;

bool LcmLog::good() const { return impl_->file.good(); }

bool LcmLog::write(const std::string& channel, const std::string& data, std::int64_t timestamp_us) {
  lcm::LogEvent e;
  e.timestamp = timestamp_us;
  e.channel = channel;
  e.datalen = static_cast<std::int32_t>(data.size());
  e.data = const_cast<char*>(data.data());
  return impl_->file.writeEvent(&e) == 0 && std::fflush(impl_->file.getFilePtr()) == 0;
}

void LcmLog::sync() { ::fdatasync(fileno(impl_->file.getFilePtr())); }

LcmLog::Read LcmLog::next(std::string& channel, std::string& data, std::string& why) {
  FILE* f = impl_->file.getFilePtr();
  const long at = std::ftell(f);
  unsigned char head[kEventHeader];
  const std::size_t got = std::fread(head, 1, kEventHeader, f);
  if (got == 0) return Read::End;
  // The sync word is checked over the bytes there are, so that a short file of something else is
  // damaged, not an event cut off.
  const unsigned char sync[4] = {kLogSync >> 24, (kLogSync >> 16) & 0xff, (kLogSync >> 8) & 0xff, kLogSync & 0xff};
  const std::uint32_t channel_len = got == kEventHeader ? be32(head + 20) : 0;
  const std::uint32_t data_len = got == kEventHeader ? be32(head + 24) : 0;
  if (std::memcmp(head, sync, std::min<std::size_t>(got, 4)) != 0 ||
      (got == kEventHeader && (channel_len == 0 || channel_len >= 1000 || data_len > kMaxEventData))) {
    why = "a record does not start where the last one ended (damaged)";
    return Read::Damaged;
  }
  if (got < kEventHeader || std::size_t(at) + kEventHeader + channel_len + data_len > file_size_) {
    channel.assign(channel_len, '\0');
    channel.resize(std::fread(channel.data(), 1, channel.size(), f));
    why = "the file ends inside a record (cut off while it was written)";
    return Read::CutOff;
  }
  std::fseek(f, at, SEEK_SET);
  const lcm::LogEvent* e = impl_->file.readNextEvent();
  if (!e || std::ftell(f) != at + long(kEventHeader + channel_len + data_len)) {
    why = "a record could not be read";
    return Read::Damaged;
  }
  channel = e->channel;
  data.assign(static_cast<const char*>(e->data), static_cast<std::size_t>(e->datalen));
  impl_->position = static_cast<std::size_t>(std::ftell(f));
  return Read::Event;
}

std::size_t LcmLog::position() const { return impl_->position; }

}  // namespace kiji::detail
