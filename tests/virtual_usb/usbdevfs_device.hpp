#pragma once
// A virtual USB device behind the real libusb, on umockdev (docs/virtual-usb.md):
// the testbed holds a sysfs record and a device node whose usbdevfs ioctls land in on_ioctl(), on
// the testbed's own thread. This class keeps the URB bookkeeping (submit, reap, discard, unplug)
// and leaves the protocol to a DeviceModel.
//
// Reaps that find nothing ready are answered EAGAIN only after 1 ms (note, item 6): umockdev does
// not emulate poll(), so an immediate EAGAIN would make libusb spin, and the deferral is also what
// paces the data in real time.
//
// Bus timing follows the descriptors (docs/virtual-usb.md, "Bus timing"): an interrupt endpoint
// moves one packet per poll, its polls bInterval frames apart; at low speed a control transfer
// moves `ep0_per_frame` 8-byte transactions per 1-ms frame (setup, data, status), one transfer at
// a time on EP0. Bulk endpoints (full speed) are not paced beyond the reap deferral.
#include <glib.h>
#include <umockdev.h>

#include <cstdint>
#include <cstdio>
#include <deque>
#include <map>
#include <mutex>
#include <span>
#include <string>
#include <vector>

namespace pof::vusb {

/// What a model answers to an IN URB (bulk, interrupt, or the data stage of a control read).
struct InResult {
  enum Kind { kWait, kData, kError } kind = kWait;
  int length = 0;  // kData: bytes written to the buffer
  int status = 0;  // kError: negative errno for the URB (-EPIPE stall, ...)
};

class DeviceModel {
 public:
  virtual ~DeviceModel() = default;
  /// An OUT transfer's payload (bulk or interrupt) on endpoint `ep`.
  virtual void on_out(std::uint8_t ep, std::span<const std::uint8_t> data, std::int64_t now_us) = 0;
  /// Fill `buf` for an IN URB on `ep`, or ask to wait.
  virtual InResult on_in(std::uint8_t ep, std::span<std::uint8_t> buf, std::int64_t now_us) = 0;
  /// A control transfer (setup packet + data stage). Return bytes for an IN request, -errno to
  /// fail it, or >= 0 for an OUT request.
  virtual int on_control(const std::uint8_t* setup, std::span<std::uint8_t> data, std::int64_t now_us) {
    (void)setup;
    (void)data;
    (void)now_us;
    return -32;  // EPIPE: not supported
  }
  virtual void on_clear_halt(std::uint8_t ep) { (void)ep; }
};

struct UsbIds {
  std::uint16_t vendor;
  std::uint16_t product;
  std::string descriptors_hex;  // device + configuration descriptors
  std::string speed = "12";     // sysfs `speed`: "12" full speed, "1.5" low speed
  // Low speed: 8-byte control transactions per frame (0 = control transfers complete at once).
  int ep0_per_frame = 1;
};

/// Transfer durations the virtual bus imposed (submit to completion), for the report.
struct BusFigures {
  std::vector<double> control_ms;       // control transfers
  std::vector<double> out_ms;           // interrupt OUT transfers
  std::vector<double> round_trip_ms;    // interrupt OUT submitted -> the next interrupt IN completed with data
};

class UsbdevfsDevice {
 public:
  /// Adds the device to `testbed` and attaches the ioctl handler. Throws std::runtime_error.
  UsbdevfsDevice(UMockdevTestbed* testbed, const UsbIds& ids, DeviceModel& model);
  /// Adds the sysfs record only and lets umockdev replay a usbmon capture on it
  /// (umockdev_testbed_load_pcap; DLT_USB_LINUX_MMAPPED, bus 1 device 2). Throws on error.
  static void replay(UMockdevTestbed* testbed, const UsbIds& ids, const std::string& pcap_path);
  /// Writes every URB submission and completion from now on to `path` as a usbmon capture
  /// (pcap, DLT_USB_LINUX_MMAPPED), the format a real device's Wireshark/usbmon capture has.
  void record_pcap(const std::string& path);
  ~UsbdevfsDevice();
  UsbdevfsDevice(const UsbdevfsDevice&) = delete;
  UsbdevfsDevice& operator=(const UsbdevfsDevice&) = delete;

  /// Unplug: pending URBs fail with -ENODEV, every later request with ENODEV, and the sysfs
  /// record goes away so enumeration no longer finds the device. Any thread.
  void unplug();
  /// Plug the device back in (a fresh device: the model should reset itself). Any thread.
  void replug();
  /// Fail the next IN URB on `ep` with `status` (e.g. -EPIPE for a stall). Any thread.
  void inject_in_error(std::uint8_t ep, int status);

  std::mutex& mutex() { return mu_; }  // held while the model is called
  long reaps() const { return reaps_; }
  const BusFigures& figures() const { return figures_; }  // under mutex()
  int claimed() const { return claimed_; }  // interfaces claimed and not released

 private:
  struct Urb {
    UMockdevIoctlData* urb = nullptr;  // the client's usbdevfs_urb (referenced)
    UMockdevIoctlData* buf = nullptr;  // its buffer
    std::uint8_t ep = 0;
    std::uint8_t type = 0;
    int length = 0;
    std::int64_t submit_us = 0;
    std::int64_t due_us = 0;     // timed_: when the bus has moved it
    int status = 0;              // timed_ control: its result
    int actual = 0;
  };
  struct Endpoint {  // from the endpoint descriptor
    std::uint8_t attributes = 0;
    int max_packet = 0;
    int interval_frames = 0;     // interrupt: bInterval (frames of 1 ms at low and full speed)
    std::int64_t next_poll_us = 0;  // IN: first poll not yet used
  };

  UsbdevfsDevice(UMockdevTestbed* testbed, const UsbIds& ids, DeviceModel& model, bool no_handler);
  static gboolean on_ioctl_cb(UMockdevIoctlBase* base, UMockdevIoctlClient* client, gpointer self);
  static gboolean on_deferred_reap(gpointer data);
  gboolean on_ioctl(UMockdevIoctlClient* client);
  void submit(UMockdevIoctlClient* client);
  void pump(std::int64_t now_us);
  bool deliver_ready(UMockdevIoctlClient* client);
  void finish(Urb& u, int status, int actual);
  void add_record();
  void parse_descriptors();
  [[nodiscard]] bool paced_interrupt(std::uint8_t ep) const;
  [[nodiscard]] std::int64_t next_poll(std::uint8_t ep, std::int64_t t) const;
  void pump_interrupt_in(std::int64_t now_us);
  void pcap_event(const Urb& u, char type, int status, int length, bool with_data);

  UMockdevTestbed* testbed_;
  UsbIds ids_;
  DeviceModel& model_;
  UMockdevIoctlBase* handler_ = nullptr;
  std::string sysfs_path_;
  GMainContext* ctx_ = nullptr;
  std::mutex mu_;
  std::deque<Urb> pending_;  // submitted IN URBs, in order
  std::deque<Urb> ready_;    // completed, waiting to be reaped
  std::deque<Urb> timed_;    // control and interrupt OUT URBs the bus has not moved yet, by due_us
  std::map<std::uint8_t, Endpoint> eps_;
  int ep0_max_packet_ = 64;
  bool low_speed_ = false;
  std::int64_t epoch_us_ = 0;      // frame 0 (the plug-in): interrupt polls are bInterval frames apart from it
  std::int64_t ep0_free_us_ = 0;   // EP0 is busy with a control transfer until then
  std::int64_t last_out_us_ = -1;  // submit time of the last interrupt OUT not yet answered on IN
  BusFigures figures_;
  bool unplugged_ = false;
  int inject_ep_ = -1;
  int inject_status_ = 0;
  long reaps_ = 0;
  int claimed_ = 0;
  std::FILE* pcap_ = nullptr;
};

}  // namespace pof::vusb
