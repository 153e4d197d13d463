// Streaming path: see acquisition.hpp.
#include "pof/daq/stream/acquisition.hpp"

#include <cmath>

#include "pof/raw_block_t.hpp"

namespace pof::daq {

Acquisition::Acquisition(const DaqConfig& cfg, double device_rate_hz, SpscQueue<Block>& queue,
                         Counters& counters, Doorbell& wake)
    : n_ch_(cfg.channels().size()),
      device_rate_hz_(device_rate_hz),
      decimate_(cfg.decimate),
      block_scans_(cfg.block_scans),
      queue_(queue),
      counters_(counters),
      wake_(wake),
      clock_(device_rate_hz) {}

void Acquisition::on_segment_start(std::int64_t earliest_us, std::int64_t latest_us,
                                   bool continuous) noexcept {
  const std::int64_t host_us = latest_us;
  if (started_ && !continuous) {
    // Scans were lost (unplug, error recovery): publish what we have, then advance the index by
    // the time that passed, so the gap shows in first_scan and is flagged.
    flush_block();
    // A partial decimation window from before the gap is dropped with the lost scans.
    const std::int64_t window_start = device_index_ - in_window_;
    in_window_ = 0;
    window_flags_ = 0;
    for (auto& v : sum_) v = 0;
    const double expected_us = static_cast<double>(clock_.time_of(static_cast<double>(device_index_)));
    const double lost = std::max(0.0, (static_cast<double>(host_us) - expected_us) * device_rate_hz_ / 1e6);
    std::int64_t next = device_index_ + std::llround(lost);
    next = (next + decimate_ - 1) / decimate_ * decimate_;  // keep published indices integral
    counters_.dropped_scans.fetch_add((next - window_start) / decimate_, std::memory_order_relaxed);
    device_index_ = next;
    pending_flags_ |= int32_t{pof::raw_block_t::FLAG_GAP};
  }
  started_ = true;
  clock_.anchor(device_index_ - in_window_, earliest_us, latest_us);
}

void Acquisition::on_scans(const float* volts, std::size_t n_scans, std::int64_t arrival_us,
                           std::int32_t flags) noexcept {
  if (n_scans == 0) return;
  counters_.scans.fetch_add(static_cast<std::int64_t>(n_scans), std::memory_order_relaxed);
  clock_.observe(device_index_ + static_cast<std::int64_t>(n_scans) - 1, arrival_us);
  for (std::size_t k = 0; k < n_scans; ++k) {
    for (std::size_t c = 0; c < n_ch_; ++c) sum_[c] += static_cast<double>(volts[k * n_ch_ + c]);
    window_flags_ |= flags;
    ++device_index_;
    if (++in_window_ == decimate_) emit_output_scan(window_flags_);
  }
}

void Acquisition::on_usb_error() noexcept {
  counters_.usb_errors.fetch_add(1, std::memory_order_relaxed);
}

void Acquisition::on_variant(std::uint32_t bits) noexcept {
  counters_.variant.store(bits, std::memory_order_relaxed);
}

void Acquisition::on_padding_set(std::size_t n) noexcept {
  counters_.padding_set.fetch_add(static_cast<std::int64_t>(n), std::memory_order_relaxed);
}

void Acquisition::emit_output_scan(std::int32_t flags) noexcept {
  const std::int64_t first_device = device_index_ - decimate_;
  if (block_ == nullptr) {
    block_ = queue_.producer_slot();
    if (block_ == nullptr) {
      // Publisher queue full: drop this scan, count it, flag the hole in the next block.
      counters_.overruns.fetch_add(1, std::memory_order_relaxed);
      counters_.dropped_scans.fetch_add(1, std::memory_order_relaxed);
      pending_flags_ |= int32_t{pof::raw_block_t::FLAG_GAP};
      in_window_ = 0;
      window_flags_ = 0;
      for (auto& s : sum_) s = 0;
      return;
    }
    block_->n_scans = 0;
    block_->first_scan = first_device / decimate_;
    // The averaged scan stands for the middle of its window.
    block_->utime = clock_.time_of(static_cast<double>(first_device) + (decimate_ - 1) / 2.0);
    // The clock's causality correction moves the anchor back when a transfer arrives earlier
    // than predicted (scan_clock.hpp): a block already published keeps its time, so a later one
    // must not be stamped before it. Held 1 us after it until the estimate passes it again.
    if (block_->utime <= last_utime_) block_->utime = last_utime_ + 1;
    last_utime_ = block_->utime;
    block_->flags = pending_flags_;
    pending_flags_ = 0;
  }
  float* out = &block_->volts[static_cast<std::size_t>(block_->n_scans) * n_ch_];
  for (std::size_t c = 0; c < n_ch_; ++c) {
    out[c] = static_cast<float>(sum_[c] / decimate_);
    sum_[c] = 0;
  }
  block_->flags |= flags;
  in_window_ = 0;
  window_flags_ = 0;
  if (++block_->n_scans == block_scans_) flush_block();
}

void Acquisition::flush_block() noexcept {
  if (block_ == nullptr) return;
  queue_.commit();
  block_ = nullptr;
  wake_.ring();
}

}  // namespace pof::daq
