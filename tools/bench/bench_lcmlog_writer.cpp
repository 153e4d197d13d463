// Cost per event of writing LCM logs: pofkit's DurableLogWriter (whole-event batches, undo on
// ENOSPC) against liblcm's own lcm_eventlog_write_event (stdio, what lcm-logger uses), in the same
// run. 10 000 events of 239 bytes (a 10-scan raw_block_t) per iteration into a fresh file in
// $TMPDIR, ending with one fdatasync in both (what a recorder does at close; DurableLogWriter
// always syncs when it closes).
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <lcm/eventlog.h>

#include "pof/recorder/lcmlog_durable.hpp"

namespace {

constexpr int kEvents = 10000;
const std::vector<unsigned char> kPayload(239, 0x5a);

std::string scratch(const char* name) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir != nullptr ? dir : "/tmp") + "/pof-bench-" + name + "-" + std::to_string(::getpid()) + ".lcmlog";
}

void BM_LcmEventlog(benchmark::State& state) {
  const std::string path = scratch("lcm");
  for (auto _ : state) {
    std::filesystem::remove(path);
    lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
    char channel[] = "POF_RAW";
    for (int i = 0; i < kEvents; ++i) {
      lcm_eventlog_event_t ev{};
      ev.eventnum = i;
      ev.timestamp = i;
      ev.channellen = 7;
      ev.datalen = static_cast<int32_t>(kPayload.size());
      ev.channel = channel;
      ev.data = const_cast<unsigned char*>(kPayload.data());
      lcm_eventlog_write_event(log, &ev);
    }
    std::fflush(log->f);
    ::fdatasync(fileno(log->f));
    lcm_eventlog_destroy(log);
  }
  std::filesystem::remove(path);
  state.SetItemsProcessed(state.iterations() * kEvents);
}

void BM_DurableLogWriter(benchmark::State& state) {
  const std::string path = scratch("pof");
  for (auto _ : state) {
    std::filesystem::remove(path);
    pof::recorder::DurableLogWriter w(path);
    for (int i = 0; i < kEvents; ++i) w.append(i, "POF_RAW", kPayload.data(), kPayload.size());
    w.sync();
  }
  std::filesystem::remove(path);
  state.SetItemsProcessed(state.iterations() * kEvents);
}

}  // namespace

BENCHMARK(BM_LcmEventlog)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DurableLogWriter)->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
