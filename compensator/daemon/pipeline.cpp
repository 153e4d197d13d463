#include "pipeline.hpp"

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

}  // namespace

Pipeline::Pipeline(io::CalibrationFile cal, std::string cal_path, PipelineSettings s,
                   std::optional<core::PotentiometerCalibration> pot_override)
    : cal_(std::move(cal)), cal_path_(std::move(cal_path)), s_(std::move(s)), stats_(s_.statistics) {
  pot_ = pot_override ? pot_override : cal_.potentiometer;
  // Validate the settings now (setup time, where throwing is allowed) at the nominal rate.
  core::CompensatorSettings probe = s_.compensator;
  if (probe.scan_rate_hz <= 0) probe.scan_rate_hz = 200.0;
  core::OnlineCompensator check(cal_.cal, probe);
  if (s_.output_rate_hz < 0) throw std::invalid_argument("output rate must be >= 0 Hz");
}

void Pipeline::replace_calibration(io::CalibrationFile cal, std::string cal_path) {
  core::CompensatorSettings probe = s_.compensator;
  probe.scan_rate_hz = rate_ > 0 ? rate_ : 200.0;
  auto fresh = std::make_unique<core::OnlineCompensator>(cal.cal, probe);  // throws before any change
  cal_ = std::move(cal);
  cal_path_ = std::move(cal_path);
  if (!pot_ || cal_.potentiometer) pot_ = cal_.potentiometer ? cal_.potentiometer : pot_;
  if (rate_ > 0) comp_ = std::move(fresh);
  ++counters_.reloads;
  counters_.last_error.clear();
}

void Pipeline::note_reload_failure(const std::string& why) {
  ++counters_.reload_failures;
  counters_.last_error = why;
}

void Pipeline::ensure_compensator(double scan_rate_hz) {
  if (comp_ && scan_rate_hz == rate_) return;
  core::CompensatorSettings cs = s_.compensator;
  cs.scan_rate_hz = scan_rate_hz;
  comp_ = std::make_unique<core::OnlineCompensator>(cal_.cal, cs);
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
  ++counters_.blocks;
  const bool shape_ok = b.n_scans >= 0 && b.n_channels > 0 && b.volts.size() == size_t(b.n_scans) &&
                        b.scan_rate_hz > 0 && std::isfinite(b.scan_rate_hz) &&
                        b.channel_names.size() == size_t(b.n_channels);
  if (!shape_ok || !map_channels(b)) {
    ++counters_.rejected_blocks;
    return;
  }
  for (const auto& scan : b.volts)
    if (scan.size() != size_t(b.n_channels)) {
      ++counters_.rejected_blocks;
      return;
    }

  try {
    ensure_compensator(b.scan_rate_hz);
  } catch (...) {  // only a nonsensical rate gets here; the block is dropped and counted
    ++counters_.rejected_blocks;
    return;
  }

  // Continuity. A sequence number going backwards is a restarted publisher: a new stream, not a
  // loss. Lost scans (index jump) or a device-flagged gap restart the velocity estimator, whose
  // window would otherwise straddle the hole.
  bool gap = (b.flags & pof::raw_block_t::FLAG_GAP) != 0;
  // A block the daemon cannot stand behind (raw_block_t.FLAG_DOUBTFUL, e.g. the USB-6008's byte
  // order not yet told from the data, docs/daq.md) is not compensated: its scans go through as
  // invalid input (NaN angle, QUALITY_INVALID_INPUT, counted as fault scans), so no wrongly decoded
  // value enters the angle or the model's memory; as after any invalid sample, the velocity
  // estimator settles again on the next good scans (QUALITY_SETTLING). No scan is lost: no gap.
  const bool doubtful = (b.flags & pof::raw_block_t::FLAG_DOUBTFUL) != 0;
  if (next_seq_ && b.seq > *next_seq_) counters_.lost_blocks += b.seq - *next_seq_;
  if (next_scan_ && b.first_scan != *next_scan_) {
    if (b.first_scan > *next_scan_) counters_.lost_scans += b.first_scan - *next_scan_;
    gap = true;
  }
  next_seq_ = b.seq + 1;
  next_scan_ = b.first_scan + b.n_scans;
  if (gap) {
    comp_->reset();
    in_window_ = 0;  // never average across a hole
  }
  if (!t0_utime_) t0_utime_ = b.utime;

  const double us_per_scan = 1e6 / b.scan_rate_hz;
  for (int k = 0; k < b.n_scans; ++k) {
    const std::vector<float>& scan = b.volts[size_t(k)];
    const std::int64_t utime = b.utime + std::llround(k * us_per_scan);
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    const double ref = doubtful ? kNaN : reference_angle(scan);
    const core::CompensatedScan cs = doubtful ? comp_->step(kNaN, kNaN, kNaN)
                                              : comp_->step(double(scan[size_t(ch_.sensor)]), double(scan[size_t(ch_.reference)]), ref);
    ++counters_.scans;
    if (cs.quality & kFaultBits) ++counters_.fault_scans;

    // Decimation window (k_ == 1: every scan).
    if (in_window_ == 0) {
      window_first_utime_ = utime;
      sum_angle_ = sum_uncomp_ = sum_ref_ = 0;
      window_quality_ = 0;
    }
    sum_angle_ += cs.angle_deg;
    sum_uncomp_ += cs.angle_uncomp_deg;
    sum_ref_ += ref;
    window_quality_ |= cs.quality;
    ++in_window_;
    if (in_window_ == k_) {
      pending_.utime = (window_first_utime_ + utime) / 2;
      pending_.scan_index = b.first_scan + k - (k_ - 1) / 2;
      pending_.angle_deg = float(sum_angle_ / k_);
      pending_.angle_uncomp_deg = float(sum_uncomp_ / k_);
      pending_.angle_ref_deg = float(sum_ref_ / k_);
      pending_.velocity_rad_s = float(cs.velocity_rad_s);
      pending_.phase = phase_of(cs.phase);
      pending_.quality = window_quality_;
      emit_angle(publish_utime, sink);
      in_window_ = 0;
    }

    // Per-cycle statistics need the reference; a cycle closes when the next flexion starts.
    if (!std::isnan(ref) && stats_.add(double(utime - *t0_utime_) * 1e-6, cs, ref)) {
      const core::CycleStats& c = stats_.last();
      pof::cycle_stats_t m{};
      m.utime = utime;
      m.seq = cycle_seq_++;
      m.cycle = c.cycle;
      m.start_utime = *t0_utime_ + std::llround(c.t_start_s * 1e6);
      m.end_utime = *t0_utime_ + std::llround(c.t_end_s * 1e6);
      m.velocity_rad_s = float(c.velocity_rad_s);
      m.rmse_comp_deg = float(c.rmse_comp_deg);
      m.rmse_uncomp_deg = float(c.rmse_uncomp_deg);
      m.hysteresis_comp_pct = float(c.hysteresis_comp_pct);
      m.hysteresis_uncomp_pct = float(c.hysteresis_uncomp_pct);
      m.max_error_deg = float(c.max_error_deg);
      m.n_samples = std::int32_t(c.n_samples);
      ++counters_.cycles;
      sink.cycle(m);
    }
  }
}

void Pipeline::emit_angle(std::int64_t publish_utime, Sink& sink) {
  pending_.publish_utime = publish_utime;
  pending_.seq = angle_seq_++;
  ++counters_.angles;
  sink.angle(pending_);
}

pof::compensator_status_t Pipeline::status(std::int64_t now_utime) const {
  pof::compensator_status_t m = counters_;
  m.utime = now_utime;
  m.sensor_id = s_.sensor_id;
  m.calibration_path = cal_path_;
  m.calibration_sensor_id = cal_.sensor_id;
  m.calibration_date = cal_.date;
  return m;
}

}  // namespace pof::compensatord
