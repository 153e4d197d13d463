// The simulated knee on the virtual DAQs' analog inputs: see analog_bench.hpp.
#include "analog_bench.hpp"

#include <algorithm>
#include <span>
#include <stdexcept>

namespace pof::vusb {

namespace {
pof::sim::Scenario load(const std::string& name_or_path) {
  pof::sim::Scenario s = pof::sim::scenario_by_name_or_path(name_or_path);
  s.loop = true;      // a streaming device never runs out of signal
  s.duration_s = 0;
  return s;
}
}  // namespace

AnalogBench::AnalogBench(const BenchOptions& o)
    : o_(o),
      scenario_(load(o.scenario)),
      sim_(std::make_unique<pof::sim::Simulator>(scenario_, o.seed, o.scan_rate_hz)) {
  if (!o.truth_csv.empty()) {
    truth_ = std::fopen(o.truth_csv.c_str(), "w");
    if (truth_ == nullptr) throw std::runtime_error("cannot write the truth file " + o.truth_csv);
    // bench_scan: position in the continuous signal; session/index: the device scan that sampled it.
    std::fprintf(truth_, "bench_scan,session,index,t_s,sensor_v,reference_v,pot_v,angle_true_deg\n");
  }
}

AnalogBench::~AnalogBench() {
  if (truth_ != nullptr) std::fclose(truth_);
}

int AnalogBench::begin_session() {
  session_offset_.push_back(generated_);
  return static_cast<int>(session_offset_.size());
}

std::int64_t AnalogBench::bench_index(int session, std::int64_t index) {
  if (session < 1 || session > static_cast<int>(session_offset_.size()) || index < 0) return -1;
  const auto s = static_cast<std::size_t>(session - 1);
  const std::int64_t b = session_offset_[s] + index;
  // An earlier session ended where the next one began.
  if (s + 1 < session_offset_.size() && b >= session_offset_[s + 1]) return -1;
  return b;
}

void AnalogBench::generate_through(std::int64_t b) {
  // One scan at a time: a session that begins later starts exactly after the last scan served.
  while (generated_ <= b) {
    pof::sim::Scan sc{};
    if (sim_->next(std::span(&sc, 1)) != 1) {  // a looping scenario never finishes
      throw std::logic_error("the looping scenario '" + scenario_.name + "' finished");
    }
    rows_.push_back({sc.sensor_v, sc.reference_v, sc.pot_v});
    if (truth_ != nullptr) {
      const auto session = static_cast<int>(session_offset_.size());
      const std::int64_t offset = session_offset_.empty() ? 0 : session_offset_.back();
      std::fprintf(truth_, "%lld,%d,%lld,%.9g,%.9g,%.9g,%.9g,%.9g\n", static_cast<long long>(generated_), session,
                   static_cast<long long>(generated_ - offset), static_cast<double>(generated_) / o_.scan_rate_hz,
                   sc.sensor_v, sc.reference_v, sc.pot_v, sc.angle_true_deg);
    }
    ++generated_;
  }
}

double AnalogBench::volts(int session, std::int64_t index, unsigned ai) {
  const std::int64_t b = bench_index(session, index);
  if (b < base_) {  // also b == -1
    ++misses_;
    return 0.0;
  }
  generate_through(b);
  const Row& r = rows_[static_cast<std::size_t>(b - base_)];
  switch (ai) {
    case 0: return r.sensor_v;
    case 1: return r.reference_v;
    case 2: return r.pot_v;
    default: return 0.0;  // grounded input
  }
}

void AnalogBench::forget_before(int session, std::int64_t index) {
  if (session < 1 || session > static_cast<int>(session_offset_.size())) return;
  const auto s = static_cast<std::size_t>(session - 1);
  std::int64_t b = session_offset_[s] + std::max<std::int64_t>(index, 0);
  if (s + 1 < session_offset_.size()) b = std::min(b, session_offset_[s + 1]);
  b = std::min(b, generated_);
  while (base_ < b && !rows_.empty()) {
    rows_.pop_front();
    ++base_;
  }
}

}  // namespace pof::vusb
