// pof-daqd's per-scan costs on the streaming path, against a memcpy of the same bytes measured in
// the same run (BENCHMARKS.md, "pof-daqd"). One "transfer" = 64 scans x 3 channels (384 bytes,
// ~4 ms of data at the USB-6009's 48 kS/s aggregate: the daemon's default transfer there).
#include <benchmark/benchmark.h>

#include <cstring>
#include <vector>

#include "pof/daq/stream/acquisition.hpp"
#include "pof/daq/stream/config.hpp"
#include "pof/raw_block_t.hpp"
#include "pof/daq/protocol/ni_usb600x.hpp"

namespace ni = pof::daq::ni;

namespace {

constexpr std::size_t kScans = 64;
constexpr std::size_t kCh = 3;

std::vector<std::uint8_t> wire(ni::SampleCoding coding) {
  std::vector<std::uint8_t> b(kScans * kCh * 2);
  for (std::size_t i = 0; i < kScans * kCh; ++i) {
    ni::encode_sample(static_cast<std::uint16_t>((i * 37) % (1U << coding.bits)), coding, &b[2 * i]);
  }
  return b;
}

// Baseline: moving the transfer's bytes once.
void BM_Baseline_Memcpy(benchmark::State& st) {
  const auto in = wire(ni::usb6009_coding());
  std::vector<std::uint8_t> out(in.size());
  for (auto _ : st) {
    std::memcpy(out.data(), in.data(), in.size());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  st.SetItemsProcessed(st.iterations() * static_cast<std::int64_t>(kScans));
}

// The decode loop of the usb600x backend: code -> volts (padding bits noted, not checked).
void BM_Decode(benchmark::State& st, ni::SampleCoding coding) {
  const auto in = wire(coding);
  std::vector<float> volts(kScans * kCh);
  for (auto _ : st) {
    for (std::size_t s = 0; s < kScans * kCh; ++s) {
      const auto c = ni::decode_sample(&in[2 * s], coding);
      volts[s] = static_cast<float>(ni::code_to_volts(c.code, coding.bits, 10.0));
    }
    benchmark::DoNotOptimize(volts.data());
    benchmark::ClobberMemory();
  }
  st.SetItemsProcessed(st.iterations() * static_cast<std::int64_t>(kScans));
}

// Acquisition::on_scans (index, clock, decimation, block assembly, SPSC push) + the consumer pop.
void BM_Acquisition(benchmark::State& st) {
  pof::daq::DaqConfig cfg;
  cfg.decimate = static_cast<int>(st.range(0));
  cfg.block_scans = static_cast<int>(st.range(1));
  pof::daq::SpscQueue<pof::daq::Block> q(256);
  pof::daq::Counters counters;
  pof::daq::Doorbell wake;
  pof::daq::Acquisition acq(cfg, 16000.0, q, counters, wake);
  acq.on_segment_start(1'700'000'000'000'000, 1'700'000'000'000'000, false);
  std::vector<float> v(kScans * kCh, 1.0F);
  std::int64_t t = 1'700'000'000'000'000;
  for (auto _ : st) {
    t += 4000;
    acq.on_scans(v.data(), kScans, t, 0);
    while (q.front() != nullptr) q.pop();
    (void)wake.try_wait();
  }
  st.SetItemsProcessed(st.iterations() * static_cast<std::int64_t>(kScans));
}

// The publisher's per-block encode (50 scans x 3 channels, preallocated message and buffer).
void BM_EncodeBlock(benchmark::State& st) {
  pof::raw_block_t m;
  m.n_channels = 3;
  m.channel_names = {"sensor", "reference", "pot"};
  m.channel_units = {"V", "V", "V"};
  m.n_scans = 50;
  m.volts.assign(50, std::vector<float>(3, 1.0F));
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  for (auto _ : st) {
    benchmark::DoNotOptimize(m.encode(buf.data(), 0, static_cast<int>(buf.size())));
  }
  st.SetItemsProcessed(st.iterations() * 50);
}

}  // namespace

BENCHMARK(BM_Baseline_Memcpy);
BENCHMARK_CAPTURE(BM_Decode, usb6008, ni::usb6008_coding(ni::ByteOrder::kBig));
BENCHMARK_CAPTURE(BM_Decode, usb6009, ni::usb6009_coding());
BENCHMARK(BM_Acquisition)->Args({1, 50})->Args({10, 1})->Args({80, 1});
BENCHMARK(BM_EncodeBlock);
BENCHMARK_MAIN();
