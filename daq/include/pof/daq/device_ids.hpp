#pragma once
// The one table of supported USB devices. The daemon matches devices with it and the udev rule in
// deploy/udev/ is generated from it (daq/daemon/gen_udev_rules.cpp); a test fails when the
// checked-in rule is stale. Sources (docs/daq.md, "Protocol facts"): NI IDs from
// seregioo/comedi ni_usb6009.c and argusro/datalogger-rpi usb6008.py; MCC ID from
// wjasper/Linux_Drivers usb-1208LS.c.
#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

namespace pof::daq {

enum class DeviceModel { kUsb6008, kUsb6009, kUsb1208ls };

struct DeviceId {
  DeviceModel model;
  std::string_view kind;  // backend name in daq.toml `device.kind` and daq_status_t.device_kind
  std::uint16_t vendor_id;
  std::uint16_t product_id;
  std::string_view description;
  // The Linux subsystem the daemon opens: "usb" (libusb, /dev/bus/usb) or "hidraw" (hidapi).
  std::string_view subsystem;
};

inline constexpr std::array<DeviceId, 3> kDeviceIds{{
    {DeviceModel::kUsb6008, "usb6008", 0x3923, 0x717a, "NI USB-6008", "usb"},
    {DeviceModel::kUsb6009, "usb6009", 0x3923, 0x717b, "NI USB-6009", "usb"},
    {DeviceModel::kUsb1208ls, "usb1208ls", 0x09db, 0x007a, "MCC USB-1208LS", "hidraw"},
}};

constexpr std::optional<DeviceId> find_device_id(std::string_view kind) {
  for (const auto& d : kDeviceIds) {
    if (d.kind == kind) return d;
  }
  return std::nullopt;
}

}  // namespace pof::daq
