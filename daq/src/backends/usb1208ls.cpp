// MCC USB-1208LS backend over hidapi (libusb flavour, so that the same usbdevfs emulation serves
// the tests). Protocol: protocol/mcc_usb1208ls.hpp.
//
// Acquisition: back-to-back single-execution AInScans (protocol [9]) read as 104- or 105-byte
// feature reports (the length decides: protocol [7]); the report's scan index must be the next
// expected one, a repeat means "not ready yet" (the device answers a feature request with its
// last report, per the public driver's polling loop [7]). The report layout is detected from the
// first reports of a session (protocol [7]) and, single-ended, the scan coding from an AIn
// reading taken at open: reports are held back until both are known, so nothing is published
// from a guess. Every seam between executions is published as lost scans (FLAG_GAP).
// At open the feature report is read once: a device that refuses it (protocol [9]) is a fault
// with its reason, or, with acquisition.mcc_mode = "auto", read by single AIns instead.
// A channel list the device cannot queue (3, 5-7) is padded (protocol [9]); the padding inputs
// are scanned and their samples dropped here.
// hidapi is synchronous: the acquisition thread asks for each report when the device's timer says
// it is complete, then polls with a 1 ms pause between empty answers.
#include <hidapi/hidapi.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <thread>
#include <utility>
#include <vector>

#include "pof/daq/stream/backend.hpp"
#include "pof/daq/backends/pacing.hpp"
#include "pof/daq/stream/config.hpp"
#include "pof/raw_block_t.hpp"
#include "pof/daq/protocol/mcc_usb1208ls.hpp"
#include "pof/lcm/utime.hpp"

namespace pof::daq {
namespace {

using pof::lcmutil::now_utime;

// How much faster than nominal a device's scan timer may run when the backend times its requests
// for a report (2000 ppm: twice the drift ScanClock follows).
constexpr double kClockTolerance = 2000e-6;

class Usb1208lsBackend final : public Backend {
 public:
  explicit Usb1208lsBackend(const DaqConfig& cfg) : cfg_(cfg) {
    for (const auto& c : cfg.channels()) ai_.push_back(static_cast<std::uint8_t>(c.ai));
    n_ch_ = ai_.size();
    const bool differential = cfg.terminal == ni::Terminal::kDifferential;
    // Pad the queue to 1, 2, 4 or 8 entries [3][9] with the lowest inputs not in use (also in
    // single-read mode, which loads the queue at open but reads only the configured channels).
    const std::size_t want = mcc::queue_length(n_ch_);
    for (std::uint8_t ai = 0; ai < (differential ? 4 : 8) && ai_.size() < want; ++ai) {
      if (std::find(ai_.begin(), ai_.end(), ai) == ai_.end()) ai_.push_back(ai);
    }
    n_queue_ = ai_.size();
    gain_ = mcc::gain_for(differential, cfg.range_v).value_or(mcc::kSe10V);
    // The device scans the queue at the timer rate: the aggregate sample rate is rate x queue.
    timer_ = mcc::scan_timer(cfg.scan_rate_hz * static_cast<double>(n_queue_));
    rate_hz_ = timer_ ? timer_->actual_rate_hz / static_cast<double>(n_queue_) : cfg.scan_rate_hz;
    single_ = cfg.mcc_single_reads;
    if (single_) rate_hz_ = cfg.scan_rate_hz;  // host-paced
    // An execution: whole reports and whole queue cycles, as long as the 16-bit count allows
    // [9] (each seam between two is a hole, published as such), or acquisition.segment_scans.
    const std::size_t unit = mcc::kSamplesPerScanReport * n_queue_;
    std::size_t burst = mcc::kMaxScanCount / unit * unit;
    if (cfg.segment_scans > 0) {
      burst = std::min<std::size_t>(burst, static_cast<std::size_t>(cfg.segment_scans) * n_queue_ / unit * unit);
    }
    if (burst < 2 * unit) burst = 2 * unit;  // the layout is known within the first scan [7]
    burst_samples_ = burst;
    volts_.assign(mcc::kSamplesPerScanReport + n_queue_, 0.0F);
  }
  ~Usb1208lsBackend() override { close(); }

  OpenStatus open(std::string& why) override {
    close();
    if (!timer_ && !cfg_.mcc_single_reads) {
      why = "acquisition.scan_rate_hz x channels must be within 100-8191 samples/s on the USB-1208LS";
      return OpenStatus::kFault;
    }
    if (hid_init() != 0) {
      why = "hid_init failed";
      return OpenStatus::kFault;
    }
    std::wstring wserial(cfg_.serial.begin(), cfg_.serial.end());
    dev_ = hid_open(mcc::kVendorId, mcc::kProductId, cfg_.serial.empty() ? nullptr : wserial.c_str());
    if (dev_ == nullptr) {
      hid_device_info* list = hid_enumerate(mcc::kVendorId, mcc::kProductId);
      const bool present = list != nullptr;
      hid_free_enumeration(list);
      why = present ? "MCC USB-1208LS 09db:007a present but cannot be opened (permissions? install "
                      "deploy/udev/60-pof-daq.rules)"
                    : "no MCC USB-1208LS 09db:007a attached";
      return present ? OpenStatus::kFault : OpenStatus::kAbsent;
    }
    if (!write(mcc::ain_stop_report(), why)) return OpenStatus::kFault;
    detector_ = mcc::LayoutDetector{};  // another device may have been plugged in
    // [9] the feature report the scan is read with, once before the scan: a device that refuses
    // it (while it answers AIn) cannot scan.
    if (!single_) {
      Report probe{};
      if (hid_get_feature_report(dev_, probe.data(), probe.size()) < 0) {
        std::int16_t counts = 0;
        if (!ain(ai_[0], counts, why)) return OpenStatus::kFault;  // not answering at all
        if (!cfg_.mcc_fallback_single || reported_rate_) {
          why = "MCC USB-1208LS: the device refuses the scan feature report (GET_REPORT fails while "
                "AIn answers; known with hidapi-libusb): AInScan cannot be read. " +
                std::string(reported_rate_ ? "The software-paced fallback needs a restart of pof-daqd (the published rate is set)"
                                           : "Set acquisition.mcc_mode = \"auto\" for software-paced AIn reads (at most 50/s)");
          return OpenStatus::kFault;
        }
        // [8] software-paced: kFallbackReadsHz AIn reads per second over the channels, for the
        // rest of the process (the published rate is set at the first open).
        single_ = true;
        fallback_ = true;
        rate_hz_ = mcc::kFallbackReadsHz / static_cast<double>(n_ch_);
      }
    }
    std::array<mcc::OutReport, 2> q{};
    const std::size_t nq = mcc::load_queue_reports(ai_, gain_, q);
    for (std::size_t i = 0; i < nq; ++i) {
      if (!write(q[i], why)) return OpenStatus::kFault;
    }
    if (single_) return opened();
    // [7] evidence for the single-ended scan coding: an AIn reading of the first queued input,
    // compared with its first scan sample once the scan runs.
    probe_ain_.reset();
    if (gain_ == mcc::kSe10V) {
      std::int16_t counts = 0;
      if (!ain(ai_[0], counts, why)) return OpenStatus::kFault;
      probe_ain_ = counts;
    }
    return opened();
  }

  OpenStatus opened() {
    reported_rate_ = true;  // the daemon reads device_scan_rate_hz() after the first kOk
    return OpenStatus::kOk;
  }

  bool ain(std::uint8_t channel, std::int16_t& counts, std::string& why) {
    if (!write(mcc::ain_report(channel, gain_), why)) return false;
    std::array<std::uint8_t, mcc::kInReportBytes> in{};
    const int n = hid_read_timeout(dev_, in.data(), in.size(), 1500);  // [2]
    if (n < 2) {
      why = n < 0 ? "MCC USB-1208LS: reading an AIn reply failed (device removed?)"
                  : "MCC USB-1208LS: no AIn reply within 1.5 s";
      return false;
    }
    counts = gain_ == mcc::kSe10V ? mcc::decode_ain_single_ended(in[0], in[1])
                                  : mcc::decode_ain_differential(in[0], in[1]);
    return true;
  }

  StreamEnd stream(ScanSink& sink, const std::atomic<bool>& stop, std::string& why) override {
    if (single_) {
      if (fallback_) sink.on_variant(kVariantSoftwarePaced);
      return stream_single(sink, stop, why);
    }
    carry_n_ = 0;
    held_n_ = 0;
    se_coding_.reset();
    size_layout_.reset();
    variant_sent_ = false;
    if (detector_.decided()) sink.on_variant(variant_bits());
    while (!stop.load(std::memory_order_relaxed)) {
      const auto count = static_cast<std::uint16_t>(burst_samples_);
      const std::int64_t sent_us = now_utime();
      if (!write(mcc::ain_scan_report(count, *timer_, 0x1 /* single execution [6] */), why)) {
        sink.on_usb_error();
        return StreamEnd::kError;
      }
      // [9] never continuous: the device was idle since the last execution's last sample (the
      // seam), so the scans it did not take are published as lost (FLAG_GAP, dropped_scans).
      sink.on_segment_start(sent_us, now_utime(), false);
      // Report k is complete 64 k samples after the start, not before (minus the crystal's
      // tolerance): ask for it then. At low speed a GET_REPORT holds EP0 for ~16 frames (docs/daq.md,
      // fact 18), so a poll sent just before a report completes delays it by a whole transfer, and
      // the last one of an execution lengthens the seam by as much (the device is idle until the
      // next AInScan). Past the due time the loop polls as before.
      const auto started = std::chrono::steady_clock::now();
      const double report_s =
          static_cast<double>(mcc::kSamplesPerScanReport) / timer_->actual_rate_hz * (1.0 - kClockTolerance);
      carry_n_ = 0;  // an execution is whole queue cycles
      std::uint16_t expect = 1;
      std::size_t got = 0;
      auto last_progress = std::chrono::steady_clock::now();
      while (got < burst_samples_) {
        if (stop.load(std::memory_order_relaxed)) return StreamEnd::kStopped;
        const auto due = started + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                       std::chrono::duration<double>(report_s * expect));
        if (const auto now = std::chrono::steady_clock::now(); now < due) {
          std::this_thread::sleep_for(
              std::min<std::chrono::steady_clock::duration>(due - now, std::chrono::milliseconds(20)));
          continue;  // in steps, so that a stop is seen within 20 ms
        }
        Report& buf = held_[held_n_ < held_.size() ? held_n_ : 0];
        buf[0] = 0;  // report id
        const int n = hid_get_feature_report(dev_, buf.data(), buf.size());
        if (n < 0) {
          sink.on_usb_error();
          // hidapi-libusb 0.13 has no hid_error text; a failing control read means the device
          // went away (or was reset): re-open, which tells absent from faulty.
          why = "MCC USB-1208LS: reading a scan report failed (device removed?)";
          return StreamEnd::kDisconnected;
        }
        // hidapi counts the report id byte it skipped: n - 1 bytes came on the wire [7].
        const auto wire_n = static_cast<std::size_t>(n > 0 ? n - 1 : 0);
        if (!mcc::is_scan_report_size(wire_n) || (size_layout_ && wire_n != size_layout_->first)) {
          sink.on_usb_error();
          why = "MCC USB-1208LS: scan report of " + std::to_string(wire_n) +
                " bytes (expected 104 or 105, the same every time)";
          return StreamEnd::kError;
        }
        if (!size_layout_) size_layout_.emplace(wire_n, mcc::layout_for_size(wire_n));
        if (wire_n < mcc::kScanReportBytes) buf[mcc::kScanReportBytes] = 0;  // not on the wire
        const mcc::ScanReport wire(buf.data() + 1, mcc::kScanReportBytes);
        if (size_layout_->second && !detector_.decided()) detector_.force(*size_layout_->second);
        const bool next = detector_.decided() ? mcc::scan_index(wire, detector_.layout()) == expect
                                              : detector_.is_next(wire, expect);
        if (!next) {
          if (std::chrono::steady_clock::now() - last_progress >
              std::chrono::milliseconds(cfg_.data_timeout_ms)) {
            sink.on_usb_error();
            why = "MCC USB-1208LS: no new scan report within acquisition.data_timeout_ms";
            return StreamEnd::kError;
          }
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
          continue;
        }
        last_progress = std::chrono::steady_clock::now();
        ++expect;
        got += mcc::kSamplesPerScanReport;
        if (!detector_.decided()) {
          detector_.accept(wire, static_cast<std::uint16_t>(expect - 1));
          ++held_n_;  // held back until the layout is known [7]
          if (!detector_.decided() && held_n_ < held_.size()) continue;
          if (!detector_.decided()) {  // both index fields count alike: no source shows that
            sink.on_usb_error();
            why = "MCC USB-1208LS: cannot tell the feature-report layout (both scan-index fields count)";
            return StreamEnd::kError;
          }
        }
        if (held_n_ > 0) {  // the layout is known: decide the single-ended coding, then publish
          if (gain_ == mcc::kSe10V && !se_coding_) decide_se_coding(held_[0]);
          sink.on_variant(variant_bits());
          for (std::size_t i = 0; i < held_n_; ++i) deliver_report(sink, held_[i]);
          held_n_ = 0;
          variant_sent_ = true;
          continue;
        }
        if (!variant_sent_) {  // the layout told by the report's length: nothing held back
          if (gain_ == mcc::kSe10V && !se_coding_) decide_se_coding(buf);
          sink.on_variant(variant_bits());
          variant_sent_ = true;
        }
        deliver_report(sink, buf);
      }
    }
    return StreamEnd::kStopped;
  }

  // Single AIn reads [3][5], one per channel per scan, paced by the host clock (absolute
  // deadlines, so the rate does not drift). For slow rates and for checking a channel.
  StreamEnd stream_single(ScanSink& sink, const std::atomic<bool>& stop, std::string& why) {
    const timespec t0 = monotonic_now();
    const std::int64_t start = now_utime();
    sink.on_segment_start(start, start, false);
    const bool differential = cfg_.terminal == ni::Terminal::kDifferential;
    const double period = 1.0 / rate_hz_;
    double origin = 0;  // seconds after t0 the current schedule counts from
    for (std::uint64_t k = 0; !stop.load(std::memory_order_relaxed); ++k) {
      sleep_until(t0, origin + static_cast<double>(k + 1) * period);
      // Each read is a 10-20 ms round trip on the bus (docs/daq.md, fact 18): a late scan is taken
      // back to back with the next ones until the schedule is caught up, but one two periods late
      // (a host that stalled, or a rate the bus cannot carry) is not taken under an index that
      // says otherwise: the scans of that time are published as lost (FLAG_GAP, dropped_scans)
      // and the schedule starts again from now.
      const double now_s = seconds_since(t0);
      if (now_s - (origin + static_cast<double>(k + 1) * period) >= 2 * period) {
        const std::int64_t now = now_utime();
        sink.on_segment_start(now, now, false);
        origin = now_s - period;
        k = 0;
      }
      std::int32_t flags = 0;
      for (std::size_t c = 0; c < n_ch_; ++c) {
        if (!write(mcc::ain_report(ai_[c], gain_), why)) {
          sink.on_usb_error();
          return StreamEnd::kDisconnected;
        }
        std::array<std::uint8_t, mcc::kInReportBytes> in{};
        const int n = hid_read_timeout(dev_, in.data(), in.size(), 1500);  // [2]
        if (n < 2) {
          sink.on_usb_error();
          why = n < 0 ? "MCC USB-1208LS: reading an AIn reply failed (device removed?)"
                      : "MCC USB-1208LS: no AIn reply within 1.5 s";
          return n < 0 ? StreamEnd::kDisconnected : StreamEnd::kError;
        }
        const std::int16_t counts = differential ? mcc::decode_ain_differential(in[0], in[1])
                                                 : mcc::decode_ain_single_ended(in[0], in[1]);
        if (counts <= (differential ? -2048 : -1024) || counts >= (differential ? 2047 : 1023)) {
          flags |= int32_t{pof::raw_block_t::FLAG_OVER_RANGE};
        }
        volts_[c] = static_cast<float>(mcc::counts_to_volts(counts, gain_));
      }
      sink.on_scans(volts_.data(), 1, now_utime(), flags);
    }
    return StreamEnd::kStopped;
  }

  void close() noexcept override {
    if (dev_ != nullptr) {
      std::string ignored;
      (void)write(mcc::ain_stop_report(), ignored);
      hid_close(dev_);
      dev_ = nullptr;
      (void)hid_exit();
    }
  }

  [[nodiscard]] DeviceIdentity identity() const override {
    return {"usb1208ls", mcc::kVendorId, mcc::kProductId, cfg_.serial};
  }
  [[nodiscard]] double device_scan_rate_hz() const override { return rate_hz_; }

 private:
  bool write(const mcc::OutReport& r, std::string& why) {
    if (dev_ == nullptr) return false;
    if (hid_write(dev_, r.data(), r.size()) != static_cast<int>(r.size())) {
      char cmd[8];
      std::snprintf(cmd, sizeof cmd, "0x%02X", r[1]);
      why = std::string("MCC USB-1208LS: writing command ") + cmd + " failed (device removed or not answering)";
      return false;
    }
    return true;
  }

  using Report = std::array<std::uint8_t, mcc::kScanReportBytes + 1>;  // report id + report

  [[nodiscard]] std::uint32_t variant_bits() const {
    std::uint32_t bits = detector_.layout() == mcc::ReportLayout::kRecordFirst ? kVariantLayoutRecordFirst
                                                                               : kVariantLayoutDataFirst;
    if (size_layout_ && size_layout_->first == mcc::kScanReportBytesNoRecord) bits |= kVariantReport104;
    if (gain_ == mcc::kSe10V) {
      if (!se_coding_ || !*se_coding_) bits |= kVariantSeScanUndecided;
      else bits |= **se_coding_ == mcc::SeScanCoding::kOffset ? kVariantSeScanOffset : kVariantSeScanTwos;
    }
    return bits;
  }

  // [7] the first sample of a session's first report is the first queued input, read by AIn at
  // open: the coding under which both agree is the device's; none (no probe, or the input moved
  // by more than 2.5 V) leaves the session's blocks flagged doubtful.
  void decide_se_coding(const Report& first) {
    std::array<std::int16_t, mcc::kSamplesPerScanReport> s{};
    (void)mcc::decode_scan_report(mcc::ScanReport(first.data() + 1, mcc::kScanReportBytes), s, detector_.layout());
    se_coding_ = probe_ain_ ? mcc::se_scan_coding_from(*probe_ain_, mcc::scan_field12(s[0]))
                            : std::optional<mcc::SeScanCoding>{};
  }

  void deliver_report(ScanSink& sink, const Report& buf) {
    const mcc::ScanReport wire(buf.data() + 1, mcc::kScanReportBytes);
    std::array<std::int16_t, mcc::kSamplesPerScanReport> s{};
    (void)mcc::decode_scan_report(wire, s, detector_.layout());
    // The error byte follows the 96 data bytes [7] in either layout.
    const bool error = wire[(detector_.layout() == mcc::ReportLayout::kRecordFirst ? 1 : 0) + 96] != 0;
    if (error) sink.on_usb_error();
    deliver(sink, s, error);
  }

  // Splits 64 samples into whole queue cycles, carrying a partial one to the next report, and
  // keeps the configured channels (the first n_ch_ queue entries; the rest is padding [9]).
  void deliver(ScanSink& sink, const std::array<std::int16_t, mcc::kSamplesPerScanReport>& s, bool error) {
    std::size_t out = 0;
    std::int32_t flags = error ? int32_t{pof::raw_block_t::FLAG_DEVICE_ERROR} : 0;
    const int fs = mcc::full_scale_counts(gain_);
    const bool se = gain_ == mcc::kSe10V;
    const bool offset = se && se_coding_ && *se_coding_ && **se_coding_ == mcc::SeScanCoding::kOffset;
    if (se && (!se_coding_ || !*se_coding_)) flags |= int32_t{pof::raw_block_t::FLAG_DOUBTFUL};
    for (std::size_t i = 0; i < carry_n_; ++i) volts_[out++] = carry_[i];
    for (auto c : s) {
      if (offset) c = mcc::se_scan_counts(mcc::scan_field12(c), mcc::SeScanCoding::kOffset);
      if (c >= fs || c <= -fs - 1) flags |= int32_t{pof::raw_block_t::FLAG_OVER_RANGE};
      volts_[out++] = static_cast<float>(mcc::scan_counts_to_volts(c, gain_));
    }
    const std::size_t scans = out / n_queue_;
    carry_n_ = out - scans * n_queue_;
    for (std::size_t i = 0; i < carry_n_; ++i) carry_[i] = volts_[scans * n_queue_ + i];
    if (n_queue_ != n_ch_) {  // drop the padding entries, in place (k * n_ch_ <= k * n_queue_)
      for (std::size_t k = 0; k < scans; ++k) {
        for (std::size_t c = 0; c < n_ch_; ++c) volts_[k * n_ch_ + c] = volts_[k * n_queue_ + c];
      }
    }
    sink.on_scans(volts_.data(), scans, now_utime(), flags);
  }

  DaqConfig cfg_;
  std::vector<std::uint8_t> ai_;
  std::size_t n_ch_ = 0;     // configured channels (published)
  std::size_t n_queue_ = 0;  // channels scanned (n_ch_ padded to 1, 2, 4 or 8 [9])
  mcc::LayoutDetector detector_;
  // (wire bytes, the layout that length implies) of the session's first report [7]
  std::optional<std::pair<std::size_t, std::optional<mcc::ReportLayout>>> size_layout_;
  std::optional<std::int16_t> probe_ain_;                       // AIn counts at open [7]
  std::optional<std::optional<mcc::SeScanCoding>> se_coding_;   // decided (or not) this session
  bool single_ = false;         // single AIn reads (configured, or the fallback)
  bool fallback_ = false;       // single reads because the device refuses the feature report
  bool reported_rate_ = false;  // an open succeeded: the daemon has read device_scan_rate_hz()
  std::array<Report, mcc::LayoutDetector::kLayoutReports + 2> held_{};
  std::size_t held_n_ = 0;
  bool variant_sent_ = false;  // this session's variant told to the sink
  mcc::Gain gain_ = mcc::kSe10V;
  std::optional<mcc::ScanTimer> timer_;
  double rate_hz_ = 0;
  std::size_t burst_samples_ = 0;
  hid_device* dev_ = nullptr;
  std::vector<float> volts_;
  std::array<float, 8> carry_{};
  std::size_t carry_n_ = 0;
};

}  // namespace

std::unique_ptr<Backend> make_usb1208ls_backend(const DaqConfig& cfg) {
  return std::make_unique<Usb1208lsBackend>(cfg);
}

}  // namespace pof::daq
