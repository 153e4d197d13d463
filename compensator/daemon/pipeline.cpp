#include "pipeline.hpp"

#include "pof/base/errors.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace pof::compensatord {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::int8_t phase_of(core::Direction d) {
  switch (d) {
    case core::Direction::kFlexion: return pof::angle_t::PHASE_FLEXION;
    case core::Direction::kExtension: return pof::angle_t::PHASE_EXTENSION;
    case core::Direction::kHold: break;
  }
  return pof::angle_t::PHASE_HOLD;
}

constexpr std::int32_t kFaultBits =
    core::quality::kReferenceLost | core::quality::kOverRange | core::quality::kInvalidInput;

// Counters saturate: a forged seq or first_scan far ahead must not wrap them negative.
void sat_add(std::int64_t& counter, std::int64_t n) {
  if (n <= 0) return;
  counter = counter > std::numeric_limits<std::int64_t>::max() - n ? std::numeric_limits<std::int64_t>::max()
                                                                  : counter + n;
}

// Times and rates a block may carry: utime within 2^62 us (146 000 years) of the epoch and a rate
// of at least 1e-3 scans/s keep utime + k * 1e6 / rate within int64 for any k below 2^31.
constexpr std::int64_t kMaxUtime = std::int64_t{1} << 62;
constexpr double kMinScanRateHz = 1e-3;

// A calibration names the sensor it was made for (`pof calibrate --sensor-id`); the compensator of
// another sensor refuses it, unless told to take it. Either side without an id names no sensor.
void require_this_sensor(const io::CalibrationFile& cal, const std::string& path, const PipelineSettings& s) {
  if (s.allow_other_sensor || cal.sensor_id.empty() || s.sensor_id.empty() || cal.sensor_id == s.sensor_id) return;
  throw ConfigError(path + ": sensor_id '" + cal.sensor_id + "' is another sensor's calibration; this compensator is '" +
                    s.sensor_id + "' (--sensor-id). Calibrate this sensor, or pass --allow-other-sensor to take it");
}

}  // namespace

Pipeline::Pipeline(io::CalibrationFile cal, std::string cal_path, PipelineSettings s,
                   std::optional<core::PotentiometerCalibration> pot_override)
    : cal_(std::move(cal)), cal_path_(std::move(cal_path)), s_(std::move(s)), stats_(s_.statistics) {
  require_this_sensor(cal_, cal_path_, s_);
  pot_ = pot_override ? pot_override : cal_.potentiometer;
  // Validate the settings now (setup time, where throwing is allowed) at the nominal rate.
  core::CompensatorSettings probe = s_.compensator;
  if (probe.scan_rate_hz <= 0) probe.scan_rate_hz = 200.0;
  core::OnlineCompensator check(cal_.cal, probe);
  if (s_.output_rate_hz < 0) throw std::invalid_argument("output rate must be >= 0 Hz");
}

void Pipeline::replace_calibration(io::CalibrationFile cal, std::string cal_path) {
  require_this_sensor(cal, cal_path, s_);
  core::CompensatorSettings probe = s_.compensator;
  if (rate_ > 0) probe.scan_rate_hz = rate_;
  else if (probe.scan_rate_hz <= 0) probe.scan_rate_hz = 200.0;
  std::unique_ptr<core::OnlineCompensator> fresh;
  try {
    fresh = std::make_unique<core::OnlineCompensator>(cal.cal, probe);  // throws before any change
  } catch (const std::invalid_argument& e) {
    throw ConfigError(cal_path + ": " + e.what());
  }
  cal_ = std::move(cal);
  cal_path_ = std::move(cal_path);
  if (!pot_ || cal_.potentiometer) pot_ = cal_.potentiometer ? cal_.potentiometer : pot_;
  if (rate_ > 0) {
    retire_compensator();
    comp_ = std::move(fresh);
    refs_stored_ = 0;
  }
  ++counters_.reloads;
  counters_.last_error.clear();
}

void Pipeline::note_reload_failure(const std::string& why) {
  ++counters_.reload_failures;
  counters_.last_error = why;
}

void Pipeline::note_publish_failure() noexcept { sat_add(counters_.publish_failures, 1); }

void Pipeline::ensure_compensator(double scan_rate_hz) {
  if (comp_ && scan_rate_hz == rate_) return;
  core::CompensatorSettings cs = s_.compensator;
  cs.scan_rate_hz = scan_rate_hz;
  auto fresh = std::make_unique<core::OnlineCompensator>(cal_.cal, cs);  // may throw: nothing changed yet
  retire_compensator();
  comp_ = std::move(fresh);
  refs_stored_ = 0;
  rate_ = scan_rate_hz;
  k_ = s_.output_rate_hz > 0 ? std::max(1, int(std::lround(scan_rate_hz / s_.output_rate_hz))) : 1;
  in_window_ = 0;
}

bool Pipeline::map_channels(const pof::raw_block_t& b) noexcept {
  if (b.channel_names == mapped_names_ && ch_.sensor >= 0) return true;
  ChannelMap m;
  for (int c = 0; c < int(b.channel_names.size()); ++c) {
    const std::string& n = b.channel_names[size_t(c)];
    if (n == "sensor") m.sensor = c;
    else if (n == "reference") m.reference = c;
    else if (n == "angle_ref") m.angle_ref = c;
    else if (n == "pot") m.pot = c;
  }
  ch_ = m;
  try {
    mapped_names_ = b.channel_names;
    // Without a reference angle no cycle is scored, so no POF_STATS: a pot channel whose calibration
    // is missing says so in the status, which every client and `pof dash` shows.
    if (ch_.pot >= 0 && ch_.angle_ref < 0 && !pot_) counters_.last_error = kNoPotentiometer;
  } catch (...) {
    mapped_names_.clear();
  }
  return ch_.sensor >= 0 && ch_.reference >= 0;
}

double Pipeline::reference_angle(const std::vector<float>& scan) const noexcept {
  if (ch_.angle_ref >= 0) return double(scan[size_t(ch_.angle_ref)]);
  if (ch_.pot >= 0 && pot_) return pot_->angle(double(scan[size_t(ch_.pot)]));
  return kNaN;
}

void Pipeline::on_block(const pof::raw_block_t& b, std::int64_t publish_utime, Sink& sink) noexcept {
  sat_add(counters_.blocks, 1);
  const bool shape_ok = b.n_scans >= 0 && b.n_channels > 0 && b.volts.size() == size_t(b.n_scans) &&
                        std::isfinite(b.scan_rate_hz) && b.scan_rate_hz >= kMinScanRateHz &&
                        b.channel_names.size() == size_t(b.n_channels) && b.seq >= 0 && b.first_scan >= 0 &&
                        b.first_scan <= std::numeric_limits<std::int64_t>::max() - b.n_scans && b.utime >= 0 &&
                        b.utime <= kMaxUtime;
  if (!shape_ok) {
    sat_add(counters_.rejected_blocks, 1);
    return;
  }
  for (const auto& scan : b.volts)
    if (scan.size() != size_t(b.n_channels)) {
      sat_add(counters_.rejected_blocks, 1);
      return;
    }

  // Duplicates and replays are dropped before anything is touched (channel map, estimator, rate):
  // see on_block() in pipeline.hpp for what a new block, a restart and a resync are.
  bool restart = false;
  if (last_seq_) {
    const bool advances = b.seq > *last_seq_ && b.first_scan >= *next_scan_;
    if (!advances) {
      restart = b.seq == 0 && b.utime > last_utime_;
      if (!restart && ++stale_run_ < kResyncBlocks) {
        sat_add(counters_.duplicate_blocks, 1);
        return;
      }
      restart = true;  // a publisher restart, or kResyncBlocks stale blocks in a row: a new stream
    }
  }

  if (!map_channels(b)) {
    sat_add(counters_.rejected_blocks, 1);
    return;
  }
  try {
    ensure_compensator(b.scan_rate_hz);
  } catch (...) {
    // A nonsensical rate, or one the calibration's [gap] terms cannot run at (a notch at or above
    // its Nyquist frequency; --scan-rate checks the expected one at start): dropped and counted.
    sat_add(counters_.rejected_blocks, 1);
    return;
  }

  // Continuity. Lost scans (an index jump, or the device's FLAG_GAP) restart the velocity
  // estimator, whose window would otherwise straddle the hole; so does a new stream.
  bool scans_lost = (b.flags & pof::raw_block_t::FLAG_GAP) != 0 || restart;
  // A block the daemon cannot stand behind (raw_block_t.FLAG_DOUBTFUL, e.g. the USB-6008's byte
  // order not yet told from the data, docs/daq.md) is not compensated: its scans go through as
  // invalid input (NaN angle, QUALITY_INVALID_INPUT, counted as fault scans), so no wrongly decoded
  // value enters the angle or the model's memory; as after any invalid sample, the velocity
  // estimator settles again on the next good scans (QUALITY_SETTLING). No scan is lost.
  const bool doubtful = (b.flags & pof::raw_block_t::FLAG_DOUBTFUL) != 0;
  // A late block (raw_block_t.FLAG_LATE: pof-daqd's backlog after an acquisition stall) is right but
  // old: compensated as usual, so the model's memory stays whole, and every angle of it says so, so
  // that no controller takes the backlog for the knee's present (docs/daq.md, "Watchdog and stalls").
  const std::int32_t late = (b.flags & pof::raw_block_t::FLAG_LATE) != 0 ? core::quality::kLate : 0;
  if (last_seq_ && !restart) {
    // b.seq > *last_seq_ >= 0 and b.first_scan >= *next_scan_ >= 0: the differences cannot overflow.
    sat_add(counters_.lost_blocks, b.seq - *last_seq_ - 1);
    if (b.first_scan > *next_scan_) {
      sat_add(counters_.lost_scans, b.first_scan - *next_scan_);
      scans_lost = true;
    }
  }
  last_seq_ = b.seq;
  next_scan_ = b.first_scan + b.n_scans;
  last_utime_ = b.utime;
  stale_run_ = 0;
  if (scans_lost) {
    comp_->reset();
    in_window_ = 0;  // never average across a hole
    refs_stored_ = 0;
  }
  if (!t0_utime_) t0_utime_ = b.utime;

  const double us_per_scan = 1e6 / b.scan_rate_hz;
  // With the estimator's fixed lag the compensator's output describes the scan `lag` back: its
  // time, index and reference angle are that scan's (CompensatorSettings::estimator_lag_s).
  const int lag = comp_->lag_scans();
  for (int k = 0; k < b.n_scans; ++k) {
    const std::vector<float>& scan = b.volts[size_t(k)];
    const std::int64_t utime = b.utime + std::llround((k - lag) * us_per_scan);
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    const double ref_now = doubtful ? kNaN : reference_angle(scan);
    const core::CompensatedScan cs = doubtful ? comp_->step(kNaN, kNaN, kNaN)
                                              : comp_->step(double(scan[size_t(ch_.sensor)]), double(scan[size_t(ch_.reference)]), ref_now);
    const double ref = lag == 0 ? ref_now : delayed_reference(ref_now, lag);
    sat_add(counters_.scans, 1);
    if (cs.quality & kFaultBits) sat_add(counters_.fault_scans, 1);

    // Decimation window (k_ == 1: every scan).
    if (in_window_ == 0) {
      window_first_utime_ = utime;
      sum_angle_ = sum_uncomp_ = sum_ref_ = sum_sigma_ = 0;
      window_quality_ = 0;
    }
    sum_angle_ += cs.angle_deg;
    sum_uncomp_ += cs.angle_uncomp_deg;
    sum_sigma_ += cs.angle_sigma_deg;
    sum_ref_ += ref;
    window_quality_ |= cs.quality | late;
    ++in_window_;
    if (in_window_ == k_) {
      pending_.utime = (window_first_utime_ + utime) / 2;
      pending_.scan_index = b.first_scan + k - lag - (k_ - 1) / 2;
      pending_.angle_deg = float(sum_angle_ / k_);
      pending_.angle_uncomp_deg = float(sum_uncomp_ / k_);
      pending_.angle_ref_deg = float(sum_ref_ / k_);
      pending_.angle_sigma_deg = float(sum_sigma_ / k_);
      pending_.velocity_rad_s = float(cs.velocity_rad_s);
      pending_.phase = phase_of(cs.phase);
      pending_.quality = window_quality_;
      emit_angle(publish_utime, sink);
      in_window_ = 0;
    }

    // Per-cycle statistics need the reference; a cycle closes when the next flexion starts or
    // after a hold that follows its extension.
    if (!std::isnan(ref) && stats_.add(double(utime - *t0_utime_) * 1e-6, cs, ref)) emit_cycle(sink);
  }
}

void Pipeline::finish(Sink& sink) noexcept {
  if (t0_utime_ && stats_.finish()) emit_cycle(sink);
}

void Pipeline::emit_cycle(Sink& sink) {
  const core::CycleStats& c = stats_.last();
  pof::cycle_stats_t m{};
  m.seq = cycle_seq_++;
  m.cycle = c.cycle;
  m.start_utime = *t0_utime_ + std::llround(c.t_start_s * 1e6);
  m.end_utime = *t0_utime_ + std::llround(c.t_end_s * 1e6);
  m.utime = m.end_utime;  // the last scan of the cycle (cycle_stats_t.lcm), not the scan that closed it
  m.velocity_rad_s = float(c.velocity_rad_s);
  m.rmse_comp_deg = float(c.rmse_comp_deg);
  m.rmse_uncomp_deg = float(c.rmse_uncomp_deg);
  m.hysteresis_comp_pct = float(c.hysteresis_comp_pct);
  m.hysteresis_uncomp_pct = float(c.hysteresis_uncomp_pct);
  m.max_error_deg = float(c.max_error_deg);
  m.n_samples = std::int32_t(c.n_samples);
  sat_add(counters_.cycles, 1);
  if (!sink.cycle(m)) note_publish_failure();
}

void Pipeline::emit_angle(std::int64_t publish_utime, Sink& sink) {
  pending_.publish_utime = publish_utime;
  pending_.seq = angle_seq_++;
  sat_add(counters_.angles, 1);
  if (!sink.angle(pending_)) note_publish_failure();
}

double Pipeline::delayed_reference(double ref, int lag) noexcept {
  refs_head_ = (refs_head_ + 1) % (lag + 1);
  refs_[static_cast<std::size_t>(refs_head_)] = ref;
  if (refs_stored_ <= lag) ++refs_stored_;
  return refs_stored_ <= lag ? std::numeric_limits<double>::quiet_NaN() : refs_[static_cast<std::size_t>((refs_head_ + 1) % (lag + 1))];
}

void Pipeline::retire_compensator() noexcept {
  if (comp_) sat_add(divergences_retired_, comp_->estimator_divergences());
}

pof::compensator_status_t Pipeline::status(std::int64_t now_utime) const {
  pof::compensator_status_t m = counters_;
  m.utime = now_utime;
  m.estimator_divergences = divergences_retired_;
  if (comp_) sat_add(m.estimator_divergences, comp_->estimator_divergences());
  m.sensor_id = s_.sensor_id;
  m.calibration_path = cal_path_;
  m.calibration_sensor_id = cal_.sensor_id;
  m.calibration_date = cal_.date;
  return m;
}

}  // namespace pof::compensatord
