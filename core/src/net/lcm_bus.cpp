#include "net/lcm_bus.h"

#include "kiji/error.h"

#include <lcm/lcm.h>

namespace kiji::detail {

namespace {
// LCM drops the newest message when a subscription's queue is full (30 by default): a join's burst
// of snapshot chunks overflowed it. Deep enough for a snapshot's burst, bounded against a flood.
constexpr int kQueueMessages = 20000;
// Over this, LCM would split a message into fragments that are lost whole: the protocol never sends one.
constexpr std::size_t kMaxDatagram = 65000;
}  // namespace

struct LcmBus::Impl {
  lcm_t* lcm = nullptr;
  lcm_subscription_t* subscription = nullptr;
  lcm_subscription_t* side_subscription = nullptr;
  std::string channel;
  std::vector<std::string> inbox, side;

  static void on_message(const lcm_recv_buf_t* buffer, const char*, void* user) {
    auto* self = static_cast<Impl*>(user);
    self->inbox.emplace_back(static_cast<const char*>(buffer->data), buffer->data_size);
  }
  static void on_side_message(const lcm_recv_buf_t* buffer, const char*, void* user) {
    auto* self = static_cast<Impl*>(user);
    self->side.emplace_back(static_cast<const char*>(buffer->data), buffer->data_size);
  }
};

LcmBus::LcmBus(const std::string& url, const std::string& channel) : impl_(std::make_unique<Impl>()) {
  impl_->channel = channel;
  impl_->lcm = lcm_create(url.c_str());
  if (!impl_->lcm)
    throw InputError("could not open the LCM network '" + url +
                     "': for multicast (udpm://) the host needs a route for 224.0.0.0/4 (on one machine: "
                     "'ip route add 224.0.0.0/4 dev lo' and 'ip link set lo multicast on'), and the port "
                     "must be free for reuse; see docs/peers.md");
  impl_->subscription = lcm_subscribe(impl_->lcm, channel.c_str(), &Impl::on_message, impl_.get());
  if (!impl_->subscription) {
    lcm_destroy(impl_->lcm);
    throw InputError("could not subscribe to LCM channel '" + channel + "' on '" + url + "'");
  }
  lcm_subscription_set_queue_capacity(impl_->subscription, kQueueMessages);
}

void LcmBus::listen_also(const std::string& channel) {
  if (impl_->side_subscription || channel == impl_->channel)
    throw InputError("the LCM channel '" + channel + "' cannot be a second channel of this bus");
  impl_->side_subscription = lcm_subscribe(impl_->lcm, channel.c_str(), &Impl::on_side_message, impl_.get());
  if (!impl_->side_subscription) throw InputError("could not subscribe to LCM channel '" + channel + "'");
  lcm_subscription_set_queue_capacity(impl_->side_subscription, kQueueMessages);
}

std::vector<std::string> LcmBus::side_messages() { return std::move(impl_->side); }

LcmBus::~LcmBus() {
  if (impl_->side_subscription) lcm_unsubscribe(impl_->lcm, impl_->side_subscription);
  if (impl_->subscription) lcm_unsubscribe(impl_->lcm, impl_->subscription);
  lcm_destroy(impl_->lcm);
}

bool LcmBus::publish(const std::string& bytes) {
  if (bytes.size() > kMaxDatagram) return false;
  return lcm_publish(impl_->lcm, impl_->channel.c_str(), bytes.data(), static_cast<unsigned>(bytes.size())) == 0;
}

std::vector<std::string> LcmBus::receive(int timeout_ms) {
  impl_->inbox.clear();
  impl_->side.clear();
  if (lcm_handle_timeout(impl_->lcm, timeout_ms) > 0)
    while (lcm_handle_timeout(impl_->lcm, 0) > 0) {
    }
  return std::move(impl_->inbox);
}

}  // namespace kiji::detail
