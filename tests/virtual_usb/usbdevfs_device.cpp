// usbdevfs emulation on umockdev: see usbdevfs_device.hpp and docs/virtual-usb.md.
#include "usbdevfs_device.hpp"

// <sys/ioctl.h> before <linux/usbdevice_fs.h> (note, item 4).
#include <sys/ioctl.h>
#include <linux/usbdevice_fs.h>

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

void UsbdevfsDevice::add_record() {
  char rec[4096];
  std::snprintf(rec, sizeof rec,
                "P: %s\nN: bus/usb/001/002\nE: DEVNAME=%s\nE: DEVTYPE=usb_device\nE: SUBSYSTEM=usb\n"
                "E: BUSNUM=001\nE: DEVNUM=002\nA: busnum=1\\n\nA: devnum=2\\n\n"
                "A: idVendor=%04x\\n\nA: idProduct=%04x\\n\nA: speed=12\\n\n"
                "A: bConfigurationValue=1\\n\nH: descriptors=%s\n",
                kSysfs, kDevNode, ids_.vendor, ids_.product, ids_.descriptors_hex.c_str());
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
  if (u.type == USBDEVFS_URB_TYPE_CONTROL) {
    std::span<std::uint8_t> data(buf->data + 8, static_cast<std::size_t>(std::max(0, u.buffer_length - 8)));
    const std::uint8_t* setup = buf->data;
    const int r = model_.on_control(setup, data, now);
    if (r >= 0) {
      if ((setup[0] & 0x80) != 0) umockdev_ioctl_data_update(buf, 8, data.data(), r);
      finish(q, 0, r);
    } else {
      finish(q, r, 0);
    }
  } else if ((u.endpoint & 0x80) == 0) {
    model_.on_out(u.endpoint, std::span<const std::uint8_t>(buf->data, static_cast<std::size_t>(u.buffer_length)), now);
    finish(q, 0, u.buffer_length);
  } else {
    pending_.push_back(q);
  }
  umockdev_ioctl_client_complete(client, 0, 0);
}

// Completes the pending IN URBs whose data the model has now, in submission order per endpoint.
void UsbdevfsDevice::pump(std::int64_t now_us) {
  for (auto it = pending_.begin(); it != pending_.end();) {
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
      for (auto it = pending_.begin(); it != pending_.end(); ++it) {
        if (it->urb->client_addr == addr || it->urb->client_addr == arg->client_addr) {
          finish(*it, -ENOENT, 0);
          pending_.erase(it);
          umockdev_ioctl_client_complete(client, 0, 0);
          return TRUE;
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
