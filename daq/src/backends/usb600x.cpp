// NI USB-6008/6009 backend: libusb, asynchronous bulk-IN with several transfers in flight, handled
// by one event thread (the daemon's acquisition thread). Protocol: protocol/ni_usb600x.hpp.
//
// Continuous acquisition (protocol [10]): back-to-back finite segments. The data transfers never
// ask for more than the segment has left, so when the last byte of a segment has arrived no
// transfer is in flight; the event loop then re-arms (0F/00..10/03, synchronous, same thread) and
// resubmits. The scan index carries over; the clock is re-anchored (ScanClock).
//
// A fresh libusb context per open: enumeration then reflects unplug/replug without depending on
// hot-plug events (which the umockdev testbed does not deliver), and nothing from a dead device
// survives into the next session.
#include <libusb-1.0/libusb.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <vector>

#include "pof/daq/stream/backend.hpp"
#include "pof/daq/stream/config.hpp"
#include "pof/daq/device_ids.hpp"
#include "pof/raw_block_t.hpp"
#include "pof/daq/protocol/ni_usb600x.hpp"
#include "pof/lcm/utime.hpp"

namespace pof::daq {
namespace {

using pof::lcmutil::now_utime;

std::string hex(std::span<const std::uint8_t> b) {
  std::string s;
  char tmp[4];
  for (auto v : b) {
    std::snprintf(tmp, sizeof tmp, "%02X ", v);
    s += tmp;
  }
  if (!s.empty()) s.pop_back();
  return s;
}

class Usb600xBackend final : public Backend {
 public:
  explicit Usb600xBackend(const DaqConfig& cfg)
      : cfg_(cfg), id_(*find_device_id(cfg.device_kind)) {
    for (const auto& c : cfg.channels()) ai_.push_back(static_cast<std::uint8_t>(c.ai));
    n_ch_ = ai_.size();
    coding_ = id_.model == DeviceModel::kUsb6009 ? ni::usb6009_coding()
                                                 : ni::usb6008_coding(cfg.sample_byte_order);
    // Only the USB-6008's byte order is disputed (protocol [9]); the 6009's is [C]'s.
    detect_order_ = id_.model != DeviceModel::kUsb6009 && cfg.sample_byte_order_auto;
    divisor_ = ni::clock_divisor(cfg.scan_rate_hz);
    rate_hz_ = ni::rate_for_divisor(divisor_);
    std::uint32_t seg = cfg.segment_scans != 0 ? cfg.segment_scans : ni::max_segment_scans(n_ch_);
    seg -= seg % static_cast<std::uint32_t>(cfg.decimate);
    seg_scans_ = seg;
    seg_bytes_ = std::uint64_t{seg} * n_ch_ * 2;
    if (cfg.transfer_bytes > 0) {
      xfer_bytes_ = static_cast<std::size_t>(cfg.transfer_bytes);
    } else {
      // ~4 ms of data per transfer: latency stays a few ms while the transfer rate stays a few
      // hundred per second even at 48 kS/s (docs/daq.md, "Latency").
      const double bytes_per_ms = rate_hz_ * static_cast<double>(n_ch_) * 2.0 / 1000.0;
      const auto packets = static_cast<std::size_t>(bytes_per_ms * 4.0 / 64.0);
      xfer_bytes_ = std::clamp<std::size_t>(packets, 1, 64) * ni::kMaxPacket;
    }
    name_ = std::string(id_.description) + " " + vidpid();
  }

  ~Usb600xBackend() override { close(); }

  OpenStatus open(std::string& why) override {
    close();
    int rc = libusb_init(&ctx_);
    if (rc != 0) {
      ctx_ = nullptr;
      why = std::string("libusb_init: ") + libusb_error_name(rc);
      return OpenStatus::kFault;
    }
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(ctx_, &list);
    libusb_device* found = nullptr;
    int matches = 0;
    for (ssize_t i = 0; i < n; ++i) {
      libusb_device_descriptor d{};
      if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
      if (d.idVendor != id_.vendor_id || d.idProduct != id_.product_id) continue;
      ++matches;
      if (!cfg_.serial.empty() && serial_of(list[i], d) != cfg_.serial) continue;
      if (found == nullptr) found = list[i];
    }
    if (found == nullptr) {
      if (n >= 0) libusb_free_device_list(list, 1);
      why = "no " + name_ + (cfg_.serial.empty() ? "" : " with serial '" + cfg_.serial + "'") +
            " attached" + (matches > 0 ? " (" + std::to_string(matches) + " with other serials)" : "");
      return OpenStatus::kAbsent;
    }
    {
      libusb_device_descriptor d{};
      found_serial_ = libusb_get_device_descriptor(found, &d) == 0 ? serial_of(found, d) : std::string{};
    }
    bus_ = libusb_get_bus_number(found);
    addr_ = libusb_get_device_address(found);
    rc = libusb_open(found, &h_);
    libusb_free_device_list(list, 1);
    if (rc != 0) {
      h_ = nullptr;
      why = where() + ": libusb_open: " + libusb_error_name(rc) +
            (rc == LIBUSB_ERROR_ACCESS ? " (install deploy/udev/60-pof-daq.rules and join group pof)" : "");
      return rc == LIBUSB_ERROR_NO_DEVICE ? OpenStatus::kAbsent : OpenStatus::kFault;
    }
    if (matches > 1 && cfg_.serial.empty()) {
      why = std::to_string(matches) + " devices match; using " + where() + " (set device.serial)";
    }
    // Detach a kernel driver only when one is bound (no driver claims these IDs on stock
    // kernels). Not auto-detach: its DISCONNECT_CLAIM ioctl is one a capture replay cannot answer.
    if (libusb_kernel_driver_active(h_, 0) == 1) (void)libusb_detach_kernel_driver(h_, 0);
    rc = libusb_claim_interface(h_, 0);
    if (rc != 0) {
      why = where() + ": claim interface 0: " + libusb_error_name(rc);
      return rc == LIBUSB_ERROR_NO_DEVICE ? OpenStatus::kAbsent : OpenStatus::kFault;
    }
    claimed_ = true;
    (void)libusb_clear_halt(h_, ni::kEpDataIn);  // a stall left over from an earlier session

    ni::ScanProgram prog;
    prog.channels = ai_;
    prog.terminal = cfg_.terminal;
    prog.range_v = cfg_.range_v;
    prog.clock_divisor = divisor_;
    // Hello with header 00 00; the reply's header byte is then used for every request (protocol
    // [3][4]: the sources disagree on it).
    hh_ = 0;
    if (const OpenStatus st = command(ni::make_frame(ni::Cmd::kHello), cfg_.command_timeout_ms, why, &hh_);
        st != OpenStatus::kOk) {
      return st;
    }
    std::vector<ni::Frame> frames = ni::session_frames(hh_);
    for (auto& f : ni::configure_frames(prog, hh_)) frames.push_back(f);
    for (const auto& f : frames) {
      const OpenStatus st = command(f, cfg_.command_timeout_ms, why);
      if (st != OpenStatus::kOk) return st;
    }
    detector_ = ni::ByteOrderDetector(coding_.bits, n_ch_);  // re-told for every device session
    if (detect_order_) coding_.order = detector_.order();
    // Transfers and buffers: allocated here, reused for the whole session.
    const std::size_t nx = static_cast<std::size_t>(cfg_.transfers_in_flight);
    bufs_.assign(nx, std::vector<std::uint8_t>(xfer_bytes_));
    for (std::size_t i = 0; i < nx; ++i) {
      libusb_transfer* t = libusb_alloc_transfer(0);
      if (t == nullptr) {
        why = "libusb_alloc_transfer failed";
        return OpenStatus::kFault;
      }
      xfers_.push_back(t);
    }
    active_.assign(nx, 0);
    scratch_.assign(xfer_bytes_ + 2 * n_ch_, 0);
    volts_.assign((xfer_bytes_ / 2 + n_ch_) , 0.0F);
    return OpenStatus::kOk;
  }

  StreamEnd stream(ScanSink& sink, const std::atomic<bool>& stop, std::string& why) override {
    sink_ = &sink;
    end_ = false;
    end_kind_ = StreamEnd::kStopped;
    end_why_ = nullptr;
    end_detail_ = 0;
    if (!start_segment(false, why)) return StreamEnd::kError;
    bool stopping = false;
    for (;;) {
      timeval tv{0, 100000};  // 100 ms: the longest SIGTERM waits for the loop
      const int rc = libusb_handle_events_timeout_completed(ctx_, &tv, nullptr);
      if (rc != 0 && rc != LIBUSB_ERROR_INTERRUPTED) fail(StreamEnd::kError, "libusb_handle_events", rc);
      if (!stopping && stop.load(std::memory_order_relaxed)) {
        stopping = true;
        end_ = true;
        end_kind_ = StreamEnd::kStopped;
      }
      if (end_) {
        if (in_flight_ == 0) break;
        cancel_all();
        continue;
      }
      if (received_ == seg_bytes_ && in_flight_ == 0) {  // segment complete: re-arm [10]
        if (!start_segment(true, why)) return StreamEnd::kError;
        continue;
      }
      if (in_flight_ > 0 && now_utime() - last_progress_us_ > std::int64_t{cfg_.data_timeout_ms} * 1000) {
        fail(StreamEnd::kError, "no data on endpoint 0x82 within acquisition.data_timeout_ms", 0);
      }
    }
    if (end_kind_ != StreamEnd::kStopped) {
      why = where() + ": " + (end_why_ != nullptr ? end_why_ : "error");
      if (end_detail_ != 0) why += std::string(" (") + libusb_error_name(end_detail_) + ")";
      if (end_bytes_ >= 0) why += " [" + std::to_string(end_bytes_) + " bytes]";
    }
    return end_kind_;
  }

  void close() noexcept override {
    if (h_ != nullptr) {
      if (claimed_ && !gone_) {
        std::string ignored;
        for (const auto& f : ni::stop_frames(hh_)) {  // best effort: the device may be gone
          if (command(f, 200, ignored) != OpenStatus::kOk) break;
        }
        (void)libusb_release_interface(h_, 0);
      }
      claimed_ = false;
      libusb_close(h_);
      h_ = nullptr;
    }
    for (auto* t : xfers_) libusb_free_transfer(t);
    xfers_.clear();
    if (ctx_ != nullptr) {
      libusb_exit(ctx_);
      ctx_ = nullptr;
    }
    gone_ = false;
  }

  [[nodiscard]] DeviceIdentity identity() const override {
    return {std::string(id_.kind), id_.vendor_id, id_.product_id,
            found_serial_.empty() ? cfg_.serial : found_serial_};
  }
  [[nodiscard]] double device_scan_rate_hz() const override { return rate_hz_; }

 private:
  [[nodiscard]] std::string vidpid() const {
    char b[16];
    std::snprintf(b, sizeof b, "%04x:%04x", id_.vendor_id, id_.product_id);
    return b;
  }
  [[nodiscard]] std::string where() const {
    return name_ + " (bus " + std::to_string(bus_) + " device " + std::to_string(addr_) + ")";
  }

  std::string serial_of(libusb_device* dev, const libusb_device_descriptor& d) {
    if (d.iSerialNumber == 0) return {};
    libusb_device_handle* h = nullptr;
    if (libusb_open(dev, &h) != 0) return {};
    unsigned char s[128] = {};
    const int n = libusb_get_string_descriptor_ascii(h, d.iSerialNumber, s, sizeof s);
    libusb_close(h);
    return n > 0 ? std::string(reinterpret_cast<char*>(s), static_cast<std::size_t>(n)) : std::string{};
  }

  // One command round trip: frame out on 0x01, reply in on 0x81, checked against the table [4].
  // `header`: where to store the reply's header byte 1 (00 or 01, protocol [3]).
  OpenStatus command(const ni::Frame& f, int timeout_ms, std::string& why, std::uint8_t* header = nullptr) {
    const auto parsed = ni::parse_frame(f.view());
    const ni::Opcode* oc = parsed ? ni::find_opcode(parsed->op, parsed->group) : nullptr;
    char label[48];
    std::snprintf(label, sizeof label, "'%s' (%02X/%02X)", oc != nullptr ? oc->name.data() : "?",
                  parsed ? parsed->op : 0, parsed ? parsed->group : 0);
    std::array<std::uint8_t, ni::kMaxPacket> out{};
    std::copy_n(f.bytes.begin(), f.size, out.begin());
    int done = 0;
    int rc = libusb_bulk_transfer(h_, ni::kEpCommandOut, out.data(), static_cast<int>(f.size), &done,
                                  static_cast<unsigned>(timeout_ms));
    if (rc == 0 && done != static_cast<int>(f.size)) rc = LIBUSB_ERROR_IO;
    if (rc == 0) {
      std::array<std::uint8_t, ni::kMaxPacket> in{};
      rc = libusb_bulk_transfer(h_, ni::kEpReplyIn, in.data(), static_cast<int>(in.size()), &done,
                                static_cast<unsigned>(timeout_ms));
      if (rc == 0) {
        const auto hh = oc != nullptr ? ni::reply_header(oc->cmd, std::span(in.data(), static_cast<std::size_t>(done)))
                                      : std::nullopt;
        if (hh) {
          if (header != nullptr) *header = *hh;
          return OpenStatus::kOk;
        }
        why = where() + ": unexpected reply to " + label + ": " +
              hex(std::span(in.data(), static_cast<std::size_t>(done)));
        return OpenStatus::kFault;
      }
    }
    if (rc == LIBUSB_ERROR_NO_DEVICE) gone_ = true;
    why = where() + ": command " + label + ": " + libusb_error_name(rc) +
          (rc == LIBUSB_ERROR_TIMEOUT ? " (the device did not answer within " +
                                            std::to_string(timeout_ms) + " ms)"
                                      : "");
    return rc == LIBUSB_ERROR_NO_DEVICE ? OpenStatus::kAbsent : OpenStatus::kFault;
  }

  bool start_segment(bool continuous, std::string& why) {
    std::int64_t sent_us = 0;
    for (const auto& f : ni::start_frames(seg_scans_, n_ch_, hh_)) {
      sent_us = now_utime();
      if (command(f, cfg_.command_timeout_ms, why) != OpenStatus::kOk) {
        sink_->on_usb_error();
        return false;
      }
    }
    // Sampling starts when the device gets the last start command (10/03, protocol [8]): between
    // sending it and its acknowledgement; ScanClock narrows that interval from the data.
    sink_->on_segment_start(sent_us, now_utime(), continuous);
    sink_->on_variant(variant_bits());
    received_ = 0;
    requested_ = 0;
    carry_n_ = 0;
    last_progress_us_ = now_utime();
    for (std::size_t i = 0; i < xfers_.size() && !end_; ++i) submit(i);
    return true;
  }

  void submit(std::size_t i) {
    const std::uint64_t left = seg_bytes_ - requested_;
    if (left == 0) return;
    const auto len = static_cast<int>(std::min<std::uint64_t>(xfer_bytes_, left));
    libusb_transfer* t = xfers_[i];
    libusb_fill_bulk_transfer(t, h_, ni::kEpDataIn, bufs_[i].data(), len, &Usb600xBackend::on_transfer,
                              this, 0);
    t->flags = 0;
    const int rc = libusb_submit_transfer(t);
    if (rc != 0) {
      fail(rc == LIBUSB_ERROR_NO_DEVICE ? StreamEnd::kDisconnected : StreamEnd::kError,
           "submitting a data transfer", rc);
      return;
    }
    active_[i] = 1;
    requested_ += static_cast<std::uint64_t>(len);
    ++in_flight_;
  }

  void cancel_all() {
    for (std::size_t i = 0; i < xfers_.size(); ++i) {
      if (active_[i] != 0) (void)libusb_cancel_transfer(xfers_[i]);
    }
  }

  // Streaming-path failure: record (no allocation, no logging), stop resubmitting.
  void fail(StreamEnd kind, const char* what, int detail, long bytes = -1) {
    if (end_) return;
    end_ = true;
    end_kind_ = kind;
    end_why_ = what;
    end_detail_ = detail;
    end_bytes_ = bytes;
    if (kind == StreamEnd::kDisconnected) gone_ = true;
  }

  static void LIBUSB_CALL on_transfer(libusb_transfer* t) {
    auto* self = static_cast<Usb600xBackend*>(t->user_data);
    self->handle(t);
  }

  void handle(libusb_transfer* t) {
    std::size_t i = 0;
    while (xfers_[i] != t) ++i;
    active_[i] = 0;
    --in_flight_;
    // Error and shutdown first (libfprint habit).
    switch (t->status) {
      case LIBUSB_TRANSFER_COMPLETED:
        break;
      case LIBUSB_TRANSFER_CANCELLED:
        return;
      case LIBUSB_TRANSFER_NO_DEVICE:
        sink_->on_usb_error();
        fail(StreamEnd::kDisconnected, "device removed", LIBUSB_ERROR_NO_DEVICE);
        return;
      case LIBUSB_TRANSFER_STALL:
        sink_->on_usb_error();
        fail(StreamEnd::kError, "endpoint 0x82 stalled", LIBUSB_ERROR_PIPE);
        return;
      default:
        sink_->on_usb_error();
        fail(StreamEnd::kError, "data transfer failed", LIBUSB_ERROR_IO);
        return;
    }
    const std::int64_t arrival = now_utime();
    requested_ -= static_cast<std::uint64_t>(t->length - t->actual_length);  // short: re-request
    if (t->actual_length > 0) {
      last_progress_us_ = arrival;
      if (!consume(t->buffer, static_cast<std::size_t>(t->actual_length), arrival)) return;
    }
    if (!end_) submit(i);
  }

  [[nodiscard]] std::uint32_t variant_bits() const {
    std::uint32_t v = hh_ == 0 ? kVariantHeader0000 : kVariantHeader0001;
    if (detect_order_ && !detector_.decided()) {
      v |= kVariantOrderUndecided;
    } else {
      v |= coding_.order == ni::ByteOrder::kBig ? kVariantBigEndian : kVariantLittleEndian;
    }
    if (padding_seen_) v |= kVariantPaddingSet;
    return v;
  }

  // Decodes one transfer. Framing is validated before the sink sees any of it: a malformed
  // transfer is dropped whole and the session restarts (never pass bad samples on). Padding bits
  // are counted, not an error (protocol [9]). While the USB-6008's byte order is not yet told
  // from the data, the scans carry FLAG_DOUBTFUL (never published as good).
  bool consume(const std::uint8_t* data, std::size_t len, std::int64_t arrival) {
    if ((len & 1U) != 0U || received_ + len > seg_bytes_) {
      sink_->on_usb_error();
      fail(StreamEnd::kError, (len & 1U) != 0U ? "odd-length data packet" : "more data than the segment holds", 0,
           static_cast<long>(len));
      return false;
    }
    received_ += len;
    std::memcpy(scratch_.data() + carry_n_, data, len);
    const std::size_t total = carry_n_ + len;
    const std::size_t scan_bytes = 2 * n_ch_;
    const std::size_t n_scans = total / scan_bytes;
    const auto max_code = static_cast<std::uint16_t>((1U << coding_.bits) - 1U);
    bool changed = false;
    if (detect_order_ && detector_.feed(scratch_.data(), n_scans)) {
      coding_.order = detector_.order();
      changed = true;
    }
    std::int32_t flags = detect_order_ && !detector_.decided() ? int32_t{pof::raw_block_t::FLAG_DOUBTFUL} : 0;
    std::size_t padded = 0;
    for (std::size_t s = 0; s < n_scans * n_ch_; ++s) {
      const ni::Sample v = ni::decode_sample(&scratch_[2 * s], coding_);
      padded += v.padding_set ? 1U : 0U;
      if (v.code == 0 || v.code == max_code) flags |= int32_t{pof::raw_block_t::FLAG_OVER_RANGE};
      volts_[s] = static_cast<float>(ni::code_to_volts(v.code, coding_.bits, cfg_.range_v));
    }
    // Read in a byte order not yet told, padding bits say nothing about the device: not counted.
    if (padded > 0 && (!detect_order_ || detector_.decided())) {
      sink_->on_padding_set(padded);
      changed = changed || !padding_seen_;
      padding_seen_ = true;
    }
    if (changed) sink_->on_variant(variant_bits());
    carry_n_ = total - n_scans * scan_bytes;
    std::memmove(scratch_.data(), scratch_.data() + n_scans * scan_bytes, carry_n_);
    sink_->on_scans(volts_.data(), n_scans, arrival, flags);
    return true;
  }

  DaqConfig cfg_;
  DeviceId id_;
  std::vector<std::uint8_t> ai_;
  std::size_t n_ch_ = 0;
  ni::SampleCoding coding_{12, ni::ByteOrder::kBig};
  bool detect_order_ = false;
  ni::ByteOrderDetector detector_{12, 1};
  bool padding_seen_ = false;  // kept across sessions: the report is about the device
  std::uint8_t hh_ = 0;  // header byte 1 of the device's replies (protocol [3])
  std::uint32_t divisor_ = 0;
  double rate_hz_ = 0;
  std::uint32_t seg_scans_ = 0;
  std::uint64_t seg_bytes_ = 0;
  std::size_t xfer_bytes_ = 64;
  std::string name_;

  libusb_context* ctx_ = nullptr;
  libusb_device_handle* h_ = nullptr;
  int bus_ = 0;
  int addr_ = 0;
  std::string found_serial_;  // the serial of the device opened last (string descriptor)
  bool claimed_ = false;
  bool gone_ = false;
  std::vector<libusb_transfer*> xfers_;
  std::vector<std::vector<std::uint8_t>> bufs_;
  std::vector<char> active_;
  std::vector<std::uint8_t> scratch_;
  std::vector<float> volts_;
  std::size_t carry_n_ = 0;

  ScanSink* sink_ = nullptr;
  int in_flight_ = 0;
  std::uint64_t received_ = 0;
  std::uint64_t requested_ = 0;
  std::int64_t last_progress_us_ = 0;
  bool end_ = false;
  StreamEnd end_kind_ = StreamEnd::kStopped;
  const char* end_why_ = nullptr;
  int end_detail_ = 0;
  long end_bytes_ = -1;
};

}  // namespace

std::unique_ptr<Backend> make_usb600x_backend(const DaqConfig& cfg) {
  return std::make_unique<Usb600xBackend>(cfg);
}

}  // namespace pof::daq
