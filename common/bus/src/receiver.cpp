#include "pof/bus/receiver.hpp"

#include "pof/bus/open.hpp"

#include <lcm/lcm-cpp.hpp>

#include <cctype>
#include <exception>
#include <stdexcept>

#include "pof/base/errors.hpp"
#include "pof/bus/auth_key.hpp"

namespace pof::bus {
namespace {

// A channel name as a regex matching only itself: liblcm subscribes by GRegex (PCRE), where a
// backslash before a non-alphanumeric character makes it literal.
std::string literal_regex(const std::string& channel) {
  std::string r;
  for (const char c : channel) {
    if (std::isalnum(static_cast<unsigned char>(c)) == 0 && c != '_') r += '\\';
    r += c;
  }
  return r;
}

// Messages taken per handle() call on the liblcm path, like UdpmReceiver's batch bound.
constexpr int kMaxLcmMessagesPerHandle = 1024;

}  // namespace

std::string ReceiveError::describe() const {
  std::string s(channel);
  if (kind == Kind::kDecode && signed_without_key)
    return s + ": " + decode.describe() +
           "; the message is signed (authenticated mode) and this process has no bus key: give it "
           "--auth-key-file or $" + auth::kKeyFileEnv + " (docs/deployment.md, \"Authenticated mode\")";
  if (kind == Kind::kDecode) return s + ": " + decode.describe();
  if (kind == Kind::kAuth) return s + ": " + auth.describe();
  constexpr std::size_t kMaxWhat = 200;  // bounded: a handler's message may quote input
  return s + ": handler failed: " + std::string(what.substr(0, kMaxWhat));
}

bool Receiver::open_direct(const std::string& url) {
  if (url.rfind("udpm://", 0) != 0 || opt_.udpm_via_liblcm) return false;
  udpm_ = std::make_unique<UdpmReceiver>(url, opt_.udpm);
  sink_ = [this](int64_t utime, std::string_view channel, const unsigned char* data, uint32_t size) {
    dispatch(channel, data, size, utime);
  };
  return true;
}

Receiver::Receiver(lcm::LCM& lc, const std::string& url, ReceiverOptions options) : lc_(&lc), opt_(options) {
  if (opt_.auth_key) verifier_ = std::make_unique<auth::Verifier>(opt_.auth_key, opt_.auth);
  if (!open_direct(url)) require_usable(*lc_, url);
}

Receiver::Receiver(const std::string& url, ReceiverOptions options) : opt_(options) {
  if (opt_.auth_key) verifier_ = std::make_unique<auth::Verifier>(opt_.auth_key, opt_.auth);
  if (open_direct(url)) return;
  own_lc_ = std::make_unique<lcm::LCM>(url);
  lc_ = own_lc_.get();
  require_usable(*lc_, url);
}

Receiver::~Receiver() {
  // Before own_lc_ (declared first, destroyed last) goes.
  for (const auto& h : hooks_)
    if (h->sub != nullptr) lcm_unsubscribe(lc_->getUnderlyingLCM(), h->sub);
}

void Receiver::add_lcm_subscription(const std::string& regex, Raw* raw) {
  auto hook = std::make_unique<Hook>();
  hook->rx = this;
  hook->raw = raw;
  hook->sub = lcm_subscribe(lc_->getUnderlyingLCM(), regex.c_str(), &Receiver::on_lcm_message, hook.get());
  if (hook->sub == nullptr) throw pof::ConfigError("channel '" + regex + "': LCM refused the subscription");
  lcm_subscription_set_queue_capacity(hook->sub, opt_.lcm_queue_capacity);
  hooks_.push_back(std::move(hook));
}

void Receiver::add_typed(const std::string& channel, std::unique_ptr<TypedBase> sub, bool layout_ok,
                         std::string_view type) {
  if (!layout_ok)
    throw std::logic_error(std::string(type) +
                           ": pof/lcm/decode.hpp's layout does not match the generated type (update it with the .lcm file)");
  auto [it, fresh] = channels_.try_emplace(channel);
  it->second.subs.push_back(std::move(sub));
  if (fresh && !udpm_) add_lcm_subscription(literal_regex(channel), nullptr);
}

void Receiver::subscribe_raw(const std::string& regex, RawHandler fn) {
  auto raw = std::make_unique<Raw>();
  raw->filter = std::make_unique<ChannelFilter>(regex);  // throws ConfigError on a bad pattern
  raw->fn = std::move(fn);
  if (!udpm_) add_lcm_subscription(regex, raw.get());
  raw_.push_back(std::move(raw));
}

void Receiver::on_lcm_message(const lcm_recv_buf_t* rbuf, const char* channel, void* hook) {
  // liblcm's C callback: nothing may propagate out of here (authentic() and deliver_* are noexcept).
  const auto* h = static_cast<const Hook*>(hook);
  Receiver& rx = *h->rx;
  const Delivery d{channel, rbuf->recv_utime};
  const auto* data = static_cast<const unsigned char*>(rbuf->data);
  std::size_t size = rbuf->data_size;
  if (rx.verifier_) {
    if (rx.lcm_verdict_.generation != rx.lcm_generation_) {  // the first subscription to see this message
      rx.lcm_verdict_.generation = rx.lcm_generation_;
      rx.lcm_verdict_.ok = rx.authentic(d.channel, data, size, d.recv_utime);
      rx.lcm_verdict_.size = size;
    }
    if (!rx.lcm_verdict_.ok) return;
    size = rx.lcm_verdict_.size;
  }
  if (h->raw != nullptr) {
    rx.deliver_raw(*h->raw, d, data, size);
    return;
  }
  const auto it = rx.channels_.find(d.channel);
  if (it != rx.channels_.end()) rx.deliver_typed(it->second, d, data, size);
}

bool Receiver::raw_matches(Raw& r, std::string_view channel) noexcept {
  try {
    return r.filter->matches(channel);  // may allocate its verdict cache
  } catch (...) {
    return false;
  }
}

bool Receiver::authentic(std::string_view channel, const unsigned char* data, std::size_t& size, int64_t utime) noexcept {
  const auth::Verification v = verifier_->verify(channel, data, size, auth::counter_time(utime));
  if (v.ok()) {
    size = v.message_size;
    return true;
  }
  if (const auto it = channels_.find(channel); it != channels_.end()) ++it->second.stats.auth_dropped;
  ReceiveError e;
  e.kind = ReceiveError::Kind::kAuth;
  e.channel = channel;
  e.auth = v;
  report(e);
  return false;
}

void Receiver::dispatch(std::string_view channel, const unsigned char* data, std::size_t size, int64_t utime) noexcept {
  const auto typed = channels_.find(channel);
  bool wanted = typed != channels_.end();
  for (std::size_t i = 0; !wanted && i < raw_.size(); ++i) wanted = raw_matches(*raw_[i], channel);
  if (!wanted) return;  // nobody's: not verified, not counted
  if (verifier_ && !authentic(channel, data, size, utime)) return;
  const Delivery d{channel, utime};
  if (typed != channels_.end()) deliver_typed(typed->second, d, data, size);
  for (const auto& r : raw_)
    if (raw_matches(*r, channel)) deliver_raw(*r, d, data, size);
}

void Receiver::deliver_typed(Channel& c, const Delivery& d, const unsigned char* data, std::size_t size) noexcept {
  ++c.stats.messages;
  for (const auto& sub : c.subs) {
    const lcmutil::DecodeResult r = sub->decode(data, size);
    if (!r) {
      ++c.stats.decode_errors;
      ReceiveError e;
      e.kind = ReceiveError::Kind::kDecode;
      e.channel = d.channel;
      e.decode = r;
      e.signed_without_key = !verifier_ && auth::parse_trailer(data, size).has_value();
      report(e);
      continue;
    }
    try {
      sub->call(d);
    } catch (...) {
      ++c.stats.handler_errors;
      report_handler_error(d.channel, std::current_exception());
    }
  }
}

void Receiver::deliver_raw(Raw& r, const Delivery& d, const unsigned char* data, std::size_t size) noexcept {
  try {
    r.fn(d, data, size);
  } catch (...) {
    report_handler_error(d.channel, std::current_exception());
  }
}

void Receiver::report_handler_error(std::string_view channel, std::exception_ptr error) noexcept {
  ReceiveError e;
  e.kind = ReceiveError::Kind::kHandler;
  e.channel = channel;
  try {
    std::rethrow_exception(std::move(error));
  } catch (const std::exception& ex) {
    e.what = ex.what();
  } catch (...) {
    e.what = "an exception that is not a std::exception";
  }
  report(e);
}

void Receiver::report(const ReceiveError& e) noexcept {
  if (!on_error_) return;
  try {
    on_error_(e);
  } catch (...) {  // an error handler that fails (e.g. out of memory while logging) loses the report only
  }
}

int Receiver::handle(int timeout_ms) noexcept {
  if (udpm_) return udpm_->receive(timeout_ms, sink_);
  try {
    ++lcm_generation_;  // one message per call (see lcm_verdict_)
    int n = lc_->handleTimeout(timeout_ms);
    if (n <= 0) return n < 0 ? -1 : 0;
    while (n < kMaxLcmMessagesPerHandle) {
      ++lcm_generation_;
      if (lc_->handleTimeout(0) <= 0) break;
      ++n;
    }
    return n;
  } catch (...) {  // liblcm's C++ wrapper does not throw; kept total regardless
    return -1;
  }
}

int Receiver::fd() const { return udpm_ ? udpm_->fd() : lc_->getFileno(); }

ReceiverStats Receiver::stats() const {
  ReceiverStats s;
  if (udpm_) {
    s.datagrams = udpm_->datagrams();
    s.malformed_datagrams = udpm_->malformed();
    s.incomplete_messages = udpm_->incomplete_messages();
  }
  for (const auto& [name, c] : channels_) {
    s.decode_errors += c.stats.decode_errors;
    s.handler_errors += c.stats.handler_errors;
  }
  if (verifier_) {
    s.authenticated = true;
    s.auth_unsigned = verifier_->count(auth::Verdict::kUnsigned);
    s.auth_bad_mac = verifier_->count(auth::Verdict::kBadMac);
    s.auth_stale = verifier_->count(auth::Verdict::kStale);
    s.auth_replayed = verifier_->count(auth::Verdict::kReplayed);
  }
  return s;
}

ChannelStats Receiver::channel_stats(std::string_view channel) const {
  const auto it = channels_.find(channel);
  return it == channels_.end() ? ChannelStats{} : it->second.stats;
}

}  // namespace pof::bus
