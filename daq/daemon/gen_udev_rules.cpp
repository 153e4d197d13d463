// Prints deploy/udev/60-pof-daq.rules from the device table (daq/include/pof/daq/device_ids.hpp), so the rule and
// the code cannot disagree (libfprint's habit, docs/daq.md). Access goes to the logged-in user
// (uaccess) and to group pof, the group the pof-daqd units run as (deploy/systemd, created by
// deploy/sysusers.d/pof.conf), never to everyone (no 0666).
#include <cstdio>

#include <CLI/CLI.hpp>

#include "pof/base/exit_codes.hpp"
#include "pof/daq/device_ids.hpp"
#include "pof/service/run_main.hpp"

namespace {
constexpr const char* kGroup = "pof";

int print_rules() {
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
  return pof::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Prints the udev rules that give the DAQ devices pofkit supports (daq/include/pof/daq/device_ids.hpp) to "
      "the seat's logged-in user and to group pof (the pof-daqd service), as deploy/udev/60-pof-daq.rules.",
      "pof-gen-udev-rules"};
  app.set_version_flag("--version", POF_VERSION);
  return pof::service::run_main("pof-gen-udev-rules", app, argc, argv, print_rules);
}
