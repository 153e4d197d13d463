#pragma once
// Where the `sim:<scenario>` backend gets its scans. A small interface so that the synthetic
// waveform below and the physics simulator (pof::sim::Simulator, daq/sim/ branch) are a one-line swap
// in make_sample_source().
#include <cstddef>
#include <memory>
#include <span>
#include <string>

namespace pof::daq {

class SampleSource {
 public:
  virtual ~SampleSource() = default;
  /// Fills `out` with up to out.size()/n_channels scans, channel-interleaved in the order
  /// sensor, reference, pot (only the wired ones). Returns the number of scans; 0 when finished.
  virtual std::size_t next(std::span<float> out) = 0;
};

/// `synthetic`: a deterministic knee cycle without physics: sensor = 4.35 V at 0 deg to 2.38 V at
/// 90 deg (the paper's f5 end points, brief "Contracts"), reference 5.0 V, pot 0.5..4.5 V, 0.5 Hz.
/// Anything else: the physics simulator (pof::sim) with a built-in scenario ("paper",
/// "realistic") or a scenario file path. Throws pof::ConfigError for an unknown scenario,
/// naming the choices.
std::unique_ptr<SampleSource> make_sample_source(const std::string& scenario, double scan_rate_hz,
                                                 bool has_reference, bool has_pot);

}  // namespace pof::daq
