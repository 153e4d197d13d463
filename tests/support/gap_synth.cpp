// gap_synth: writes a synthetic recording with hidden effects (pof::gap::synthesise) as CSV, for the
// e2e tests of `pof gap`. Usage: gap_synth OUT.csv SEED [--short] [--gait S] [--wander F] [effect=magnitude ...]
#include <cstdlib>
#include <iostream>
#include <string>

#include "pof/gap/io.hpp"
#include "pof/io/csv_writer.hpp"
#include "pof/io/recording_reader.hpp"
#include "pof/testing/gap_synth.hpp"
#include "pof/base/errors.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: gap_synth OUT.csv SEED [--short] [--gait S] [--wander F] [effect=magnitude ...]\n";
    return 2;
  }
  try {
    pof::gap::SynthConfig cfg;
    for (int i = 3; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--short") cfg.short_protocol = true;
      else if (a == "--gait" && i + 1 < argc) cfg.extra_seconds = std::stod(argv[++i]);
      else if (a == "--wander" && i + 1 < argc) cfg.reference_wander = std::stod(argv[++i]);
      else if (a == "--tau" && i + 1 < argc) cfg.creep_tau_s = std::stod(argv[++i]);
      else if (const auto eq = a.find('='); eq != std::string::npos) cfg.effects[a.substr(0, eq)] = std::stod(a.substr(eq + 1));
      else { std::cerr << "gap_synth: unknown argument '" << a << "'\n"; return 2; }
    }
    pof::io::write_csv(argv[1], pof::gap::synthesise(cfg, std::stoull(argv[2])));
  } catch (const pof::Error& e) {
    std::cerr << "gap_synth: " << e.what() << '\n';
    return e.code();
  } catch (const std::exception& e) {
    std::cerr << "gap_synth: " << e.what() << '\n';
    return 2;
  }
  return 0;
}
