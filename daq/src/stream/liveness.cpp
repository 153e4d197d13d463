// Stall and watchdog bounds: see liveness.hpp.
#include "pof/daq/stream/liveness.hpp"

#include <algorithm>
#include <cmath>

#include "pof/daq/stream/config.hpp"

namespace pof::daq {

int stall_bound_ms(const DaqConfig& cfg, double device_rate_hz) {
  if (cfg.stall_ms > 0) return cfg.stall_ms;
  const double rate = device_rate_hz > 0 ? device_rate_hz : cfg.scan_rate_hz;
  const double block_ms = 1e3 * cfg.block_scans * cfg.decimate / rate;
  const double handover_ms = 1e3 * kStallDeviceScans / rate;
  const double ms = kStallBlocks * std::max(block_ms, handover_ms);
  return static_cast<int>(std::min(std::max(std::ceil(ms), double{kStallFloorMs}), 3.6e6));
}

int watchdog_grace_ms(const DaqConfig& cfg, int stall_ms) {
  return stall_ms + std::max(cfg.data_timeout_ms, cfg.command_timeout_ms);
}

}  // namespace pof::daq
