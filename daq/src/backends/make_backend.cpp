// Backend selection by `device.kind`.
#include "pof/daq/stream/backend.hpp"

#include "pof/daq/stream/config.hpp"
#include "pof/base/errors.hpp"

namespace pof::daq {

std::unique_ptr<Backend> make_backend(const DaqConfig& cfg) {
  if (cfg.device_kind.rfind("sim:", 0) == 0) return make_sim_backend(cfg);
  if (cfg.device_kind == "usb6008" || cfg.device_kind == "usb6009") return make_usb600x_backend(cfg);
  if (cfg.device_kind == "usb1208ls") return make_usb1208ls_backend(cfg);
  throw pof::ConfigError("device.kind: unknown backend '" + cfg.device_kind + "'");
}

}  // namespace pof::daq
