#include "pof/dash/model.hpp"

#include <algorithm>
#include <cmath>

#include "pof/bus/channels.hpp"
#include "pof/lcm/decode.hpp"
#include "pof/lcm/json.hpp"
#include "pof/spy/monitor.hpp"

namespace pof::dash {
namespace {

using nlohmann::json;

using lcmutil::json_fields;
using lcmutil::json_number;

double age_s(int64_t now, int64_t then) { return then == 0 ? -1.0 : static_cast<double>(now - then) * 1e-6; }

// The messages' numbers (pof/lcm/json.hpp), with the names and texts the page shows.
json angle_json(const pof::angle_t& a) {
  json j = json_fields(a);
  j["phase_name"] = spy::phase_name(a.phase);
  j["quality_names"] = spy::quality_names(a.quality);
  return j;
}

json daq_json(const pof::daq_status_t& d) {
  json j = json_fields(d);
  j["state_name"] = spy::daq_state_name(d.state);
  j["state_text"] = d.state_text;
  j["device_kind"] = d.device_kind;
  j["serial"] = d.serial;
  return j;
}

json compensator_json(const pof::compensator_status_t& c) {
  json j = json_fields(c);
  j["calibration_path"] = c.calibration_path;
  j["calibration_sensor_id"] = c.calibration_sensor_id;
  j["calibration_date"] = c.calibration_date;
  j["last_error"] = c.last_error;
  return j;
}

}  // namespace

Model::Model(ModelSettings s) : settings_(s) {
  settings_.display_hz = std::clamp(settings_.display_hz, 1.0, 1000.0);
  settings_.window_s = std::clamp(settings_.window_s, 1.0, 600.0);
  settings_.cycles_kept = std::clamp<std::size_t>(settings_.cycles_kept, 1, 10'000);
  bucket_us_ = static_cast<int64_t>(std::llround(1e6 / settings_.display_hz));
  ring_capacity_ = static_cast<std::size_t>(std::ceil(settings_.window_s * settings_.display_hz));
}

Model::Sensor* Model::sensor(const std::string& id) noexcept {
  if (auto it = sensors_.find(id); it != sensors_.end()) return &it->second;
  if (sensors_.size() >= kMaxSensors || !bus::sensor_id_problem(id).empty()) {
    ++ignored_sensors_;
    return nullptr;
  }
  try {
    Sensor& s = sensors_[id];
    s.ring.resize(ring_capacity_);
    s.cycles.resize(settings_.cycles_kept);
    return &s;
  } catch (...) {  // out of memory: the message is dropped, the bus goes on
    sensors_.erase(id);
    ++ignored_sensors_;
    return nullptr;
  }
}

void Model::on_message(std::string_view channel, const void* data, std::size_t size, int64_t recv_utime) noexcept {
  const auto name = bus::parse_channel(channel);
  if (!name || name->stream == bus::Stream::kRaw) return;
  Sensor* s = sensor(name->sensor_id);
  if (s == nullptr) return;
  // The bounded decoder (pof/lcm/decode.hpp): a hostile length never becomes an
  // allocation.
  switch (name->stream) {
    case bus::Stream::kAngle: {
      pof::angle_t a;
      if (!lcmutil::decode(data, size, a)) break;
      add_angle(*s, a, recv_utime);
      return;
    }
    case bus::Stream::kStats: {
      pof::cycle_stats_t c;
      if (!lcmutil::decode(data, size, c)) break;
      s->cycles[s->cycles_total % s->cycles.size()] = c;
      ++s->cycles_total;
      return;
    }
    case bus::Stream::kDaqStatus: {
      pof::daq_status_t d;
      if (!lcmutil::decode(data, size, d)) break;
      s->daq = std::move(d);
      s->daq_recv_utime = recv_utime;
      return;
    }
    case bus::Stream::kCompensatorStatus: {
      pof::compensator_status_t c;
      if (!lcmutil::decode(data, size, c)) break;
      s->compensator = std::move(c);
      s->compensator_recv_utime = recv_utime;
      return;
    }
    case bus::Stream::kRaw:
      return;
  }
  ++s->decode_errors;
}

void Model::add_angle(Sensor& s, const pof::angle_t& a, int64_t recv_utime) {
  if (epoch_utime_ == 0) epoch_utime_ = a.utime;
  ++s.angles;
  if (a.quality != 0) ++s.flagged;
  if (s.last_seq >= 0 && a.seq > s.last_seq + 1) s.missing += static_cast<uint64_t>(a.seq - s.last_seq - 1);
  s.last_seq = a.seq;
  s.angle = a;
  s.angle_recv_utime = recv_utime;
  // A scan time outside the open bucket (later, or earlier after a publisher
  // restart) closes it.
  if (s.pending && (a.utime >= s.bucket_end || a.utime < s.pending->utime)) close_bucket(s);
  const int32_t quality = s.pending ? s.pending->quality | a.quality : a.quality;
  if (!s.pending) s.bucket_end = (a.utime / bucket_us_ + 1) * bucket_us_;
  s.pending = Point{a.utime, a.angle_deg, a.angle_uncomp_deg, a.angle_ref_deg, a.angle_sigma_deg, quality};
}

void Model::close_bucket(Sensor& s) {
  if (!s.pending) return;
  s.ring[s.points % s.ring.size()] = *s.pending;
  ++s.points;
  s.pending.reset();
}

void Model::tick(int64_t now_utime) {
  for (auto& [id, s] : sensors_) {
    // The scan clock and this host's differ by the bus latency: a bucket is
    // closed once no angle arrived for a bucket's time, whatever the clocks
    // say.
    if (s.pending && now_utime - s.angle_recv_utime >= bucket_us_) close_bucket(s);
    if (s.rate_utime == 0) {
      s.rate_utime = now_utime;
      s.rate_angles = s.angles;
    } else if (now_utime - s.rate_utime >= 1'000'000) {
      s.rate_hz = static_cast<double>(s.angles - s.rate_angles) * 1e6 / static_cast<double>(now_utime - s.rate_utime);
      s.rate_utime = now_utime;
      s.rate_angles = s.angles;
    }
  }
}

uint64_t Model::points_added(std::string_view sensor_id) const {
  const auto it = sensors_.find(sensor_id);
  return it == sensors_.end() ? 0 : it->second.points;
}

json Model::sensor_frame(const std::string& id, const Sensor& s, Cursor& c, int64_t now) const {
  json f;
  f["id"] = id;
  // Points: from the browser's cursor, or the whole ring when it is new or fell
  // out of it.
  const uint64_t oldest = s.points > s.ring.size() ? s.points - s.ring.size() : 0;
  auto [pit, fresh] = c.next_point.try_emplace(id, 0);
  const bool reset = fresh || pit->second < oldest || pit->second > s.points;
  const uint64_t from = reset ? oldest : pit->second;
  json t = json::array(), a = json::array(), u = json::array(), r = json::array(), sg = json::array(),
       q = json::array();
  for (uint64_t i = from; i < s.points; ++i) {
    const Point& p = s.ring[i % s.ring.size()];
    t.push_back(std::round(static_cast<double>(p.utime - epoch_utime_) * 1e-3) * 1e-3);  // ms resolution
    a.push_back(json_number(p.angle_deg));
    u.push_back(json_number(p.uncomp_deg));
    r.push_back(json_number(p.ref_deg));
    sg.push_back(json_number(p.sigma_deg));
    q.push_back(p.quality);
  }
  pit->second = s.points;
  f["reset"] = reset;
  f["points"] = {{"t", std::move(t)},   {"angle", std::move(a)},  {"uncomp", std::move(u)},
                 {"ref", std::move(r)}, {"sigma", std::move(sg)}, {"quality", std::move(q)}};

  // Cycles the browser has not seen, oldest first (at most the cycles kept).
  auto [cit, cfresh] = c.next_cycle.try_emplace(id, 0);
  const uint64_t ckept = s.cycles.size();
  const uint64_t cfirst = std::max(cit->second, s.cycles_total > ckept ? s.cycles_total - ckept : 0);
  json cycles = json::array();
  for (uint64_t i = cfirst; i < s.cycles_total; ++i)
    cycles.push_back(json_fields(s.cycles[i % ckept]));
  cit->second = s.cycles_total;
  f["cycles"] = std::move(cycles);
  f["cycles_total"] = s.cycles_total;

  f["latest"] = s.angle ? angle_json(*s.angle) : json(nullptr);
  f["angle_age_s"] = age_s(now, s.angle_recv_utime);
  f["angles"] = s.angles;
  f["angles_flagged"] = s.flagged;
  f["angles_missing"] = s.missing;
  f["angle_rate_hz"] = s.rate_hz;
  f["decode_errors"] = s.decode_errors;
  f["daq"] = s.daq ? daq_json(*s.daq) : json(nullptr);
  f["daq_age_s"] = age_s(now, s.daq_recv_utime);
  f["compensator"] = s.compensator ? compensator_json(*s.compensator) : json(nullptr);
  f["compensator_age_s"] = age_s(now, s.compensator_recv_utime);
  return f;
}

json Model::frame(Cursor& c, int64_t now_utime) const {
  json f;
  f["now_utime"] = now_utime;
  f["epoch_utime"] = epoch_utime_;
  f["window_s"] = settings_.window_s;
  f["display_hz"] = settings_.display_hz;
  json sensors = json::array();
  for (const auto& [id, s] : sensors_)
    sensors.push_back(sensor_frame(id, s, c, now_utime));
  f["sensors"] = std::move(sensors);
  f["ignored_sensors"] = ignored_sensors_;
  f["bus"] = {{"url", bus_.url},
              {"authenticated", bus_.authenticated},
              {"auth_dropped", bus_.auth_dropped},
              {"malformed_datagrams", bus_.malformed_datagrams},
              {"decode_errors", bus_.decode_errors},
              {"kernel_drops", bus_.kernel_drops},
              {"clients", bus_.clients},
              {"frames_sent", bus_.frames_sent},
              {"frames_skipped", bus_.frames_skipped}};
  return f;
}

}  // namespace pof::dash
