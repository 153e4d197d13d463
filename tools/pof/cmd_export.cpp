// `pof export <log> --channel CH -o out.csv`: one channel of an LCM log as CSV, for spreadsheets,
// plots (PlotJuggler opens it) and checks (e.g. what pof-compensatord published, recorded by `pof
// record`); `--format sto|mot` (or an -o ending in .sto/.mot) writes an OpenSim Storage file of the
// numeric streams instead: header with nRows/nColumns, `time` in seconds, angles in degrees
// (docs/export.md, "OpenSim": the format facts it follows).
// The message type is recognised by its 8-byte fingerprint (LCM type specification: every message
// starts with its type's fingerprint), so any channel name works (POF_ANGLE_LEFT_KNEE, ...).
// raw_block_t is flattened to one row per scan; the status types give one row per message, text
// fields quoted as RFC 4180 says.
//
// The log is scanned by io::LcmLogReader (lengths bounded by the file, resynchronising after
// damage). A damaged log (damaged framing, or an event on the channel that does not decode as the
// channel's type) is bad input: exit 65 naming the first damage and the counts, nothing written.
// --salvage writes the rows of every event that could be read, then still exits 65 with the counts,
// so a script cannot mistake a salvaged export for a complete one.
#include <cctype>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "pof/base/format.hpp"
#include "pof/bus/channels.hpp"
#include "pof/bus/fingerprint.hpp"
#include "pof/angle_t.hpp"
#include "pof/compensator_status_t.hpp"
#include "pof/cycle_stats_t.hpp"
#include "pof/daq_status_t.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/base/errors.hpp"
#include "pof/io/lcmlog_scan.hpp"
#include "pof/raw_block_t.hpp"

namespace pof::cli {
namespace {

// Text that reads back to the same float (9 significant digits); every NaN as "nan".
std::string num(double v) { return std::isnan(v) ? "nan" : format_significant(v, 9); }

// A text field as one CSV cell (RFC 4180): quoted when it holds a comma, quote or line break, so a
// state text or a reload error cannot shift the columns.
std::string text(const std::string& v) {
  if (v.find_first_of(",\"\r\n") == std::string::npos) return v;
  std::string q = "\"";
  for (char c : v) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + '"';
}

const char* state_name(std::int8_t s) {
  switch (s) {
    case pof::daq_status_t::STATE_STARTING: return "starting";
    case pof::daq_status_t::STATE_STREAMING: return "streaming";
    case pof::daq_status_t::STATE_DISCONNECTED: return "disconnected";
    case pof::daq_status_t::STATE_FAULT: return "fault";
    case pof::daq_status_t::STATE_STOPPING: return "stopping";
    default: return "unknown";
  }
}

const char* phase_name(std::int8_t p) {
  return p == pof::angle_t::PHASE_FLEXION ? "flexion" : p == pof::angle_t::PHASE_EXTENSION ? "extension" : "hold";
}

struct ExportOptions {
  std::string log, channel, output;
  std::string format = "auto";
  bool salvage = false;
};

enum class Format { kCsv, kSto, kMot };

Format format_of(const ExportOptions& o) {
  if (o.format == "csv") return Format::kCsv;
  if (o.format == "sto") return Format::kSto;
  if (o.format == "mot") return Format::kMot;
  const auto ends_with = [&](const char* ext) {
    const std::string e(ext);
    return o.output.size() > e.size() && o.output.compare(o.output.size() - e.size(), e.size(), e) == 0;
  };
  return ends_with(".sto") ? Format::kSto : ends_with(".mot") ? Format::kMot : Format::kCsv;
}

// An OpenSim Storage table (docs/export.md, "OpenSim"): OpenSim's readers take a header ending
// in `endheader`, a tab-separated label line starting with `time`, then tab-separated rows; nRows
// and nColumns (time included) must match the body, so the body is kept and the header written
// last. Time is seconds from the first row (utime, microseconds since the epoch, would keep only
// whole seconds in 9 significant digits); the first row's utime is kept in the header. OpenSim 4's
// table refuses a time that does not increase, so such a log is refused here, naming the row.
// Labels are whitespace-free (a raw block's channel names come from the log: a tab or space in
// one would shift every column after it).
class StorageTable {
 public:
  void set_labels(std::vector<std::string> labels) {
    for (auto& l : labels)
      for (char& c : l)
        if (std::isspace(static_cast<unsigned char>(c)) != 0 || std::iscntrl(static_cast<unsigned char>(c)) != 0) c = '_';
    labels_ = std::move(labels);
  }
  [[nodiscard]] bool has_labels() const { return !labels_.empty(); }

  void row(std::int64_t utime, const std::vector<double>& values) {
    if (rows_ == 0) {
      t0_ = utime;
    } else if (utime <= last_ && order_problem_.empty()) {
      order_problem_ = "row " + std::to_string(rows_ + 1) + ": utime " + std::to_string(utime) +
                       " does not follow utime " + std::to_string(last_) + " of the row before";
    }
    last_ = utime;
    // Microseconds, exactly: a long session stays below 2^53 us.
    char t[32];
    std::snprintf(t, sizeof t, "%.6f", double(utime - t0_) * 1e-6);
    body_ << t;
    for (double v : values) body_ << '\t' << (std::isnan(v) ? std::string("NaN") : num(v));
    body_ << '\n';
    ++rows_;
  }
  [[nodiscard]] std::int64_t rows() const { return rows_; }
  [[nodiscard]] const std::string& order_problem() const { return order_problem_; }

  [[nodiscard]] std::string text(const std::string& name) const {
    std::ostringstream out;
    out << name << "\nversion=1\nnRows=" << rows_ << "\nnColumns=" << labels_.size() + 1
        << "\ninDegrees=yes\ntime_zero_utime=" << t0_ << "\nendheader\ntime";
    for (const auto& l : labels_) out << '\t' << l;
    out << '\n' << body_.str();
    return out.str();
  }

 private:
  std::vector<std::string> labels_;
  std::ostringstream body_;
  std::int64_t rows_ = 0, t0_ = 0, last_ = 0;
  std::string order_problem_;
};

// The column prefix of a channel in a Storage file: the sensor id in lower case ("left_knee" for
// POF_ANGLE_LEFT_KNEE), "pof" for a channel without one, the channel itself in lower case for a
// name that is none of pofkit's streams. OpenSim models name their coordinates (knee_angle_r, ...);
// which sensor is which joint only the lab knows, so no such name is assumed (docs/export.md).
std::string column_prefix(const std::string& channel) {
  const auto parsed = bus::parse_channel(channel);
  std::string p = parsed ? (parsed->sensor_id.empty() ? std::string("pof") : parsed->sensor_id) : channel;
  for (char& c : p) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return p;
}

constexpr double kDegPerRad = 180.0 / M_PI;

std::string hex_fingerprint(std::uint64_t fp) {
  char b[24];
  std::snprintf(b, sizeof b, "0x%016" PRIx64, fp);
  return b;
}

void run(const ExportOptions& o) {
  io::refuse_output_over_input({{"log", o.log}}, {{"-o", o.output}});
  io::LcmLogReader log(o.log);
  const Format format = format_of(o);
  const bool storage = format != Format::kCsv;
  StorageTable sto;
  const std::string px = column_prefix(o.channel) + "_";
  std::ostringstream out;
  std::int64_t rows = 0, events = 0;
  bus::MessageType type = bus::MessageType::kUnknown;  // the channel's, from its first message of ours
  bool raw_header_written = false;
  std::vector<std::string> raw_names;
  // Events before the first one of a known type: damage if the channel turns out to have a type,
  // otherwise the channel is simply of another type.
  std::vector<io::LcmEventRef> unknown_before_type;
  log.scan([&](const io::LcmEventRef& ev) {
    if (ev.channel != o.channel) return;
    ++events;
    const bus::MessageType t = bus::message_type_of(ev.data, ev.data_size);
    if (type == bus::MessageType::kUnknown) {
      if (t == bus::MessageType::kUnknown) {
        unknown_before_type.push_back(ev);
        return;
      }
      type = t;
      for (const auto& u : unknown_before_type)
        log.undecodable(u, "fingerprint " + hex_fingerprint(bus::fingerprint_of(u.data, u.data_size)) +
                               " differs from the channel's type");
      switch (t) {
        case bus::MessageType::kAngle:
          out << "utime,seq,scan_index,angle_deg,angle_uncomp_deg,angle_ref_deg,velocity_rad_s,phase,quality,angle_sigma_deg\n";
          break;
        case bus::MessageType::kCycleStats:
          out << "utime,seq,cycle,start_utime,end_utime,velocity_rad_s,rmse_comp_deg,rmse_uncomp_deg,"
                 "hysteresis_comp_pct,hysteresis_uncomp_pct,max_error_deg,n_samples\n";
          break;
        case bus::MessageType::kDaqStatus:
          out << "utime,seq,sensor_id,device_kind,vendor_id,product_id,serial,state,state_text,scan_rate_hz,"
                 "n_channels,scans,blocks,dropped_scans,usb_errors,overruns,reconnects,protocol_variant,padding_set,"
                 "publish_failures\n";
          break;
        case bus::MessageType::kCompensatorStatus:
          out << "utime,seq,sensor_id,calibration_path,calibration_sensor_id,calibration_date,blocks,scans,"
                 "lost_blocks,lost_scans,rejected_blocks,fault_scans,angles,cycles,reloads,reload_failures,"
                 "last_error,decode_errors,malformed_datagrams,duplicate_blocks,publish_failures,authenticated,"
                 "auth_unsigned,auth_bad_mac,auth_stale,auth_replayed,estimator_divergences\n";
          break;
        case bus::MessageType::kRawBlock:
        case bus::MessageType::kUnknown:
          out << "utime,block_seq,scan_index,flags";  // channel columns follow from the first block
          break;
      }
    } else if (t != type) {
      log.undecodable(ev, "fingerprint " + hex_fingerprint(bus::fingerprint_of(ev.data, ev.data_size)) +
                              " differs from the channel's first message");
      return;
    }
    if (t == bus::MessageType::kAngle) {
      pof::angle_t m{};
      if (auto why = io::decode_lcm_event(ev, m)) return log.undecodable(ev, *why);
      if (storage) {
        // Every angle in degrees (inDegrees=yes), the velocity too; phase and quality as numbers
        // (angle_t.lcm's PHASE_* and QUALITY_*).
        if (!sto.has_labels())
          sto.set_labels({px + "angle", px + "angle_uncomp", px + "angle_ref", px + "velocity", px + "angle_sigma",
                          px + "phase", px + "quality"});
        sto.row(m.utime, {double(m.angle_deg), double(m.angle_uncomp_deg), double(m.angle_ref_deg),
                          double(m.velocity_rad_s) * kDegPerRad, double(m.angle_sigma_deg), double(m.phase),
                          double(m.quality)});
        ++rows;
        return;
      }
      out << m.utime << ',' << m.seq << ',' << m.scan_index << ',' << num(double(m.angle_deg)) << ','
          << num(double(m.angle_uncomp_deg)) << ',' << num(double(m.angle_ref_deg)) << ','
          << num(double(m.velocity_rad_s)) << ',' << phase_name(m.phase) << ',' << m.quality << ','
          << num(double(m.angle_sigma_deg)) << '\n';
      ++rows;
    } else if (t == bus::MessageType::kCycleStats) {
      pof::cycle_stats_t m{};
      if (auto why = io::decode_lcm_event(ev, m)) return log.undecodable(ev, *why);
      if (storage) {  // one row per cycle, at its end
        if (!sto.has_labels())
          sto.set_labels({px + "cycle", px + "velocity", px + "rmse_comp", px + "rmse_uncomp",
                          px + "hysteresis_comp_pct", px + "hysteresis_uncomp_pct", px + "max_error", px + "n_samples"});
        sto.row(m.end_utime, {double(m.cycle), double(m.velocity_rad_s) * kDegPerRad, double(m.rmse_comp_deg),
                              double(m.rmse_uncomp_deg), double(m.hysteresis_comp_pct),
                              double(m.hysteresis_uncomp_pct), double(m.max_error_deg), double(m.n_samples)});
        ++rows;
        return;
      }
      out << m.utime << ',' << m.seq << ',' << m.cycle << ',' << m.start_utime << ',' << m.end_utime << ','
          << num(double(m.velocity_rad_s)) << ',' << num(double(m.rmse_comp_deg)) << ','
          << num(double(m.rmse_uncomp_deg)) << ',' << num(double(m.hysteresis_comp_pct)) << ','
          << num(double(m.hysteresis_uncomp_pct)) << ',' << num(double(m.max_error_deg)) << ',' << m.n_samples
          << '\n';
      ++rows;
    } else if (storage && (t == bus::MessageType::kDaqStatus || t == bus::MessageType::kCompensatorStatus)) {
      return;  // refused after the scan: status text has no place in a Storage file
    } else if (t == bus::MessageType::kDaqStatus) {
      pof::daq_status_t m{};
      if (auto why = io::decode_lcm_event(ev, m)) return log.undecodable(ev, *why);
      out << m.utime << ',' << m.seq << ',' << text(m.sensor_id) << ',' << text(m.device_kind) << ',' << m.vendor_id
          << ',' << m.product_id << ',' << text(m.serial) << ',' << state_name(m.state) << ','
          << text(m.state_text) << ',' << num(m.scan_rate_hz) << ',' << m.n_channels << ',' << m.scans << ','
          << m.blocks << ',' << m.dropped_scans << ',' << m.usb_errors << ',' << m.overruns << ',' << m.reconnects
          << ',' << text(m.protocol_variant) << ',' << m.padding_set << ',' << m.publish_failures << '\n';
      ++rows;
    } else if (t == bus::MessageType::kCompensatorStatus) {
      pof::compensator_status_t m{};
      if (auto why = io::decode_lcm_event(ev, m)) return log.undecodable(ev, *why);
      out << m.utime << ',' << m.seq << ',' << text(m.sensor_id) << ',' << text(m.calibration_path) << ','
          << text(m.calibration_sensor_id) << ',' << text(m.calibration_date) << ',' << m.blocks << ',' << m.scans
          << ',' << m.lost_blocks << ',' << m.lost_scans << ',' << m.rejected_blocks << ',' << m.fault_scans << ','
          << m.angles << ',' << m.cycles << ',' << m.reloads << ',' << m.reload_failures << ','
          << text(m.last_error) << ',' << m.decode_errors << ',' << m.malformed_datagrams << ','
          << m.duplicate_blocks << ',' << m.publish_failures << ',' << (m.authenticated ? 1 : 0) << ','
          << m.auth_unsigned << ',' << m.auth_bad_mac << ',' << m.auth_stale << ',' << m.auth_replayed << ','
          << m.estimator_divergences << '\n';
      ++rows;
    } else {
      pof::raw_block_t m{};
      if (auto why = io::decode_lcm_event(ev, m)) return log.undecodable(ev, *why);
      if (!(m.scan_rate_hz > 0) || !std::isfinite(m.scan_rate_hz))
        return log.undecodable(ev, "scan_rate_hz " + num(m.scan_rate_hz) + ", expected > 0");
      // Times and scan indices of a damaged block can be any int64: no row may overflow.
      const double span_us = m.n_scans > 0 ? (m.n_scans - 1) * 1e6 / m.scan_rate_hz : 0.0;
      std::int64_t last = 0;
      if (!(span_us < 1e15) || __builtin_add_overflow(m.utime, static_cast<std::int64_t>(span_us) + 1, &last) ||
          __builtin_add_overflow(m.first_scan, std::int64_t{m.n_scans}, &last))
        return log.undecodable(ev, "utime or first_scan out of range");
      if (!raw_header_written) {
        raw_header_written = true;
        raw_names = m.channel_names;
        if (storage) {  // volts per DAQ channel; the flags as a number (raw_block_t.lcm's FLAG_*)
          std::vector<std::string> labels;
          for (const auto& c : m.channel_names) labels.push_back(px + c + "_v");
          labels.push_back(px + "flags");
          sto.set_labels(std::move(labels));
        }
        for (const auto& c : m.channel_names) out << ',' << c;
        out << '\n';
      } else if (m.channel_names != raw_names) {
        return log.undecodable(ev, "channel names differ from the first block's (the CSV columns)");
      }
      if (storage) {
        std::vector<double> values;
        for (int k = 0; k < m.n_scans; ++k) {
          values.clear();
          for (float v : m.volts[size_t(k)]) values.push_back(double(v));
          values.push_back(double(m.flags));
          sto.row(m.utime + std::llround(k * 1e6 / m.scan_rate_hz), values);
          ++rows;
        }
        return;
      }
      for (int k = 0; k < m.n_scans; ++k) {
        out << m.utime + std::llround(k * 1e6 / m.scan_rate_hz) << ',' << m.seq << ',' << m.first_scan + k << ','
            << m.flags;
        for (float v : m.volts[size_t(k)]) out << ',' << num(double(v));
        out << '\n';
        ++rows;
      }
    }
  });
  const bool damaged = log.damaged();
  if (events == 0 && !damaged) throw pof::DataError(o.log + ": no event on channel " + pof::excerpt(o.channel));
  if (type == bus::MessageType::kUnknown && !damaged) {
    throw pof::DataError(o.log + ": channel " + pof::excerpt(o.channel) +
                        ": not a pofkit message (angle_t, cycle_stats_t, raw_block_t, daq_status_t, "
                        "compensator_status_t)");
  }
  if (storage && (type == bus::MessageType::kDaqStatus || type == bus::MessageType::kCompensatorStatus)) {
    throw pof::UsageError("channel " + pof::excerpt(o.channel) + " holds " +
                          (type == bus::MessageType::kDaqStatus ? "daq_status_t" : "compensator_status_t") +
                          " messages: an OpenSim Storage file (--format sto|mot) takes angle_t, cycle_stats_t or "
                          "raw_block_t channels; --format csv writes status channels");
  }
  if (damaged && !o.salvage)
    throw pof::DataError(log.damage_report() + "; nothing written (--salvage writes what is readable)");
  if (type == bus::MessageType::kUnknown && damaged)
    throw pof::DataError(log.damage_report() + "; no readable event on channel " + pof::excerpt(o.channel) + ", nothing written");
  if (storage && !sto.order_problem().empty()) {
    throw pof::DataError(o.log + ": channel " + pof::excerpt(o.channel) + ": " + sto.order_problem() +
                         ": an OpenSim Storage file needs an increasing time; nothing written (--format csv "
                         "keeps every row)");
  }
  io::write_output(o.output, storage ? sto.text(o.channel) : out.str());
  if (o.output != "-") {
    std::fprintf(stderr, "pof export: %s: %" PRId64 " events -> %" PRId64 " rows in %s\n", o.channel.c_str(), events,
                 rows, o.output.c_str());
  }
  if (damaged)
    throw pof::DataError(log.damage_report() + "; salvaged " + std::to_string(rows) + " rows of channel " +
                        pof::excerpt(o.channel) + " into " + o.output);
}

}  // namespace

void add_export(CLI::App& app) {
  auto o = std::make_shared<ExportOptions>();
  auto* cmd = app.add_subcommand("export", "Write one channel of an LCM log (angles, cycle statistics, raw blocks, DAQ and compensator status) as CSV, "
                                 "or as an OpenSim Storage file (.sto/.mot)");
  cmd->add_option("log", o->log, "LCM log file (from pof record, lcm-logger or pof sim)")->required();
  cmd->add_option("--channel,-c", o->channel, "Channel, e.g. POF_ANGLE or POF_STATS_LEFT_KNEE")->required();
  cmd->add_option("-o,--output", o->output, "Output file ('-' for stdout)")->required();
  cmd->add_option("--format", o->format,
                  "csv, or sto/mot: an OpenSim Storage file of an angle, statistics or raw channel (time in s, "
                  "angles in deg); auto: sto/mot for an -o ending in .sto/.mot, else csv")
      ->check(CLI::IsMember({"auto", "csv", "sto", "mot"}))
      ->capture_default_str();
  cmd->add_flag("--salvage", o->salvage,
                "From a damaged log, write the rows of every event that can be read (still exit 65, with the counts)");
  cmd->callback([o] { run(*o); });
}

}  // namespace pof::cli
