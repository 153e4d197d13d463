// Prints deploy/udev/60-pof-daq.rules from the device table (daq/device_ids.hpp), so the rule and
// the code cannot disagree (libfprint habit, style.md). Access goes to the logged-in user
// (uaccess) and to group plugdev, never to everyone (no 0666: daq-protocols.md).
#include <cstdio>

#include "device_ids.hpp"

int main() {
  std::printf(
      "# Generated from daq/device_ids.hpp by pof-gen-udev-rules; do not edit.\n"
      "# Regenerate: cmake --build --preset release --target pof_udev_rules\n"
      "# Install: sudo install -m 644 60-pof-daq.rules /etc/udev/rules.d/ && sudo udevadm trigger\n"
      "# Access: the seat's logged-in user (uaccess) and group plugdev (the pof-daqd service).\n");
  for (const auto& d : pof::daq::kDeviceIds) {
    std::printf("\n# %.*s (%.*s)\n", static_cast<int>(d.description.size()), d.description.data(),
                static_cast<int>(d.kind.size()), d.kind.data());
    // The libusb device node, used by both backends (hidapi's libusb flavour opens it too).
    std::printf(
        "SUBSYSTEM==\"usb\", ENV{DEVTYPE}==\"usb_device\", ATTR{idVendor}==\"%04x\", "
        "ATTR{idProduct}==\"%04x\", MODE=\"0660\", GROUP=\"plugdev\", TAG+=\"uaccess\"\n",
        d.vendor_id, d.product_id);
    if (d.subsystem == "hidraw") {
      std::printf(
          "KERNEL==\"hidraw*\", SUBSYSTEM==\"hidraw\", ATTRS{idVendor}==\"%04x\", "
          "ATTRS{idProduct}==\"%04x\", MODE=\"0660\", GROUP=\"plugdev\", TAG+=\"uaccess\"\n",
          d.vendor_id, d.product_id);
    }
  }
  return 0;
}
