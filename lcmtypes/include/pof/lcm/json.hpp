#pragma once
// pofkit's status and result messages as JSON objects, field by field with the .lcm names and
// units, for the programs that hand them to other tools: `pof bridge` (PlotJuggler) and `pof dash`
// (the browser). Numbers only: PlotJuggler plots numbers, and each caller adds the strings and
// names it shows (a status's text, a flag's name). NaN and infinities become null (JSON has
// neither). Header-only; needs nlohmann-json.
#include <cmath>

#include <nlohmann/json.hpp>

#include "pof/angle_t.hpp"
#include "pof/compensator_status_t.hpp"
#include "pof/cycle_stats_t.hpp"
#include "pof/daq_status_t.hpp"

namespace pof::lcmutil {

inline nlohmann::json json_number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

inline nlohmann::json json_fields(const pof::angle_t& m) {
  return {{"utime", m.utime},
          {"publish_utime", m.publish_utime},
          {"seq", m.seq},
          {"scan_index", m.scan_index},
          {"angle_deg", json_number(m.angle_deg)},
          {"angle_uncomp_deg", json_number(m.angle_uncomp_deg)},
          {"angle_ref_deg", json_number(m.angle_ref_deg)},
          {"velocity_rad_s", json_number(m.velocity_rad_s)},
          {"phase", m.phase},
          {"quality", m.quality},
          {"angle_sigma_deg", json_number(m.angle_sigma_deg)}};
}

inline nlohmann::json json_fields(const pof::cycle_stats_t& m) {
  return {{"utime", m.utime},
          {"seq", m.seq},
          {"cycle", m.cycle},
          {"start_utime", m.start_utime},
          {"end_utime", m.end_utime},
          {"velocity_rad_s", json_number(m.velocity_rad_s)},
          {"rmse_comp_deg", json_number(m.rmse_comp_deg)},
          {"rmse_uncomp_deg", json_number(m.rmse_uncomp_deg)},
          {"hysteresis_comp_pct", json_number(m.hysteresis_comp_pct)},
          {"hysteresis_uncomp_pct", json_number(m.hysteresis_uncomp_pct)},
          {"max_error_deg", json_number(m.max_error_deg)},
          {"n_samples", m.n_samples}};
}

inline nlohmann::json json_fields(const pof::daq_status_t& m) {
  return {{"utime", m.utime},
          {"seq", m.seq},
          {"state", m.state},
          {"scan_rate_hz", json_number(m.scan_rate_hz)},
          {"n_channels", m.n_channels},
          {"scans", m.scans},
          {"blocks", m.blocks},
          {"dropped_scans", m.dropped_scans},
          {"usb_errors", m.usb_errors},
          {"overruns", m.overruns},
          {"reconnects", m.reconnects},
          {"padding_set", m.padding_set},
          {"publish_failures", m.publish_failures}};
}

inline nlohmann::json json_fields(const pof::compensator_status_t& m) {
  return {{"utime", m.utime},
          {"seq", m.seq},
          {"blocks", m.blocks},
          {"scans", m.scans},
          {"lost_blocks", m.lost_blocks},
          {"lost_scans", m.lost_scans},
          {"rejected_blocks", m.rejected_blocks},
          {"fault_scans", m.fault_scans},
          {"angles", m.angles},
          {"cycles", m.cycles},
          {"reloads", m.reloads},
          {"reload_failures", m.reload_failures},
          {"decode_errors", m.decode_errors},
          {"malformed_datagrams", m.malformed_datagrams},
          {"duplicate_blocks", m.duplicate_blocks},
          {"publish_failures", m.publish_failures},
          {"authenticated", m.authenticated ? 1 : 0},
          {"auth_unsigned", m.auth_unsigned},
          {"auth_bad_mac", m.auth_bad_mac},
          {"auth_stale", m.auth_stale},
          {"auth_replayed", m.auth_replayed},
          {"estimator_divergences", m.estimator_divergences}};
}

}  // namespace pof::lcmutil
