// `pof export <log> --channel CH -o out.csv`: one channel of an LCM log as CSV, for spreadsheets,
// plots and checks (e.g. what pof-compensatord published, recorded by `pof record`).
// The message type is recognised by its 8-byte fingerprint (../shared/notes/lcm.md), so any
// channel name works (POF_ANGLE_LEFT_KNEE, ...). raw_block_t is flattened to one row per scan.
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "commands.hpp"
#include "pof/angle_t.hpp"
#include "pof/compensator_status_t.hpp"
#include "pof/cycle_stats_t.hpp"
#include "pof/daq_status_t.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/errors.hpp"
#include "pof/raw_block_t.hpp"

namespace pof::cli {
namespace {

std::int64_t fingerprint_of(const void* data, std::uint32_t size) {
  if (size < 8) return 0;
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint64_t h = 0;
  for (int i = 0; i < 8; ++i) h = (h << 8) | p[i];
  return std::int64_t(h);
}

template <typename Msg>
bool decode(const lcm::LogEvent& ev, Msg& m) {
  return m.decode(ev.data, 0, int(ev.datalen)) >= 0;
}

// Shortest text that reads back to the same float/double.
std::string num(double v) {
  if (std::isnan(v)) return "nan";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

const char* phase_name(std::int8_t p) {
  return p == pof::angle_t::PHASE_FLEXION ? "flexion" : p == pof::angle_t::PHASE_EXTENSION ? "extension" : "hold";
}

struct ExportOptions {
  std::string log, channel, output;
};

void run(const ExportOptions& o) {
  if (::access(o.log.c_str(), R_OK) != 0) throw io::NoInputError(o.log + ": cannot open: " + std::strerror(errno));
  lcm::LogFile log(o.log, "r");
  if (!log.good()) throw io::NoInputError(o.log + ": cannot open as an LCM log");
  std::ostringstream out;
  std::int64_t rows = 0, events = 0;
  std::int64_t type = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel != o.channel) continue;
    ++events;
    const std::int64_t fp = fingerprint_of(ev->data, std::uint32_t(ev->datalen));
    if (type == 0) {
      type = fp;
      if (fp == pof::angle_t::getHash())
        out << "utime,seq,scan_index,angle_deg,angle_uncomp_deg,angle_ref_deg,velocity_rad_s,phase,quality\n";
      else if (fp == pof::cycle_stats_t::getHash())
        out << "utime,seq,cycle,start_utime,end_utime,velocity_rad_s,rmse_comp_deg,rmse_uncomp_deg,"
               "hysteresis_comp_pct,hysteresis_uncomp_pct,max_error_deg,n_samples\n";
      else if (fp == pof::raw_block_t::getHash())
        out << "utime,block_seq,scan_index,flags";  // channel columns follow from the first block
      else
        throw io::DataError(o.log + ": channel " + o.channel +
                            ": not a pof.angle_t, pof.cycle_stats_t or pof.raw_block_t message");
    } else if (fp != type) {
      throw io::DataError(o.log + ": channel " + o.channel + ": event " + std::to_string(ev->eventnum) +
                          " changes message type");
    }
    if (fp == pof::angle_t::getHash()) {
      pof::angle_t m{};
      if (!decode(*ev, m)) throw io::DataError(o.log + ": event " + std::to_string(ev->eventnum) + ": cannot decode");
      out << m.utime << ',' << m.seq << ',' << m.scan_index << ',' << num(double(m.angle_deg)) << ','
          << num(double(m.angle_uncomp_deg)) << ',' << num(double(m.angle_ref_deg)) << ','
          << num(double(m.velocity_rad_s)) << ',' << phase_name(m.phase) << ',' << m.quality << '\n';
      ++rows;
    } else if (fp == pof::cycle_stats_t::getHash()) {
      pof::cycle_stats_t m{};
      if (!decode(*ev, m)) throw io::DataError(o.log + ": event " + std::to_string(ev->eventnum) + ": cannot decode");
      out << m.utime << ',' << m.seq << ',' << m.cycle << ',' << m.start_utime << ',' << m.end_utime << ','
          << num(double(m.velocity_rad_s)) << ',' << num(double(m.rmse_comp_deg)) << ','
          << num(double(m.rmse_uncomp_deg)) << ',' << num(double(m.hysteresis_comp_pct)) << ','
          << num(double(m.hysteresis_uncomp_pct)) << ',' << num(double(m.max_error_deg)) << ',' << m.n_samples
          << '\n';
      ++rows;
    } else {
      pof::raw_block_t m{};
      if (!decode(*ev, m)) throw io::DataError(o.log + ": event " + std::to_string(ev->eventnum) + ": cannot decode");
      if (rows == 0) {
        for (const auto& c : m.channel_names) out << ',' << c;
        out << '\n';
      }
      for (int k = 0; k < m.n_scans; ++k) {
        out << m.utime + std::llround(k * 1e6 / m.scan_rate_hz) << ',' << m.seq << ',' << m.first_scan + k << ','
            << m.flags;
        for (float v : m.volts[size_t(k)]) out << ',' << num(double(v));
        out << '\n';
        ++rows;
      }
    }
  }
  if (events == 0) throw io::DataError(o.log + ": no event on channel " + o.channel);
  io::write_output(o.output, out.str());
  if (o.output != "-") {
    std::fprintf(stderr, "pof export: %s: %" PRId64 " events -> %" PRId64 " rows in %s\n", o.channel.c_str(), events,
                 rows, o.output.c_str());
  }
}

}  // namespace

void add_export(CLI::App& app) {
  auto o = std::make_shared<ExportOptions>();
  auto* cmd = app.add_subcommand("export", "Write one channel of an LCM log (angles, cycle statistics, raw blocks) as CSV");
  cmd->add_option("log", o->log, "LCM log file (from pof record, lcm-logger or pof sim)")->required();
  cmd->add_option("--channel,-c", o->channel, "Channel, e.g. POF_ANGLE or POF_STATS_LEFT_KNEE")->required();
  cmd->add_option("-o,--output", o->output, "Output CSV ('-' for stdout)")->required();
  cmd->callback([o] { run(*o); });
}

}  // namespace pof::cli
