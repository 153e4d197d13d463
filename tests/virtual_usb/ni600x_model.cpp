// Virtual NI USB-6008/6009: see ni600x_model.hpp.
#include "ni600x_model.hpp"

#include <algorithm>
#include <cmath>

namespace pof::vusb {

namespace ni = pof::daq::ni;

namespace {
std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}
}  // namespace

Ni600xModel::Ni600xModel(const NiOptions& o, AnalogBench& bench)
    : o_(o), bench_(bench), coding_(o.usb6009 ? ni::usb6009_coding() : ni::usb6008_coding(o.order)) {}

std::uint16_t Ni600xModel::code(int session, std::int64_t index, std::size_t ch) {
  // The sensor, reference and pot levels differ, so a channel swap shows; the noise toggles the
  // low bits and the knee's motion the high ones, so a byte-order or justification error shows.
  if (!std::isnan(o_.steady_volts)) {  // a steady level with +-1 LSB of noise, as an ADC shows
    const auto c = ni::volts_to_code(o_.steady_volts, coding_.bits, o_.range_v);
    if (o_.steady_noise_lsb == 0) return c;  // a perfectly steady input: no order reads rougher
    return static_cast<std::uint16_t>(c + static_cast<int>((index * 7 + static_cast<std::int64_t>(ch) * 3 + session) % 3) - 1);
  }
  return ni::volts_to_code(bench_.volts(session, index, ai_[ch % ai_.size()]), coding_.bits, o_.range_v);
}

void Ni600xModel::power_cycle() {
  replies_.clear();
  running_ = false;
  session_pending_ = false;
  prev_end_us_ = -1;
}

void Ni600xModel::on_out(std::uint8_t ep, std::span<const std::uint8_t> data, std::int64_t now_us) {
  if (ep != ni::kEpCommandOut) return;
  const auto f = ni::parse_frame(data);
  const ni::Opcode* oc = f ? ni::find_opcode(f->op, f->group) : nullptr;
  if (oc == nullptr) {
    ++protocol_errors;
    return;  // a real device would not answer either
  }
  const auto& p = f->params;
  last_command = std::string(oc->name);
  if (oc->cmd != ni::Cmd::kHello) ++(f->hh == 0 ? requests_00 : requests_01);
  switch (oc->cmd) {
    case ni::Cmd::kHello:
      ++hellos;
      session_pending_ = true;
      running_ = false;
      prev_end_us_ = -1;
      break;
    case ni::Cmd::kChannelList:
      if (const std::size_t len = p.size() >= 2 ? static_cast<std::size_t>((p[0] << 8) | p[1]) : 0; len >= 2) {
        // BE16 length, then one BE16 analog input number per entry
        n_ch_ = std::min<std::size_t>((len - 2) / 2, ai_.size());
        for (std::size_t i = 0; i < n_ch_ && 3 + 2 * i < p.size(); ++i) {
          ai_[i] = static_cast<unsigned>((p[2 + 2 * i] << 8) | p[3 + 2 * i]);
        }
      }
      break;
    case ni::Cmd::kClock:
      if (p.size() >= 4) rate_hz_ = ni::rate_for_divisor(be32(p.data()));
      break;
    case ni::Cmd::kScanCount:
      if (p.size() >= 4) count_ = be32(p.data());
      break;
    case ni::Cmd::kByteCount:
      if (p.size() < 4 || std::uint64_t{be32(p.data())} != std::uint64_t{count_} * n_ch_ * 2) ++protocol_errors;
      break;
    case ni::Cmd::kStart1003: {
      if (session_pending_) {
        session_ = bench_.begin_session();
        index_ = 0;
        session_pending_ = false;
      }
      const double rate = rate_hz_ * (1.0 + o_.clock_ppm * 1e-6);
      if (prev_end_us_ >= 0) seams_us.push_back(now_us - prev_end_us_);
      segments.push_back({session_, index_, count_, now_us, rate});
      seg_start_us_ = now_us;
      sent_ = 0;
      running_ = true;
      break;
    }
    default:
      break;
  }
  if (!o_.silent) {
    const ni::Frame r = ni::make_reply(oc->cmd, o_.reply_header);
    replies_.emplace_back(r.bytes.begin(), r.bytes.begin() + static_cast<long>(r.size));
  }
}

InResult Ni600xModel::on_in(std::uint8_t ep, std::span<std::uint8_t> buf, std::int64_t now_us) {
  if (ep == ni::kEpReplyIn) {
    if (replies_.empty()) return {};
    const auto r = replies_.front();
    replies_.erase(replies_.begin());
    const std::size_t n = std::min(r.size(), buf.size());
    std::copy_n(r.begin(), n, buf.begin());
    return {InResult::kData, static_cast<int>(n), 0};
  }
  if (ep != ni::kEpDataIn || !running_ || n_ch_ == 0) return {};
  const bool pad_this = garbage_ == 2;  // scenario: one packet with padding bits set, then stop
  if (garbage_ == 1) {  // scenario: one malformed (odd-length) packet, then the device stops
    garbage_ = 0;
    running_ = false;
    const std::size_t n = std::min<std::size_t>(63, buf.size());
    std::fill_n(buf.begin(), n, 0xFF);
    return {InResult::kData, static_cast<int>(n), 0};
  }
  const Segment& seg = segments.back();
  const double elapsed_s = static_cast<double>(now_us - seg_start_us_) / 1e6;
  const auto due = static_cast<std::uint64_t>(
      std::min(static_cast<double>(count_), std::floor(elapsed_s * seg.rate_hz)));
  const std::uint64_t total = std::uint64_t{count_} * n_ch_ * 2;
  const std::uint64_t avail = due * n_ch_ * 2 - sent_;
  std::size_t n = 0;
  if (avail >= buf.size()) {
    n = buf.size();
  } else if (due == count_ && avail > 0) {
    n = static_cast<std::size_t>(avail);  // the segment's short final packet
  } else {
    return {};
  }
  if (o_.short_every > 0 && ++data_urbs_ % o_.short_every == 0 && n >= 4) n -= 2;
  for (std::size_t i = 0; i < n; i += 2) {
    const std::uint64_t sample = (sent_ + i) / 2;
    const auto scan = static_cast<std::int64_t>(sample / n_ch_);
    const std::size_t ch = sample % n_ch_;
    ni::encode_sample(code(seg.session, seg.first_index + scan, ch), coding_, &buf[i]);
    if (o_.padding_noise || pad_this) {  // the low bits of the word, whichever byte holds them
      const auto noise = static_cast<std::uint8_t>((sent_ + i) / 2 * 5 % ((1U << (16U - coding_.bits)) - 1U) + 1U);
      buf[i + (coding_.order == ni::ByteOrder::kBig ? 1 : 0)] |= noise;
    }
  }
  sent_ += n;
  if (pad_this) {
    garbage_ = 0;
    running_ = false;
  }
  if (sent_ == total) {
    running_ = false;
    prev_end_us_ = seg_start_us_ + static_cast<std::int64_t>(std::llround(count_ / seg.rate_hz * 1e6));
    index_ = seg.first_index + count_;
  }
  return {InResult::kData, static_cast<int>(n), 0};
}

void Ni600xModel::on_clear_halt(std::uint8_t) {}

int Ni600xModel::on_control(const std::uint8_t* setup, std::span<std::uint8_t> data, std::int64_t) {
  // Standard GET_DESCRIPTOR (bmRequestType 0x80, bRequest 6) of type string (3) only.
  if (setup[0] != 0x80 || setup[1] != 0x06 || setup[3] != 0x03 || o_.serial.empty()) return -32;
  std::vector<std::uint8_t> d;
  if (setup[2] == 0) {
    d = {4, 3, 0x09, 0x04};  // English (US)
  } else if (setup[2] == 3) {
    d = {static_cast<std::uint8_t>(2 + 2 * o_.serial.size()), 3};
    for (char ch : o_.serial) {
      d.push_back(static_cast<std::uint8_t>(ch));
      d.push_back(0);
    }
  } else {
    return -32;
  }
  const std::size_t n = std::min(d.size(), data.size());
  std::copy_n(d.begin(), n, data.begin());
  return static_cast<int>(n);
}

}  // namespace pof::vusb
