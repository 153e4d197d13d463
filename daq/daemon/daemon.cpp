// pof-daqd lifecycle: see daemon.hpp.
#include "daemon.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <spdlog/spdlog.h>

#include "pof/bus/auth_key.hpp"
#include "pof/bus/open.hpp"
#include "pof/bus/error_log.hpp"
#include "pof/bus/publisher.hpp"
#include "pof/daq_status_t.hpp"
#include "pof/service/sd_notify.hpp"
#include "pof/base/errors.hpp"
#include "pof/raw_block_t.hpp"
#include "pof/lcm/utime.hpp"

namespace pof::daq {
namespace {

using pof::lcmutil::now_utime;

std::shared_ptr<const bus::auth::Key> load_key(const DaqConfig& cfg) {
  return cfg.auth_key_file.empty() ? nullptr : bus::auth::load_key_file(cfg.auth_key_file);
}

}  // namespace

const char* state_name(State s) {
  switch (s) {
    case State::kStarting: return "starting";
    case State::kStreaming: return "streaming";
    case State::kDisconnected: return "disconnected";
    case State::kFault: return "fault";
    case State::kStopping: return "stopping";
  }
  return "?";
}

Daemon::Daemon(DaqConfig cfg, std::unique_ptr<Backend> backend)
    : cfg_(std::move(cfg)),
      backend_(std::move(backend)),
      owned_lcm_(std::make_unique<lcm::LCM>(cfg_.lcm_url)),
      lcm_(owned_lcm_.get()),
      key_(load_key(cfg_)),
      queue_(static_cast<std::size_t>(cfg_.queue_blocks)) {
  bus::require_usable(*lcm_, cfg_.lcm_url);
}

Daemon::Daemon(DaqConfig cfg, std::unique_ptr<Backend> backend, lcm::LCM& bus)
    : cfg_(std::move(cfg)),
      backend_(std::move(backend)),
      lcm_(&bus),
      key_(load_key(cfg_)),
      queue_(static_cast<std::size_t>(cfg_.queue_blocks)) {
  if (!lcm_->good()) throw pof::IoError("the LCM instance given to pof-daqd's Daemon is not usable");
}

Daemon::~Daemon() { stop(); }

void Daemon::start() {
  // spdlog creates its default logger on first use; both threads log, so create it here, before
  // they start (ThreadSanitizer saw the two first uses race inside the uninstrumented libspdlog
  // when a process had not logged before start(), as the functional tests do).
  (void)spdlog::default_logger_raw();
  pub_thread_ = std::thread([this] { publisher_main(); });
  acq_thread_ = std::thread([this] { acquisition_main(); });
}

void Daemon::stop() {
  stop_.store(true);
  if (acq_thread_.joinable()) acq_thread_.join();
  publisher_stop_.store(true);
  wake_.ring();
  if (pub_thread_.joinable()) pub_thread_.join();
}

void Daemon::set_state(State s, const std::string& why) {
  beat();
  {
    std::lock_guard lock(state_mu_);
    if (s == state_ && why == state_text_) return;
    state_ = s;
    state_text_ = why;
    stalled_ = false;
    state_events_.emplace_back(s, why);
  }
  spdlog::info("state {}: {}", state_name(s), why);
  wake_.ring();
}

bool Daemon::sleep_unless_stopped(int ms) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  while (std::chrono::steady_clock::now() < until) {
    if (stop_.load()) return false;
    beat();  // waiting on purpose is progress: the watchdog stays fed through a back-off
    std::this_thread::sleep_for(std::chrono::milliseconds(std::min(ms, 20)));
  }
  return !stop_.load();
}

void Daemon::acquisition_main() {
  std::unique_ptr<Acquisition> acq;
  bool had_session = false;
  bool lost_session = false;
  int failures = 0;  // consecutive attempts that ended without a scan: the retry back-off
  while (!stop_.load()) {
    set_state(State::kStarting, "opening " + cfg_.device_kind);
    std::string why;
    const OpenStatus st = open_backend(why);
    if (st != OpenStatus::kOk) {
      set_state(st == OpenStatus::kAbsent ? State::kDisconnected : State::kFault, why);
      // An absent device is polled at the plain interval (it is plugged in by a person); a
      // faulty one backs off so that a device we cannot talk to is not re-initialised in a loop.
      if (!sleep_unless_stopped(st == OpenStatus::kAbsent ? cfg_.retry_ms : retry_delay_ms(failures++))) break;
      continue;
    }
    if (!acq) {  // first open: the device's real rate is known now
      acq = std::make_unique<Acquisition>(cfg_, backend_->device_scan_rate_hz(), queue_,
                                          counters_, wake_);
      published_rate_hz_.store(acq->published_rate_hz());
    }
    {
      std::lock_guard lock(state_mu_);
      identity_ = backend_->identity();  // serial read at open (control path)
    }
    if (lost_session) counters_.reconnects.fetch_add(1);
    had_session = true;
    // `streaming` is published by the publisher once scans arrive (watch_streaming).
    const std::int64_t scans_before = counters_.scans.load();
    armed_scans_.store(scans_before);
    set_state(State::kStarting, "configured " + cfg_.device_kind + ", waiting for scans");
    const StreamEnd end = stream_backend(*acq, why);
    {
      std::lock_guard lock(state_mu_);
      armed_scans_.store(-1);
    }
    backend_->close();
    if (end == StreamEnd::kStopped) {
      if (!stop_.load()) set_state(State::kStopping, why);  // e.g. a finite simulator scenario
      break;
    }
    lost_session = had_session;
    if (counters_.scans.load() > scans_before) failures = 0;  // it streamed: start over
    if (end == StreamEnd::kDisconnected) {
      set_state(State::kDisconnected, why);
      if (!sleep_unless_stopped(cfg_.retry_ms)) break;
    } else {
      set_state(State::kFault, why);
      if (!sleep_unless_stopped(retry_delay_ms(failures++))) break;
    }
  }
  backend_->close();
  if (stop_.load()) set_state(State::kStopping, "stopped on request");
  acquisition_done_.store(true);
}

// open() and stream() promise not to throw (backend.hpp). One that does anyway (a bug, or
// std::bad_alloc while building a message) fails that attempt like a device fault: the state says
// so and the daemon retries with back-off, instead of std::terminate taking the service down
// without a last status.
OpenStatus Daemon::open_backend(std::string& why) {
  try {
    return backend_->open(why);
  } catch (const std::exception& e) {
    why = cfg_.device_kind + ": opening failed: " + e.what();
  } catch (...) {
    why = cfg_.device_kind + ": opening failed: an exception of unknown type";
  }
  return OpenStatus::kFault;
}

StreamEnd Daemon::stream_backend(ScanSink& sink, std::string& why) {
  try {
    return backend_->stream(sink, stop_, why);
  } catch (const std::exception& e) {
    why = cfg_.device_kind + ": streaming failed: " + e.what();
  } catch (...) {
    why = cfg_.device_kind + ": streaming failed: an exception of unknown type";
  }
  return StreamEnd::kError;
}

int Daemon::retry_delay_ms(int failures) const {
  // retry_ms, doubling per consecutive failure, at most 30 s (or retry_ms when that is longer).
  const std::int64_t cap = std::max<std::int64_t>(cfg_.retry_ms, 30000);
  std::int64_t d = cfg_.retry_ms;
  for (int i = 0; i < failures && d < cap; ++i) d *= 2;
  return static_cast<int>(std::min(d, cap));
}

void Daemon::watch_streaming() {
  {
    // Checked and changed under the lock the acquisition thread holds when it ends a session
    // (armed_scans_ = -1), so a session that just failed is never reported as streaming.
    std::lock_guard lock(state_mu_);
    const std::int64_t armed = armed_scans_.load();
    if (state_ != State::kStarting || armed < 0 || counters_.scans.load() <= armed) return;
    state_ = State::kStreaming;
    state_text_ = "streaming from " + cfg_.device_kind;
    state_events_.emplace_back(state_, state_text_);
  }
  spdlog::info("state {}: {}", state_name(State::kStreaming), "streaming from " + cfg_.device_kind);
}

void Daemon::watch_stall(const Liveness& live, Liveness::Clock::time_point now) {
  using std::chrono::duration_cast;
  using std::chrono::milliseconds;
  std::string stalled_text;
  {
    // Under the lock the acquisition thread holds when it ends a session and sets a state, so a
    // state it sets is never overwritten by a stall verdict about a session that is over.
    std::lock_guard lock(state_mu_);
    const std::int64_t armed = armed_scans_.load();
    if (armed < 0) return;
    if (!stalled_) {
      if (state_ != State::kStreaming || !live.scans_stalled(now)) return;
      stalled_ = true;
      stalled_scans_ = live.scans();
      state_ = State::kFault;
      state_text_ = "acquisition stalled: no scans from " + cfg_.device_kind + " for " +
                    std::to_string(duration_cast<milliseconds>(live.since_scans(now)).count()) +
                    " ms (stall bound " + std::to_string(live.stall().count()) + " ms)";
      state_events_.emplace_back(state_, state_text_);
      stalled_text = state_text_;
    } else {
      if (state_ != State::kFault || live.scans() <= stalled_scans_) return;
      stalled_ = false;
      state_ = State::kStreaming;
      state_text_ = "streaming from " + cfg_.device_kind;
      state_events_.emplace_back(state_, state_text_);
    }
  }
  if (!stalled_text.empty()) {
    spdlog::warn("state {}: {}", state_name(State::kFault), stalled_text);
  } else {
    spdlog::info("state {}: streaming from {} again (scans resumed after a stall)", state_name(State::kStreaming),
                 cfg_.device_kind);
  }
}

std::string Daemon::probe_line() {
  std::lock_guard lock(state_mu_);
  char ids[32];
  std::snprintf(ids, sizeof ids, "%04x:%04x", identity_.vendor_id, identity_.product_id);
  const std::string variant = describe_variant(counters_.variant.load());
  return cfg_.device_kind + " " + ids + (identity_.serial.empty() ? "" : " serial " + identity_.serial) +
         ": " + state_name(state_) + " (" + state_text_ + "); scans " +
         std::to_string(counters_.scans.load()) + "; usb_errors " + std::to_string(counters_.usb_errors.load()) +
         "; padding_set " + std::to_string(counters_.padding_set.load()) + "; protocol variant: " +
         (variant.empty() ? "unknown" : variant);
}

bool Daemon::variant_known() const {
  const std::uint32_t v = counters_.variant.load();
  return counters_.scans.load() > 0 && v != 0 && (v & kVariantOrderUndecided) == 0U;
}

pof::daq_status_t Daemon::status(State state, const std::string& text) {
  pof::daq_status_t s;
  s.utime = now_utime();
  s.sensor_id = cfg_.sensor_id;
  s.device_kind = cfg_.device_kind;
  {
    std::lock_guard lock(state_mu_);
    s.vendor_id = identity_.vendor_id;
    s.product_id = identity_.product_id;
    s.serial = identity_.serial;
  }
  s.state = static_cast<std::int8_t>(state);
  s.state_text = text;
  const double real_rate = published_rate_hz_.load();
  s.scan_rate_hz = real_rate > 0 ? real_rate : cfg_.published_rate_hz();
  s.n_channels = static_cast<std::int16_t>(cfg_.channels().size());
  s.scans = counters_.scans.load();
  s.blocks = counters_.blocks.load();
  s.dropped_scans = counters_.dropped_scans.load();
  s.usb_errors = counters_.usb_errors.load();
  s.overruns = counters_.overruns.load();
  s.reconnects = counters_.reconnects.load();
  s.protocol_variant = describe_variant(counters_.variant.load());
  s.padding_set = counters_.padding_set.load();
  s.publish_failures = counters_.publish_failures.load();
  return s;
}

void Daemon::publisher_main() {
  const std::vector<ChannelMap> chans = cfg_.channels();
  const auto n_ch = static_cast<std::int16_t>(chans.size());
  const std::string raw_channel = cfg_.raw_channel();
  const std::string status_channel = cfg_.status_channel();

  // Preallocated message and encode buffer: lcm-gen encodes by the count fields, so the volts
  // rows are sized once to the maximum and n_scans says how many are used (no allocation here).
  pof::raw_block_t msg;
  msg.sensor_id = cfg_.sensor_id;
  msg.n_channels = n_ch;
  for (const auto& c : chans) {
    msg.channel_names.push_back(c.name);
    msg.channel_units.push_back("V");
  }
  msg.volts.assign(kMaxBlockScans, std::vector<float>(chans.size(), 0.0F));
  msg.n_scans = static_cast<std::int32_t>(kMaxBlockScans);
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  // Everything goes out through one Publisher: liblcm's publish(), signed in the authenticated mode.
  pof::bus::Publisher pub(*lcm_, key_);
  if (key_)
    spdlog::info("authenticated mode: bus key {} (key id {}); publishing as sender {:016x}", cfg_.auth_key_file,
                 bus::auth::key_id_hex(key_->id()), pub.signer()->sender_id());
  std::int64_t seq = 0;
  std::int64_t status_seq = 0;
  const bool simulated = cfg_.device_kind.rfind("sim:", 0) == 0;
  {
    std::lock_guard lock(state_mu_);
    identity_ = backend_->identity();  // before the first open: configured values
  }

  // A message LCM refuses is counted (published in the next status; its seq is skipped) and
  // logged: the first per channel in full, then a count every 10 s. The lines are made here.
  pof::bus::ErrorLog errors([](const std::string& line) { spdlog::warn("{}", line); });
  const auto refusal = [&](const std::string& channel, const char* type) {
    return "LCM refused to publish a " + std::string(type) + " on " + channel + " (" + cfg_.lcm_url +
           (key_ ? "; or it could not be signed" : "") + "; counted in publish_failures)";
  };
  const std::string raw_refused = refusal(raw_channel, "raw_block_t");
  const std::string status_refused = refusal(status_channel, "daq_status_t");
  auto refused = [&](const std::string& channel, const std::string& line) {
    counters_.publish_failures.fetch_add(1, std::memory_order_relaxed);
    errors.note(channel, line, now_utime());
  };
  auto publish_status = [&](State state, const std::string& text) {
    pof::daq_status_t s = status(state, text);
    s.seq = status_seq++;
    if (pub.publish(status_channel, s) != 0) refused(status_channel, status_refused);
  };

  // The state changes since the last call (into `events`) and the state now, under its lock.
  std::deque<std::pair<State, std::string>> events;
  State state{};
  std::string text;
  auto take_state = [&] {
    std::lock_guard lock(state_mu_);
    events.clear();
    events.swap(state_events_);
    state = state_;
    text = state_text_;
  };

  const auto period = std::chrono::duration<double>(cfg_.status_period_s);
  auto next_status = std::chrono::steady_clock::now();
  // systemd (Type=notify, WatchdogSec): ready once publishing (a disconnected device is a state we
  // publish, not a failure to start). The watchdog is fed from this loop, which turns at least
  // every 50 ms, and only while the acquisition thread makes progress (scans, or its state machine
  // turning): a hung publisher or a hung acquisition thread gets the daemon restarted.
  const int stall_ms = stall_bound_ms(cfg_, cfg_.scan_rate_hz);
  const int grace_ms = watchdog_grace_ms(cfg_, stall_ms);
  Liveness live(std::chrono::milliseconds(stall_ms), std::chrono::milliseconds(grace_ms),
                std::chrono::steady_clock::now());
  spdlog::debug("stall bound {} ms; watchdog fed while the acquisition thread progressed within {} ms", stall_ms,
                grace_ms);
  pof::service::ServiceNotifier notifier;
  notifier.ready("publishing " + raw_channel + " and " + status_channel);
  std::uint32_t logged_variant = 0;
  std::int64_t late_run = 0;      // consecutive blocks published FLAG_LATE
  std::int64_t late_max_us = 0;   // the oldest of them [us]
  bool starved_logged = false;    // the watchdog is not being fed (logged once per episode)
  for (;;) {
    {
      const auto now = std::chrono::steady_clock::now();
      live.observe(now, counters_.scans.load(), heartbeat_.load(std::memory_order_relaxed));
      if (live.alive(now)) {
        notifier.watchdog_if_due();
        starved_logged = false;
      } else if (!starved_logged) {
        starved_logged = true;
        spdlog::error("the acquisition thread made no progress for more than {} ms: no longer feeding the watchdog", grace_ms);
      }
    }
    (void)wake_.wait_until(
        std::min(next_status, std::chrono::steady_clock::now() + std::chrono::milliseconds(50)));
    live.observe(std::chrono::steady_clock::now(), counters_.scans.load(), heartbeat_.load(std::memory_order_relaxed));
    watch_streaming();
    watch_stall(live, std::chrono::steady_clock::now());
    if (const std::uint32_t v = counters_.variant.load(); v != logged_variant) {
      logged_variant = v;  // the first user with hardware reads this (docs/hardware-bringup.md)
      spdlog::info("{}: protocol variant: {}", cfg_.device_kind, describe_variant(v));
    }
    while (Block* b = queue_.front()) {
      msg.utime = b->utime;
      msg.seq = seq++;
      msg.first_scan = b->first_scan;
      msg.scan_rate_hz = published_rate_hz_.load();
      msg.n_scans = b->n_scans;
      msg.flags = b->flags | (simulated ? int32_t{pof::raw_block_t::FLAG_SIMULATED} : 0);
      for (std::int32_t k = 0; k < b->n_scans; ++k) {
        for (std::size_t c = 0; c < chans.size(); ++c) {
          msg.volts[static_cast<std::size_t>(k)][c] =
              b->volts[static_cast<std::size_t>(k) * chans.size() + c];
        }
      }
      queue_.pop();
      msg.publish_utime = now_utime();
      // A block handed over long after its scans were taken (the backlog of a stalled acquisition
      // thread, or a publisher that fell behind) is old data: flagged, so that no consumer takes
      // it as the current state of the knee. Its timestamps stay those of the scans.
      // Judged on the published fields themselves (publish_utime against the newest scan's time),
      // so a consumer can check the flag; a forward step of the host clock while streaming ages
      // the timestamps as much and is flagged too.
      const std::int64_t newest_scan =
          msg.scan_rate_hz > 0 ? msg.utime + std::llround(static_cast<double>(msg.n_scans - 1) * 1e6 / msg.scan_rate_hz)
                               : msg.utime;
      if (block_is_late(newest_scan, msg.publish_utime, stall_ms)) {
        msg.flags |= int32_t{pof::raw_block_t::FLAG_LATE};
        if (late_run++ == 0)
          spdlog::warn("raw blocks held up by {} ms or more: published flagged FLAG_LATE",
                       (msg.publish_utime - newest_scan) / 1000);
        late_max_us = std::max(late_max_us, msg.publish_utime - newest_scan);
      } else if (late_run > 0) {
        spdlog::info("{} raw blocks published flagged FLAG_LATE (the oldest {} ms old); blocks are current again",
                     late_run, late_max_us / 1000);
        late_run = 0;
        late_max_us = 0;
      }
      const int len = msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
      if (len <= 0) {
        // The buffer is sized for the largest block the backend may queue: a bug, not the bus's doing.
        refused(raw_channel, "could not encode a raw_block_t of " + std::to_string(msg.n_scans) + " scans x " +
                                 std::to_string(chans.size()) + " channels for " + raw_channel + " into " +
                                 std::to_string(buf.size()) + " bytes (counted in publish_failures)");
      } else if (pub.publish(raw_channel, buf.data(), static_cast<std::size_t>(len)) != 0) {
        refused(raw_channel, raw_refused);
      }
      counters_.blocks.fetch_add(1, std::memory_order_relaxed);
    }
    take_state();
    for (const auto& [st, why] : events) publish_status(st, why);
    errors.tick(now_utime());
    const auto now = std::chrono::steady_clock::now();
    if (now >= next_status) {
      if (events.empty()) publish_status(state, text);
      next_status += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
      if (next_status < now) next_status = now;
    }
    if (publisher_stop_.load() && queue_.front() == nullptr) {
      // stop() joined the acquisition thread before raising publisher_stop_, but its last state
      // ("stopped on request") may have come after this round's swap above: read it again, or the
      // final status carries the state before it (seen as a missing "stopped on request").
      take_state();
      for (const auto& [st, why] : events)
        if (st != state || why != text) publish_status(st, why);
      notifier.stopping("stopping");
      publish_status(state, text);  // final state (stopping) with the final counters
      break;
    }
  }
}

}  // namespace pof::daq
