// usbdevfs emulation on umockdev: see usbdevfs_device.hpp and docs/virtual-usb.md.
#include "usbdevfs_device.hpp"

// <sys/ioctl.h> before <linux/usbdevice_fs.h> (note, item 4).
#include <sys/ioctl.h>
#include <linux/usbdevice_fs.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace pof::vusb {
namespace {

constexpr const char* kSysfs = "/devices/pci0000:00/0000:00:14.0/usb1/1-1";
constexpr const char* kDevNode = "/dev/bus/usb/001/002";

usbdevfs_urb read_urb(UMockdevIoctlData* d) {
  usbdevfs_urb u{};
  std::memcpy(&u, d->data, sizeof u);
  return u;
}

}  // namespace

UsbdevfsDevice::UsbdevfsDevice(UMockdevTestbed* testbed, const UsbIds& ids, DeviceModel& model)
    : testbed_(testbed), ids_(ids), model_(model) {
  parse_descriptors();
  add_record();
  handler_ = umockdev_ioctl_base_new();
  g_signal_connect_data(handler_, "handle-ioctl", reinterpret_cast<GCallback>(&on_ioctl_cb), this,
                        nullptr, static_cast<GConnectFlags>(0));
  GError* err = nullptr;
  if (!umockdev_testbed_attach_ioctl(testbed_, kDevNode, handler_, &err)) {
    std::string msg = std::string("umockdev_testbed_attach_ioctl: ") + (err ? err->message : "?");
    if (err) g_error_free(err);
    throw std::runtime_error(msg);
  }
}

void UsbdevfsDevice::replay(UMockdevTestbed* testbed, const UsbIds& ids, const std::string& pcap_path) {
  struct Null final : DeviceModel {
    void on_out(std::uint8_t, std::span<const std::uint8_t>, std::int64_t) override {}
    InResult on_in(std::uint8_t, std::span<std::uint8_t>, std::int64_t) override { return {}; }
  } null_model;
  UsbdevfsDevice record_only(testbed, ids, null_model, false);
  GError* err = nullptr;
  if (!umockdev_testbed_load_pcap(testbed, record_only.sysfs_path_.c_str(), pcap_path.c_str(), &err)) {
    std::string msg = "umockdev_testbed_load_pcap(" + pcap_path + "): " + (err ? err->message : "?");
    if (err) g_error_free(err);
    throw std::runtime_error(msg);
  }
}

UsbdevfsDevice::UsbdevfsDevice(UMockdevTestbed* testbed, const UsbIds& ids, DeviceModel& model, bool)
    : testbed_(testbed), ids_(ids), model_(model) {
  add_record();
}

void UsbdevfsDevice::record_pcap(const std::string& path) {
  std::lock_guard lock(mu_);
  pcap_ = std::fopen(path.c_str(), "wb");
  if (pcap_ == nullptr) throw std::runtime_error("cannot write " + path);
  // pcap global header: magic, v2.4, tz 0, sigfigs 0, snaplen, DLT_USB_LINUX_MMAPPED (220).
  const guint32 magic = 0xa1b2c3d4;
  const guint16 major = 2;
  const guint16 minor = 4;
  const gint32 zone = 0;
  const guint32 sigfigs = 0;
  const guint32 snaplen = 65535;
  const guint32 linktype = 220;
  std::fwrite(&magic, 4, 1, pcap_);
  std::fwrite(&major, 2, 1, pcap_);
  std::fwrite(&minor, 2, 1, pcap_);
  std::fwrite(&zone, 4, 1, pcap_);
  std::fwrite(&sigfigs, 4, 1, pcap_);
  std::fwrite(&snaplen, 4, 1, pcap_);
  std::fwrite(&linktype, 4, 1, pcap_);
}

// One usbmon event: the 64-byte mmapped header (linux/usb/mon, pcap-usb-linux-common) + data.
void UsbdevfsDevice::pcap_event(const Urb& u, char type, int status, int length, bool with_data) {
  if (pcap_ == nullptr) return;
  struct __attribute__((packed)) Header {
    guint64 id;
    char event_type;
    guint8 transfer_type;
    guint8 endpoint;
    guint8 device;
    guint16 bus;
    char setup_flag;
    char data_flag;
    gint64 ts_sec;
    gint32 ts_usec;
    gint32 status;
    guint32 urb_len;
    guint32 data_len;
    guint8 setup[8];
    gint32 interval;
    gint32 start_frame;
    guint32 xfer_flags;
    guint32 ndesc;
  } h{};
  static_assert(sizeof(Header) == 64, "usbmon mmapped header is 64 bytes");
  const std::int64_t now = g_get_real_time();
  h.id = u.urb->client_addr;
  h.event_type = type;
  h.transfer_type = u.type;
  h.endpoint = u.ep;
  h.device = 2;
  h.bus = 1;
  h.setup_flag = '-';
  h.data_flag = with_data ? 0 : '<';
  h.ts_sec = now / 1000000;
  h.ts_usec = static_cast<gint32>(now % 1000000);
  h.status = status;
  h.urb_len = static_cast<guint32>(length);
  h.data_len = with_data ? static_cast<guint32>(length) : 0U;
  const guint32 caplen = 64U + h.data_len;
  const guint32 ts_sec = static_cast<guint32>(h.ts_sec);
  const guint32 ts_usec = static_cast<guint32>(h.ts_usec);
  std::fwrite(&ts_sec, 4, 1, pcap_);
  std::fwrite(&ts_usec, 4, 1, pcap_);
  std::fwrite(&caplen, 4, 1, pcap_);
  std::fwrite(&caplen, 4, 1, pcap_);
  std::fwrite(&h, sizeof h, 1, pcap_);
  if (h.data_len > 0) std::fwrite(u.buf->data, 1, h.data_len, pcap_);
  std::fflush(pcap_);
}

UsbdevfsDevice::~UsbdevfsDevice() {
  if (pcap_ != nullptr) std::fclose(pcap_);
  if (handler_ != nullptr) {
    GError* err = nullptr;
    (void)umockdev_testbed_detach_ioctl(testbed_, kDevNode, &err);
    if (err) g_error_free(err);
    g_object_unref(handler_);
  }
}

// The timing the descriptors imply (docs/virtual-usb.md, "Bus timing"): bMaxPacketSize0 from the
// device descriptor, and each endpoint's type, wMaxPacketSize and bInterval.
void UsbdevfsDevice::parse_descriptors() {
  std::vector<std::uint8_t> d;
  for (std::size_t i = 0; i + 1 < ids_.descriptors_hex.size(); i += 2) {
    d.push_back(static_cast<std::uint8_t>(std::stoul(ids_.descriptors_hex.substr(i, 2), nullptr, 16)));
  }
  if (d.size() >= 8 && d[1] == 1) ep0_max_packet_ = d[7];
  for (std::size_t i = 0; i + 1 < d.size() && d[i] >= 2; i += d[i]) {
    if (d[i + 1] == 5 && d[i] >= 7 && i + 6 < d.size()) {
      Endpoint e;
      e.attributes = d[i + 3];
      e.max_packet = d[i + 4] | (d[i + 5] << 8);
      e.interval_frames = (e.attributes & 3U) == 3U ? std::max<int>(1, d[i + 6]) : 0;
      eps_[d[i + 2]] = e;
    }
  }
  low_speed_ = ids_.speed == "1.5";
  epoch_us_ = g_get_real_time() / 1000 * 1000;
}

bool UsbdevfsDevice::paced_interrupt(std::uint8_t ep) const {
  const auto it = eps_.find(ep);
  return it != eps_.end() && it->second.interval_frames > 0;
}

// The first poll of interrupt endpoint `ep` at or after `t`: polls are bInterval frames apart,
// counted from the plug-in (a host keeps an endpoint's slot in its periodic schedule).
std::int64_t UsbdevfsDevice::next_poll(std::uint8_t ep, std::int64_t t) const {
  const std::int64_t period = std::int64_t{eps_.at(ep).interval_frames} * 1000;
  const std::int64_t k = (std::max(t, epoch_us_) - epoch_us_ + period - 1) / period;
  return epoch_us_ + k * period;
}

void UsbdevfsDevice::add_record() {
  char rec[4096];
  std::snprintf(rec, sizeof rec,
                "P: %s\nN: bus/usb/001/002\nE: DEVNAME=%s\nE: DEVTYPE=usb_device\nE: SUBSYSTEM=usb\n"
                "E: BUSNUM=001\nE: DEVNUM=002\nA: busnum=1\\n\nA: devnum=2\\n\n"
                "A: idVendor=%04x\\n\nA: idProduct=%04x\\n\nA: speed=%s\\n\n"
                "A: bConfigurationValue=1\\n\nH: descriptors=%s\n",
                kSysfs, kDevNode, ids_.vendor, ids_.product, ids_.speed.c_str(), ids_.descriptors_hex.c_str());
  GError* err = nullptr;
  if (!umockdev_testbed_add_from_string(testbed_, rec, &err)) {
    std::string msg = std::string("umockdev_testbed_add_from_string: ") + (err ? err->message : "?");
    if (err) g_error_free(err);
    throw std::runtime_error(msg);
  }
  sysfs_path_ = std::string("/sys") + kSysfs;
}

void UsbdevfsDevice::unplug() {
  std::lock_guard lock(mu_);
  unplugged_ = true;
  while (!pending_.empty()) {
    finish(pending_.front(), -ENODEV, 0);
    pending_.pop_front();
  }
  while (!timed_.empty()) {
    finish(timed_.front(), -ENODEV, 0);
    timed_.pop_front();
  }
  umockdev_testbed_remove_device(testbed_, sysfs_path_.c_str());
}

void UsbdevfsDevice::replug() {
  std::lock_guard lock(mu_);
  for (auto& u : ready_) {
    g_object_unref(u.urb);
    g_object_unref(u.buf);
  }
  ready_.clear();
  add_record();
  epoch_us_ = g_get_real_time() / 1000 * 1000;  // a fresh device: a new periodic schedule
  for (auto& [ep, e] : eps_) e.next_poll_us = 0;
  ep0_free_us_ = 0;
  last_out_us_ = -1;
  unplugged_ = false;
  claimed_ = 0;  // a fresh device
}

void UsbdevfsDevice::inject_in_error(std::uint8_t ep, int status) {
  std::lock_guard lock(mu_);
  inject_ep_ = ep;
  inject_status_ = status;
}

gboolean UsbdevfsDevice::on_ioctl_cb(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
  return static_cast<UsbdevfsDevice*>(self)->on_ioctl(client);
}

void UsbdevfsDevice::finish(Urb& u, int status, int actual) {
  pcap_event(u, 'C', status, actual, (u.ep & 0x80) != 0 && actual > 0);
  usbdevfs_urb copy = read_urb(u.urb);
  copy.status = status;
  copy.actual_length = actual;
  umockdev_ioctl_data_update(u.urb, 0, reinterpret_cast<guint8*>(&copy), static_cast<gint>(sizeof copy));
  ready_.push_back(u);
}

void UsbdevfsDevice::submit(UMockdevIoctlClient* client) {
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  GError* err = nullptr;
  UMockdevIoctlData* urb = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_urb), &err);
  if (urb == nullptr) {
    if (err) g_error_free(err);
    umockdev_ioctl_client_complete(client, -1, EFAULT);
    return;
  }
  const usbdevfs_urb u = read_urb(urb);
  UMockdevIoctlData* buf = umockdev_ioctl_data_resolve(urb, offsetof(usbdevfs_urb, buffer),
                                                       static_cast<gsize>(u.buffer_length), &err);
  if (buf == nullptr) {
    if (err) g_error_free(err);
    umockdev_ioctl_client_complete(client, -1, EFAULT);
    return;
  }
  Urb q{g_object_ref(urb), g_object_ref(buf), u.endpoint, u.type, u.buffer_length};
  pcap_event(q, 'S', -EINPROGRESS, u.buffer_length, (u.endpoint & 0x80) == 0 && u.type != USBDEVFS_URB_TYPE_CONTROL);
  const std::int64_t now = g_get_real_time();
  q.submit_us = now;
  if (u.type == USBDEVFS_URB_TYPE_CONTROL) {
    std::span<std::uint8_t> data(buf->data + 8, static_cast<std::size_t>(std::max(0, u.buffer_length - 8)));
    const std::uint8_t* setup = buf->data;
    // The device answers the setup packet when it arrives; the data reach the host later.
    const int r = model_.on_control(setup, data, now);
    if (r >= 0 && (setup[0] & 0x80) != 0) umockdev_ioctl_data_update(buf, 8, data.data(), r);
    q.status = r >= 0 ? 0 : r;
    q.actual = r >= 0 ? r : 0;
    if (!low_speed_ || ids_.ep0_per_frame <= 0) {
      finish(q, q.status, q.actual);
    } else {
      // Setup, data and status transactions of at most bMaxPacketSize0 bytes each, from the next
      // frame on, `ep0_per_frame` a frame; a short or zero-length packet ends an IN data stage.
      const int w_length = setup[6] | (setup[7] << 8);
      const bool in = (setup[0] & 0x80) != 0;
      const int moved = r < 0 ? 0 : in ? r : w_length;
      int data_tx = (moved + ep0_max_packet_ - 1) / ep0_max_packet_;
      if (in && r >= 0 && moved < w_length && moved % ep0_max_packet_ == 0) ++data_tx;  // zero-length packet
      const int tx = r < 0 ? 2 : 2 + data_tx;  // a stall ends the transfer at its first data or status stage
      const std::int64_t start = std::max(now, ep0_free_us_);
      const std::int64_t frame = epoch_us_ + (start - epoch_us_ + 999) / 1000 * 1000;
      q.due_us = frame + std::int64_t{(tx + ids_.ep0_per_frame - 1) / ids_.ep0_per_frame} * 1000;
      ep0_free_us_ = q.due_us;
      figures_.control_ms.push_back(static_cast<double>(q.due_us - now) / 1000.0);
      timed_.insert(std::upper_bound(timed_.begin(), timed_.end(), q,
                                     [](const Urb& a, const Urb& b) { return a.due_us < b.due_us; }),
                    q);
    }
  } else if ((u.endpoint & 0x80) == 0) {
    if (paced_interrupt(u.endpoint)) {
      // One packet per poll, the polls of this endpoint in order: the device takes the command at
      // the poll that carries its last packet (on_out in pump()).
      Endpoint& e = eps_[u.endpoint];
      const int packets = std::max(1, (u.buffer_length + e.max_packet - 1) / std::max(1, e.max_packet));
      std::int64_t slot = next_poll(u.endpoint, std::max(now, e.next_poll_us));
      for (int i = 1; i < packets; ++i) slot = next_poll(u.endpoint, slot + 1);
      e.next_poll_us = slot + 1;
      q.due_us = slot;
      q.actual = u.buffer_length;
      last_out_us_ = now;
      figures_.out_ms.push_back(static_cast<double>(slot - now) / 1000.0);
      timed_.insert(std::upper_bound(timed_.begin(), timed_.end(), q,
                                     [](const Urb& a, const Urb& b) { return a.due_us < b.due_us; }),
                    q);
    } else {
      model_.on_out(u.endpoint,
                    std::span<const std::uint8_t>(buf->data, static_cast<std::size_t>(u.buffer_length)), now);
      finish(q, 0, u.buffer_length);
    }
  } else {
    pending_.push_back(q);
  }
  umockdev_ioctl_client_complete(client, 0, 0);
}

// Completes the pending IN URBs whose data the model has now, in submission order per endpoint.
void UsbdevfsDevice::pump(std::int64_t now_us) {
  // Control and interrupt OUT transfers the bus has moved by now.
  while (!timed_.empty() && timed_.front().due_us <= now_us) {
    Urb u = timed_.front();
    timed_.pop_front();
    if (u.type == USBDEVFS_URB_TYPE_CONTROL) {
      finish(u, u.status, u.actual);
    } else {
      model_.on_out(u.ep, std::span<const std::uint8_t>(u.buf->data, static_cast<std::size_t>(u.length)), u.due_us);
      finish(u, 0, u.actual);
    }
  }
  pump_interrupt_in(now_us);
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (paced_interrupt(it->ep)) {  // pump_interrupt_in()
      ++it;
      continue;
    }
    if (inject_ep_ == it->ep) {
      inject_ep_ = -1;
      finish(*it, inject_status_, 0);
      it = pending_.erase(it);
      continue;
    }
    std::vector<std::uint8_t> tmp(static_cast<std::size_t>(it->length));
    const InResult r = model_.on_in(it->ep, tmp, now_us);
    if (r.kind == InResult::kWait) {
      // Later URBs on the same endpoint must wait behind this one.
      const std::uint8_t ep = it->ep;
      ++it;
      while (it != pending_.end() && it->ep == ep) ++it;
      continue;
    }
    if (r.kind == InResult::kData) {
      umockdev_ioctl_data_update(it->buf, 0, tmp.data(), r.length);
      finish(*it, 0, r.length);
    } else {
      finish(*it, r.status, 0);
    }
    it = pending_.erase(it);
  }
}

// Interrupt IN: the host polls each endpoint every bInterval frames; a poll moves at most one
// packet, and only if the device has it ready then. The first pending URB of an endpoint gets the
// polls from its submission on (hidapi keeps one submitted all the time).
void UsbdevfsDevice::pump_interrupt_in(std::int64_t now_us) {
  for (auto& [ep, e] : eps_) {
    if ((ep & 0x80) == 0 || e.interval_frames == 0) continue;
    for (int guard = 0; guard < 10000; ++guard) {
      const auto it = std::find_if(pending_.begin(), pending_.end(), [ep = ep](const Urb& u) { return u.ep == ep; });
      if (it == pending_.end()) break;
      if (inject_ep_ == ep) {
        inject_ep_ = -1;
        finish(*it, inject_status_, 0);
        pending_.erase(it);
        continue;
      }
      const std::int64_t slot = next_poll(ep, std::max(it->submit_us, e.next_poll_us));
      if (slot > now_us) break;
      e.next_poll_us = slot + 1;
      std::vector<std::uint8_t> tmp(static_cast<std::size_t>(std::min(it->length, std::max(1, e.max_packet))));
      const InResult r = model_.on_in(ep, tmp, slot);
      if (r.kind == InResult::kWait) continue;  // NAK: the next poll
      if (r.kind == InResult::kData) {
        umockdev_ioctl_data_update(it->buf, 0, tmp.data(), r.length);
        finish(*it, 0, r.length);
        if (last_out_us_ >= 0) {
          figures_.round_trip_ms.push_back(static_cast<double>(now_us - last_out_us_) / 1000.0);
          last_out_us_ = -1;
        }
      } else {
        finish(*it, r.status, 0);
      }
      pending_.erase(it);
    }
  }
}

bool UsbdevfsDevice::deliver_ready(UMockdevIoctlClient* client) {
  if (ready_.empty()) return false;
  Urb u = ready_.front();
  ready_.pop_front();
  GError* err = nullptr;
  UMockdevIoctlData* p = umockdev_ioctl_data_resolve(umockdev_ioctl_client_get_arg(client), 0,
                                                     sizeof(void*), &err);
  if (p == nullptr) {
    if (err) g_error_free(err);
    umockdev_ioctl_client_complete(client, -1, EFAULT);
  } else {
    umockdev_ioctl_data_set_ptr(p, 0, u.urb);  // on the resolved p, not on arg (note, item 4)
    umockdev_ioctl_client_complete(client, 0, 0);
  }
  g_object_unref(u.urb);
  g_object_unref(u.buf);
  return true;
}

struct Deferred {
  UsbdevfsDevice* self;
  UMockdevIoctlClient* client;
};

gboolean UsbdevfsDevice::on_deferred_reap(gpointer data) {
  auto* d = static_cast<Deferred*>(data);
  UsbdevfsDevice* self = d->self;
  {
    std::lock_guard lock(self->mu_);
    self->pump(g_get_real_time());
    if (!self->deliver_ready(d->client)) {
      umockdev_ioctl_client_complete(d->client, -1, self->unplugged_ ? ENODEV : EAGAIN);
    }
  }
  g_object_unref(d->client);
  delete d;
  return G_SOURCE_REMOVE;
}

gboolean UsbdevfsDevice::on_ioctl(UMockdevIoctlClient* client) {
  const gulong req = umockdev_ioctl_client_get_request(client);
  std::lock_guard lock(mu_);
  if (ctx_ == nullptr) {
    ctx_ = g_main_context_get_thread_default();
    if (ctx_ == nullptr) ctx_ = g_main_context_default();
  }
  switch (req) {
    case USBDEVFS_SUBMITURB:
      if (unplugged_) {
        umockdev_ioctl_client_complete(client, -1, ENODEV);
        return TRUE;
      }
      submit(client);
      return TRUE;
    case USBDEVFS_REAPURB:
    case USBDEVFS_REAPURBNDELAY: {
      ++reaps_;
      pump(g_get_real_time());
      if (deliver_ready(client)) return TRUE;
      if (unplugged_) {
        umockdev_ioctl_client_complete(client, -1, ENODEV);
        return TRUE;
      }
      // Nothing ready: answer in 1 ms (note, item 6), with data if the clock produced some.
      GSource* src = g_timeout_source_new(1);
      g_source_set_callback(src, &UsbdevfsDevice::on_deferred_reap,
                            new Deferred{this, static_cast<UMockdevIoctlClient*>(g_object_ref(client))},
                            nullptr);
      g_source_attach(src, ctx_);
      g_source_unref(src);
      return TRUE;
    }
    case USBDEVFS_DISCARDURB: {
      // The argument is the URB's address in the client (not a pointer to it).
      UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
      guint64 addr = 0;
      if (arg->data_len >= static_cast<gint>(sizeof addr)) std::memcpy(&addr, arg->data, sizeof addr);
      for (auto* q : {&pending_, &timed_}) {
        for (auto it = q->begin(); it != q->end(); ++it) {
          if (it->urb->client_addr == addr || it->urb->client_addr == arg->client_addr) {
            finish(*it, -ENOENT, 0);
            q->erase(it);
            umockdev_ioctl_client_complete(client, 0, 0);
            return TRUE;
          }
        }
      }
      umockdev_ioctl_client_complete(client, -1, EINVAL);
      return TRUE;
    }
    case USBDEVFS_CLEAR_HALT: {
      if (unplugged_) {
        umockdev_ioctl_client_complete(client, -1, ENODEV);
        return TRUE;
      }
      GError* err = nullptr;
      UMockdevIoctlData* p = umockdev_ioctl_data_resolve(umockdev_ioctl_client_get_arg(client), 0,
                                                         sizeof(unsigned int), &err);
      if (err) g_error_free(err);
      unsigned int ep = 0;
      if (p != nullptr) std::memcpy(&ep, p->data, sizeof ep);
      model_.on_clear_halt(static_cast<std::uint8_t>(ep));
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    }
    case USBDEVFS_CLAIMINTERFACE:
    case USBDEVFS_RELEASEINTERFACE:
      if (!unplugged_) claimed_ += req == USBDEVFS_CLAIMINTERFACE ? 1 : -1;
      umockdev_ioctl_client_complete(client, unplugged_ ? -1 : 0, unplugged_ ? ENODEV : 0);
      return TRUE;
    case USBDEVFS_SETINTERFACE:
    case USBDEVFS_SETCONFIGURATION:
    case USBDEVFS_RESETEP:
    case USBDEVFS_DISCONNECT_CLAIM:
      umockdev_ioctl_client_complete(client, unplugged_ ? -1 : 0, unplugged_ ? ENODEV : 0);
      return TRUE;
    case USBDEVFS_GETDRIVER:
    case USBDEVFS_IOCTL:
      umockdev_ioctl_client_complete(client, -1, ENODATA);  // no kernel driver bound
      return TRUE;
    case USBDEVFS_GET_CAPABILITIES: {
      GError* err = nullptr;
      UMockdevIoctlData* p = umockdev_ioctl_data_resolve(umockdev_ioctl_client_get_arg(client), 0,
                                                         sizeof(guint32), &err);
      if (err) g_error_free(err);
      guint32 caps = 0;
      if (p != nullptr) umockdev_ioctl_data_update(p, 0, reinterpret_cast<guint8*>(&caps), sizeof caps);
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    }
    default:
      return FALSE;
  }
}

}  // namespace pof::vusb
