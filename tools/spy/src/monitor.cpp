#include "pof/spy/monitor.hpp"

#include <algorithm>
#include <climits>
#include <cstdarg>
#include <cmath>
#include <cstdio>
#include <string>

#include "pof/lcm/decode.hpp"

namespace pof::spy {
namespace {

// The bounded decoder (pof/lcm/decode.hpp): a message whose lengths do not fit its size is a
// decode error, never an allocation of what it claims.
template <class T>
bool decode_into(std::optional<T>& slot, const void* data, std::size_t size) {
  T m;
  if (!lcmutil::decode(data, size, m)) return false;
  slot = std::move(m);
  return true;
}

// printf into a std::string (the screen is built from fixed-width columns).
__attribute__((format(printf, 1, 2))) std::string fmt(const char* f, ...) {
  char b[512];
  va_list ap;
  va_start(ap, f);
  const int n = std::vsnprintf(b, sizeof b, f, ap);
  va_end(ap);
  return std::string(b, n < 0 ? 0 : std::min<std::size_t>(static_cast<std::size_t>(n), sizeof b - 1));
}

std::string heading(const RenderOptions& o, const std::string& s) {
  return o.ansi ? "\x1b[1m" + s + "\x1b[0m" : s;
}

std::string fixed(double v, int prec) {
  if (std::isnan(v)) return "nan";
  return fmt("%.*f", prec, v);
}

}  // namespace

std::string quality_names(int32_t q) {
  if (q == 0) return "OK";
  static const std::pair<int32_t, const char*> kNames[] = {
      {pof::angle_t::QUALITY_REFERENCE_LOST, "REFERENCE_LOST"},
      {pof::angle_t::QUALITY_OVER_RANGE, "OVER_RANGE"},
      {pof::angle_t::QUALITY_INVALID_INPUT, "INVALID_INPUT"},
      {pof::angle_t::QUALITY_GAP, "GAP"},
      {pof::angle_t::QUALITY_VELOCITY_EXTRAPOLATED, "VELOCITY_EXTRAPOLATED"},
      {pof::angle_t::QUALITY_ANGLE_EXTRAPOLATED, "ANGLE_EXTRAPOLATED"},
      {pof::angle_t::QUALITY_SETTLING, "SETTLING"},
      {pof::angle_t::QUALITY_LATE, "LATE"}};
  std::string s;
  int32_t rest = q;
  for (const auto& [bit, name] : kNames) {
    if ((q & bit) == 0) continue;
    if (!s.empty()) s += '|';
    s += name;
    rest &= ~bit;
  }
  if (rest != 0) s += fmt("%s0x%x", s.empty() ? "" : "|", static_cast<unsigned>(rest));
  return s;
}

std::string phase_name(int8_t p) {
  switch (p) {
    case pof::angle_t::PHASE_HOLD: return "HOLD";
    case pof::angle_t::PHASE_FLEXION: return "FLEXION";
    case pof::angle_t::PHASE_EXTENSION: return "EXTENSION";
    default: return std::to_string(p);
  }
}

std::string daq_state_name(int8_t s) {
  switch (s) {
    case pof::daq_status_t::STATE_STARTING: return "STARTING";
    case pof::daq_status_t::STATE_STREAMING: return "STREAMING";
    case pof::daq_status_t::STATE_DISCONNECTED: return "DISCONNECTED";
    case pof::daq_status_t::STATE_FAULT: return "FAULT";
    case pof::daq_status_t::STATE_STOPPING: return "STOPPING";
    default: return std::to_string(s);
  }
}

void Monitor::on_message(std::string_view channel, const void* data, std::size_t size, int64_t recv_utime) {
  auto it = channels_.find(std::string(channel));
  if (it == channels_.end()) {
    if (!recorder::admit_channel(channel, channels_.size())) {
      ++total_;
      other_.note(channel, size);
      return;
    }
    it = channels_.emplace(std::string(channel), ChannelView{}).first;
    it->second.name = std::string(channel);
  }
  ChannelView& c = it->second;
  ++total_;
  ++c.count;
  c.bytes += size;
  c.last_size = size;
  c.last_recv_utime = recv_utime;
  // A signed message that reached us unverified (no key given, so the receiver did not check and
  // strip it): the LCM message is in front of its trailer (pof/bus/auth_trailer.hpp).
  if (const auto t = bus::auth::parse_trailer(static_cast<const unsigned char*>(data), size)) {
    ++c.unverified;
    size = t->message_size;
  }
  c.fingerprint = bus::fingerprint_of(data, size);
  c.type = bus::message_type_of(data, size);
  bool ok = true;
  int64_t seq = 0;
  // Every pofkit message carries a seq: decode into `slot` and take it.
  const auto take = [&](auto& slot) {
    if (!decode_into(slot, data, size)) return false;
    seq = slot->seq;
    return true;
  };
  switch (c.type) {
    case bus::MessageType::kRawBlock: ok = take(c.raw); break;
    case bus::MessageType::kAngle: ok = take(c.angle); break;
    case bus::MessageType::kCycleStats: {
      std::optional<pof::cycle_stats_t> s;
      ok = take(s);
      if (ok) {
        c.stats.push_back(*s);
        if (c.stats.size() > kStatsKept) c.stats.pop_front();
      }
      break;
    }
    case bus::MessageType::kDaqStatus: ok = take(c.status); break;
    case bus::MessageType::kCompensatorStatus: ok = take(c.compensator); break;
    case bus::MessageType::kUnknown:
      return;
  }
  if (!ok) {
    ++c.decode_errors;
    return;
  }
  c.seq.update(seq);
}

void Monitor::tick(int64_t now_utime) {
  for (auto& [name, c] : channels_) {
    c.history.emplace_back(now_utime, c.count);
    while (c.history.size() > 2 && now_utime - c.history[1].first >= 1'000'000) c.history.pop_front();
    const auto& [t0, n0] = c.history.front();
    c.rate_hz = now_utime > t0 ? static_cast<double>(c.count - n0) * 1e6 / static_cast<double>(now_utime - t0) : 0.0;
  }
}

std::string render(const Monitor& m, const RenderOptions& o) {
  std::string s;
  if (o.ansi) s += "\x1b[H\x1b[2J";
  std::string bad;  // shown only when there is some: hostile or broken traffic on the port
  if (o.malformed_datagrams > 0 || o.incomplete_messages > 0)
    bad = fmt("  malformed datagrams %llu  incomplete messages %llu", static_cast<unsigned long long>(o.malformed_datagrams),
              static_cast<unsigned long long>(o.incomplete_messages));
  s += heading(o, fmt("pof spy  %s  up %.1f s  %llu messages  kernel UDP drops %llu%s", o.url.c_str(), o.uptime_s,
                      static_cast<unsigned long long>(m.total_messages()),
                      static_cast<unsigned long long>(o.kernel_drops), bad.c_str())) +
       (o.ansi ? "   (q quits)\n" : "\n");
  if (o.authenticated)  // what the verifier dropped before anything was decoded or shown
    s += fmt("authenticated (key %s): dropped unsigned %llu  bad_mac %llu  stale %llu  replayed %llu\n",
             o.key_id.c_str(), static_cast<unsigned long long>(o.auth_unsigned),
             static_cast<unsigned long long>(o.auth_bad_mac), static_cast<unsigned long long>(o.auth_stale),
             static_cast<unsigned long long>(o.auth_replayed));
  s += "\n";
  s += heading(o, fmt("%-26s %-19s %9s %10s %7s %8s %9s %7s", "CHANNEL", "TYPE", "RATE/s", "MSGS", "SIZE", "GAPS",
                      "MISSING", "AGE s")) +
       "\n";
  for (const auto& [name, c] : m.channels()) {
    std::string type = c.type == bus::MessageType::kUnknown ? fmt("fp:%016llx", static_cast<unsigned long long>(c.fingerprint))
                                                             : bus::message_type_name(c.type);
    const double age = o.now_utime > c.last_recv_utime ? static_cast<double>(o.now_utime - c.last_recv_utime) / 1e6 : 0.0;
    std::string gaps = c.type == bus::MessageType::kUnknown ? "-" : std::to_string(c.seq.gaps);
    std::string missing = c.type == bus::MessageType::kUnknown ? "-" : std::to_string(c.seq.missing);
    s += fmt("%-26s %-19s %9.1f %10llu %7zu %8s %9s %7.2f", name.c_str(), type.c_str(), c.rate_hz,
             static_cast<unsigned long long>(c.count), c.last_size, gaps.c_str(), missing.c_str(), age);
    if (c.seq.restarts > 0) s += fmt("  restarts %llu", static_cast<unsigned long long>(c.seq.restarts));
    if (c.decode_errors > 0) s += fmt("  DECODE ERRORS %llu", static_cast<unsigned long long>(c.decode_errors));
    if (c.unverified > 0) s += fmt("  SIGNED, NOT VERIFIED %llu", static_cast<unsigned long long>(c.unverified));
    s += "\n";
  }
  if (const auto& other = m.other_channels(); other.events > 0) {
    std::string examples;
    for (const auto& e : other.examples) examples += (examples.empty() ? "" : ", ") + e;
    s += fmt("%-26s %-19s %9s %10llu %7s  not tracked: more than %zu channels (e.g. %s)\n", "(other channels)", "-",
             "-", static_cast<unsigned long long>(other.events), "-", recorder::kMaxTrackedChannels, examples.c_str());
  }

  for (const auto& [name, c] : m.channels()) {
    if (c.raw) {
      const auto& r = *c.raw;
      s += "\n" + heading(o, fmt("%s  raw block", name.c_str())) +
           fmt("  sensor_id %s  %.1f scans/s  %d scans/block  first_scan %lld  age %.1f ms%s%s%s%s\n",
               r.sensor_id.empty() ? "-" : r.sensor_id.c_str(), r.scan_rate_hz, r.n_scans,
               static_cast<long long>(r.first_scan), static_cast<double>(r.publish_utime - r.utime) / 1e3,
               (r.flags & pof::raw_block_t::FLAG_SIMULATED) != 0 ? "  SIMULATED" : "",
               (r.flags & pof::raw_block_t::FLAG_GAP) != 0 ? "  GAP" : "",
               (r.flags & pof::raw_block_t::FLAG_OVER_RANGE) != 0 ? "  OVER_RANGE" : "",
               (r.flags & pof::raw_block_t::FLAG_LATE) != 0 ? "  LATE" : "");
      std::string line = "   latest:";
      if (r.n_scans > 0 && static_cast<std::size_t>(r.n_scans) == r.volts.size()) {
        const auto& last = r.volts.back();
        for (std::size_t k = 0; k < last.size() && k < r.channel_names.size(); ++k) {
          const std::string unit = k < r.channel_units.size() ? r.channel_units[k] : "";
          line += fmt("  %s %s %s", r.channel_names[k].c_str(), fixed(static_cast<double>(last[k]), 4).c_str(), unit.c_str());
        }
      }
      s += line + "\n";
    }
    if (c.angle) {
      const auto& a = *c.angle;
      const double err = static_cast<double>(a.angle_deg) - static_cast<double>(a.angle_ref_deg);
      s += "\n" + heading(o, fmt("%s  angle", name.c_str())) +
           fmt("  %s deg  (uncomp %s)  ref %s deg  err %s deg  %s  %s rad/s  quality %s\n",
               fixed(static_cast<double>(a.angle_deg), 2).c_str(), fixed(static_cast<double>(a.angle_uncomp_deg), 2).c_str(),
               fixed(static_cast<double>(a.angle_ref_deg), 2).c_str(), fixed(err, 2).c_str(), phase_name(a.phase).c_str(),
               fixed(static_cast<double>(a.velocity_rad_s), 3).c_str(), quality_names(a.quality).c_str());
      // A 0..120 deg bar: '#' the compensated angle, '|' the reference (knee range of the paper's
      // exoskeleton tests, 0-90 deg, with headroom).
      const int bar = std::max(20, std::min(o.width - 12, 80));
      std::string b(static_cast<std::size_t>(bar), '.');
      auto pos = [bar](double deg) {
        if (std::isnan(deg)) return -1;
        const double x = std::clamp(deg / 120.0, 0.0, 1.0) * (bar - 1);
        return static_cast<int>(std::lround(x));
      };
      const int pr = pos(static_cast<double>(a.angle_ref_deg));
      const int pa = pos(static_cast<double>(a.angle_deg));
      if (pr >= 0) b[static_cast<std::size_t>(pr)] = '|';
      if (pa >= 0) b[static_cast<std::size_t>(pa)] = pa == pr ? '*' : '#';
      s += "   0 [" + b + "] 120 deg   # angle  | reference  * both\n";
    }
    if (!c.stats.empty()) {
      s += "\n" + heading(o, fmt("%s  cycle statistics (table 3 of the paper)", name.c_str())) + "\n";
      s += fmt("   %6s %9s %10s %12s %10s %12s %9s %7s\n", "cycle", "vel rad/s", "RMSE comp", "RMSE uncomp", "hyst comp",
               "hyst uncomp", "max err", "n");
      for (const auto& st : c.stats)
        s += fmt("   %6d %9.3f %10.3f %12.3f %9.2f%% %11.2f%% %9.3f %7d\n", st.cycle, static_cast<double>(st.velocity_rad_s),
                 static_cast<double>(st.rmse_comp_deg), static_cast<double>(st.rmse_uncomp_deg),
                 static_cast<double>(st.hysteresis_comp_pct), static_cast<double>(st.hysteresis_uncomp_pct),
                 static_cast<double>(st.max_error_deg), st.n_samples);
    }
    if (c.status) {
      const auto& d = *c.status;
      s += "\n" + heading(o, fmt("%s  daq status", name.c_str())) +
           fmt("  %s (%s)  %s  sensor %s  %04x:%04x %s  %.1f scans/s x %d ch\n", daq_state_name(d.state).c_str(),
               d.state_text.c_str(), d.device_kind.c_str(), d.sensor_id.empty() ? "-" : d.sensor_id.c_str(),
               static_cast<unsigned>(d.vendor_id), static_cast<unsigned>(d.product_id), d.serial.c_str(), d.scan_rate_hz,
               d.n_channels);
      s += fmt("   scans %lld  blocks %lld  dropped_scans %lld  usb_errors %lld  overruns %lld  reconnects %lld"
               "  publish_failures %lld\n",
               static_cast<long long>(d.scans), static_cast<long long>(d.blocks), static_cast<long long>(d.dropped_scans),
               static_cast<long long>(d.usb_errors), static_cast<long long>(d.overruns),
               static_cast<long long>(d.reconnects), static_cast<long long>(d.publish_failures));
    }
    if (c.compensator) {  // pof-compensatord's health: what it lost, rejected or flagged
      const auto& d = *c.compensator;
      s += "\n" + heading(o, fmt("%s  compensator status", name.c_str())) +
           fmt("  sensor %s  calibration %s (sensor %s, %s)\n", d.sensor_id.empty() ? "-" : d.sensor_id.c_str(),
               d.calibration_path.c_str(), d.calibration_sensor_id.empty() ? "-" : d.calibration_sensor_id.c_str(),
               d.calibration_date.c_str());
      s += fmt("   blocks %lld  scans %lld  lost_blocks %lld  lost_scans %lld  rejected_blocks %lld  fault_scans %lld\n",
               static_cast<long long>(d.blocks), static_cast<long long>(d.scans), static_cast<long long>(d.lost_blocks),
               static_cast<long long>(d.lost_scans), static_cast<long long>(d.rejected_blocks),
               static_cast<long long>(d.fault_scans));
      s += fmt("   angles %lld  cycles %lld  reloads %d  reload failures %d%s%s\n", static_cast<long long>(d.angles),
               static_cast<long long>(d.cycles), d.reloads, d.reload_failures,
               d.last_error.empty() ? "" : "  last error: ", d.last_error.c_str());
      s += fmt("   decode_errors %lld  malformed_datagrams %lld  duplicate_blocks %lld  publish_failures %lld\n",
               static_cast<long long>(d.decode_errors), static_cast<long long>(d.malformed_datagrams),
               static_cast<long long>(d.duplicate_blocks), static_cast<long long>(d.publish_failures));
      if (d.authenticated)
        s += fmt("   authenticated: dropped auth_unsigned %lld  auth_bad_mac %lld  auth_stale %lld  auth_replayed %lld\n",
                 static_cast<long long>(d.auth_unsigned), static_cast<long long>(d.auth_bad_mac),
                 static_cast<long long>(d.auth_stale), static_cast<long long>(d.auth_replayed));
    }
  }
  if (m.channels().empty()) s += "(no messages yet)\n";
  return s;
}

}  // namespace pof::spy
