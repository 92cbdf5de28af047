// An LCM bus behind a plain interface: raw messages published and received on one channel. Like
// lcm_log.h, kept apart from every file that includes CGAL (GMP's lcm() clashes with LCM's names).
// Internal to the core.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace kiji::detail {

class LcmBus {
 public:
  // Opens `url` (an LCM provider, e.g. udpm://239.255.76.67:7667?ttl=0) and subscribes to `channel`.
  // Throws InputError saying why and what to do when the provider cannot be opened.
  LcmBus(const std::string& url, const std::string& channel);
  ~LcmBus();
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  // False if the operating system refused the datagram (the protocol repairs losses anyway).
  bool publish(const std::string& bytes);
  // Waits up to `timeout_ms` for a message, then takes every message already waiting.
  std::vector<std::string> receive(int timeout_ms);
  // Also subscribes to a second channel (a recording played to this bus); its messages are kept
  // apart, for side_messages(). Throws InputError if LCM refuses.
  void listen_also(const std::string& channel);
  // The second channel's messages that came with the last receive().
  std::vector<std::string> side_messages();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kiji::detail
