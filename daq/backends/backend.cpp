// Backend selection by `device.kind`.
#include "backends/backend.hpp"

#include "core/config.hpp"
#include "pof/io/errors.hpp"

namespace pof::daq {

std::string describe_variant(std::uint32_t bits) {
  std::string s;
  auto add = [&](std::uint32_t bit, const char* text) {
    if ((bits & bit) == 0U) return;
    if (!s.empty()) s += "; ";
    s += text;
  };
  add(kVariantHeader0000, "reply header 00 00");
  add(kVariantHeader0001, "reply header 00 01");
  add(kVariantBigEndian, "samples big-endian");
  add(kVariantLittleEndian, "samples little-endian");
  add(kVariantOrderUndecided, "sample byte order undecided (blocks flagged doubtful)");
  add(kVariantLayoutRecordFirst, "report layout record-first (index at 102)");
  add(kVariantLayoutDataFirst, "report layout data-first (index at 101)");
  add(kVariantPaddingSet, "padding bits set in samples");
  return s;
}

std::unique_ptr<Backend> make_backend(const DaqConfig& cfg) {
  if (cfg.device_kind.rfind("sim:", 0) == 0) return make_sim_backend(cfg);
  if (cfg.device_kind == "usb6008" || cfg.device_kind == "usb6009") return make_usb600x_backend(cfg);
  if (cfg.device_kind == "usb1208ls") return make_usb1208ls_backend(cfg);
  throw pof::io::ConfigError("device.kind: unknown backend '" + cfg.device_kind + "'");
}

}  // namespace pof::daq
