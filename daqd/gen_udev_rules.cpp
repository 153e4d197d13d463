// Prints deploy/udev/60-pof-daq.rules from the device table (daq/include/pof/daq/device_ids.hpp), so the rule and
// the code cannot disagree (libfprint's habit, docs/daq.md). Access goes to the logged-in user
// (uaccess) and to group pof, the group the pof-daqd units run as (deploy/systemd, created by
// deploy/sysusers.d/pof.conf), never to everyone (no 0666).
#include <cstdio>
#include <cstring>

#include "pof/daq/device_ids.hpp"

namespace {
constexpr const char* kGroup = "pof";

constexpr const char* kUsage =
    "Usage: pof-gen-udev-rules\n"
    "Prints the udev rules that give the DAQ devices pofkit supports (daq/include/pof/daq/device_ids.hpp) to the\n"
    "seat's logged-in user and to group pof (the pof-daqd service), as deploy/udev/60-pof-daq.rules.\n"
    "Options: -h, --help  this text\n";
}  // namespace

int main(int argc, char** argv) {
  if (argc > 1) {
    const bool help = std::strcmp(argv[1], "-h") == 0 || std::strcmp(argv[1], "--help") == 0;
    std::fputs(kUsage, help ? stdout : stderr);
    if (!help) std::fprintf(stderr, "pof-gen-udev-rules: unexpected argument '%s'\n", argv[1]);
    return help ? 0 : 2;
  }
  std::printf(
      "# Generated from daq/include/pof/daq/device_ids.hpp by pof-gen-udev-rules; do not edit.\n"
      "# Regenerate: cmake --build --preset release --target pof_udev_rules\n"
      "# Install: sudo install -m 644 60-pof-daq.rules /etc/udev/rules.d/ && sudo udevadm trigger\n"
      "# Access: the seat's logged-in user (uaccess) and group %s (the pof-daqd service).\n",
      kGroup);
  for (const auto& d : pof::daq::kDeviceIds) {
    std::printf("\n# %.*s (%.*s)\n", static_cast<int>(d.description.size()), d.description.data(),
                static_cast<int>(d.kind.size()), d.kind.data());
    // The libusb device node, used by both backends (hidapi's libusb flavour opens it too).
    std::printf(
        "SUBSYSTEM==\"usb\", ENV{DEVTYPE}==\"usb_device\", ATTR{idVendor}==\"%04x\", "
        "ATTR{idProduct}==\"%04x\", MODE=\"0660\", GROUP=\"%s\", TAG+=\"uaccess\"\n",
        d.vendor_id, d.product_id, kGroup);
    if (d.subsystem == "hidraw") {
      std::printf(
          "KERNEL==\"hidraw*\", SUBSYSTEM==\"hidraw\", ATTRS{idVendor}==\"%04x\", "
          "ATTRS{idProduct}==\"%04x\", MODE=\"0660\", GROUP=\"%s\", TAG+=\"uaccess\"\n",
          d.vendor_id, d.product_id, kGroup);
    }
  }
  return 0;
}
