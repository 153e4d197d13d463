// Virtual MCC USB-1208LS: see usb1208ls_model.hpp.
#include "usb1208ls_model.hpp"

#include <algorithm>
#include <cmath>

namespace pof::vusb {

namespace mcc = pof::daq::mcc;

void Usb1208lsModel::power_cycle() {
  std::fill(last_report_.begin(), last_report_.end(), 0);  // RAM does not survive power loss
  running_ = false;
  queue_loaded_ = false;
  replies_.clear();
}

void Usb1208lsModel::begin_session() {
  sessions = bench_.begin_session();
  session_sample_ = 0;
  delivered_ = 0;
  end_us_ = -1;
  std::fill(reads_.begin(), reads_.end(), 0);
}

std::int64_t Usb1208lsModel::bench_scan_of(int session, std::int64_t delivered) const {
  std::int64_t b = delivered;
  for (const auto& s : seams) {
    if (s.session == session && s.scans_before <= delivered) b += s.skipped;
  }
  return b;
}

bool Usb1208lsModel::scanned(int session) const {
  return std::find(scan_sessions.begin(), scan_sessions.end(), session) != scan_sessions.end();
}

std::int16_t Usb1208lsModel::counts(int session, std::int64_t sample) {
  // AInScan: samples interleaved in queue order, 12-bit counts of the queue's gain.
  const std::size_t n = std::max<std::size_t>(1, channels_.size());
  const auto scan = sample / static_cast<std::int64_t>(n);
  const auto ch = static_cast<std::size_t>(sample % static_cast<std::int64_t>(n));
  const unsigned ai = channels_.empty() ? 0U : channels_[ch];
  // Full scale 0x3FF single-ended, 0x7FF differential (wjasper volts_LS, protocol [5]).
  const double fs = mcc::full_scale_counts(gain_);
  const double c = std::round(bench_.volts(session, scan, ai) / mcc::gain_range_v(gain_) * fs);
  return static_cast<std::int16_t>(std::clamp(c, -fs - 1.0, fs));
}

double Usb1208lsModel::volts_sent(int session, std::int64_t idx, std::size_t ch) {
  const auto n = static_cast<std::int64_t>(std::max<std::size_t>(1, channels_.size()));
  return mcc::scan_counts_to_volts(counts(session, idx * n + static_cast<std::int64_t>(ch)), gain_);
}

std::int16_t Usb1208lsModel::se_counts(int session, std::int64_t idx, std::size_t ch) {
  const double v = bench_.volts(session, idx, static_cast<unsigned>(ch));
  return static_cast<std::int16_t>(std::clamp(std::round(v / 10.0 * 0x3FF), -1024.0, 1023.0));
}

double Usb1208lsModel::volts_single(int session, std::int64_t idx, std::size_t ch) {
  return mcc::counts_to_volts(se_counts(session, idx, ch), mcc::kSe10V);
}

void Usb1208lsModel::command(std::span<const std::uint8_t> r, std::int64_t now_us) {
  if (r.empty()) return;
  switch (r[0]) {
    case mcc::kAInStop:
      running_ = false;
      break;
    case mcc::kALoadQueue: {
      const std::size_t n = r.size() > 1 ? r[1] : 0;
      if (n == 0 || mcc::queue_length(n) != n) {  // [3] 1, 2, 4 or 8 only: not loaded
        ++protocol_errors;
        queue_loaded_ = false;
        channels_.clear();
        break;
      }
      const bool more = n == 2 && channels_.size() == 6;  // the second report of an 8-entry queue
      if (!more) channels_.clear();
      for (std::size_t i = 0; i < std::min<std::size_t>(n, 6) && 2 + i < r.size(); ++i) {
        channels_.push_back(r[2 + i] & 0x7U);
        gain_ = static_cast<mcc::Gain>(r[2 + i] & 0x78U);
      }
      queue_loaded_ = true;
      if (!more) begin_session();  // a (re)configuration: a new session
      break;
    }
    case mcc::kAInScan: {
      if (r.size() < 5) break;
      if (channels_.empty()) {  // no valid queue: nothing to scan
        ++protocol_errors;
        break;
      }
      count_ = static_cast<std::uint16_t>(r[1] | (r[2] << 8));
      const unsigned prescale = r[4];
      static constexpr std::uint8_t kSetup[8] = {0, 10, 6, 3, 1, 0, 0, 0};
      const double timer = static_cast<double>(r[3] - kSetup[prescale & 7U]);
      rate_hz = mcc::kClockHz / (static_cast<double>(1U << (prescale + 1U)) * (256.0 - timer)) * (1.0 + ppm_ * 1e-6);
      queue_loaded_ = false;
      const auto n = static_cast<std::int64_t>(std::max<std::size_t>(1, channels_.size()));
      if (end_us_ >= 0) {
        // A later execution of the session: the input went on while the device was idle.
        const double idle_us = std::max(0.0, static_cast<double>(now_us) - end_us_);
        const auto skipped = static_cast<std::int64_t>(std::llround(idle_us * 1e-6 * rate_hz / static_cast<double>(n)));
        seams.push_back({sessions, delivered_, skipped});
        session_sample_ += skipped * n;
      }
      ++bursts;
      std::fill(last_report_.begin(), last_report_.end(), 0);  // a new scan starts from index 0
      start_us_ = now_us;
      last_index_ = 0;
      running_ = true;
      break;
    }
    case mcc::kAIn: {  // single read: 11-bit single-ended reply {lo, hi} [5]
      if (sessions == 0) begin_session();  // a read before any queue was loaded
      single_reads_seen = true;
      const std::size_t ch = r.size() > 1 ? (r[1] & 7U) : 0;
      const auto raw = static_cast<unsigned>(se_counts(sessions, reads_[ch]++, ch) + 0x400);
      std::vector<std::uint8_t> reply(8, 0);
      reply[0] = static_cast<std::uint8_t>(raw & 0x0F);
      reply[1] = static_cast<std::uint8_t>(raw >> 4);
      replies_.push_back({now_us + kReplyLatencyUs, reply});
      break;
    }
    default:
      break;
  }
}

int Usb1208lsModel::on_control(const std::uint8_t* setup, std::span<std::uint8_t> data, std::int64_t now_us) {
  const std::uint8_t type = setup[0];
  const std::uint8_t req = setup[1];
  const unsigned value = static_cast<unsigned>(setup[2] | (setup[3] << 8));
  // SET_REPORT: an output report on EP0 (HID class request; hidapi uses it only when the interface
  // has no interrupt OUT endpoint, which the published descriptors have).
  if (type == 0x21 && req == 0x09) {
    command(data, now_us);
    return static_cast<int>(data.size());
  }
  if (type == 0xA1 && req == 0x01 && (value >> 8) == 3) {  // GET_REPORT feature: scan data
    if (opt_.refuse_feature) {
      ++feature_refusals;
      return -32;  // EPIPE: hidapi-libusb returns -1
    }
    if (running_) {
      const double elapsed = static_cast<double>(now_us - start_us_) / 1e6;
      const auto done = static_cast<long>(std::min<double>(count_, std::floor(elapsed * rate_hz)));
      const long ready_reports = done / static_cast<long>(mcc::kSamplesPerScanReport);
      if (last_index_ < ready_reports) {
        std::array<std::int16_t, mcc::kSamplesPerScanReport> s{};
        const std::int64_t base = session_sample_ + std::int64_t{last_index_} * 64;
        for (std::size_t i = 0; i < s.size(); ++i) {
          s[i] = counts(sessions, base + static_cast<std::int64_t>(i));
          // Single-ended samples coded like the AIn reply (an 11-bit offset) instead of 12-bit
          // two's complement: the reading no public source rules out [7].
          if (opt_.se_scan_offset && gain_ == mcc::kSe10V) s[i] = static_cast<std::int16_t>(s[i] + 0x400);
        }
        ++last_index_;
        mcc::encode_scan_report(s, last_index_, static_cast<std::uint8_t>(last_index_),
                                std::span<std::uint8_t, mcc::kScanReportBytes>(last_report_.data(), mcc::kScanReportBytes),
                                layout_);
        if (!scanned(sessions)) scan_sessions.push_back(sessions);
        if (std::int64_t{last_index_} * 64 >= count_) {
          running_ = false;
          session_sample_ += count_;
          const auto n = static_cast<std::int64_t>(std::max<std::size_t>(1, channels_.size()));
          delivered_ += count_ / n;
          end_us_ = static_cast<double>(start_us_) + static_cast<double>(count_) / rate_hz * 1e6;
        }
      }
    }
    // 104 bytes: [WP]'s reading, the 105-byte struct without its record number [7].
    const std::size_t n = std::min(data.size(), opt_.report_bytes);
    std::copy_n(last_report_.begin(), n, data.begin());
    return static_cast<int>(n);
  }
  return -32;  // EPIPE: a stalled control request, as a real device answers unknown requests
}

void Usb1208lsModel::on_out(std::uint8_t ep, std::span<const std::uint8_t> data, std::int64_t now_us) {
  if (ep == 0x01) command(data, now_us);  // an output report (hidapi strips report id 0)
}

InResult Usb1208lsModel::on_in(std::uint8_t ep, std::span<std::uint8_t> buf, std::int64_t now_us) {
  if (ep != 0x81 || replies_.empty() || replies_.front().ready_us > now_us) return {};
  const auto r = replies_.front().bytes;
  replies_.pop_front();
  const std::size_t n = std::min(r.size(), buf.size());
  std::copy_n(r.begin(), n, buf.begin());
  return {InResult::kData, static_cast<int>(n), 0};
}

}  // namespace pof::vusb
