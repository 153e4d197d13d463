// pof-daqd configuration: TOML + command-line overrides, validated key by key (exit 78 names it).
#include "pof/daq/stream/config.hpp"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "pof/bus/channels.hpp"
#include "pof/daq/device_ids.hpp"
#include "pof/base/errors.hpp"
#include "pof/base/text_file.hpp"
#include "pof/daq/protocol/mcc_usb1208ls.hpp"

namespace pof::daq {
namespace {

using pof::ConfigError;

[[noreturn]] void bad(const std::string& source, const std::string& key, const std::string& want,
                      const std::string& got = {}) {
  std::string msg = source + ": key '" + key + "': expected " + want;
  if (!got.empty()) msg += ", got " + got;
  throw ConfigError(msg);
}

std::string describe(const toml::node& n) {
  std::ostringstream os;
  if (n.is_string()) {
    os << '\'' << pof::excerpt(n.value_or(std::string{})) << '\'';
  } else if (n.is_table()) {
    os << "a table";
  } else if (n.is_array()) {
    os << "an array";
  } else {
    n.visit([&](const auto& v) { os << v; });
  }
  return os.str();
}

// Reads typed keys of one table and remembers which were consumed, so leftovers are reported.
class Reader {
 public:
  Reader(const toml::table& t, std::string source, std::string prefix)
      : t_(t), source_(std::move(source)), prefix_(std::move(prefix)) {}

  [[nodiscard]] std::string key(const std::string& k) const {
    return prefix_.empty() ? k : prefix_ + "." + k;
  }

  double number(const std::string& k, double def, double lo, double hi) {
    const toml::node* n = take(k);
    if (n == nullptr) return def;
    std::optional<double> v;
    if (n->is_floating_point() || n->is_integer()) v = n->value<double>();
    if (!v || !std::isfinite(*v) || *v < lo || *v > hi) {
      std::ostringstream want;
      want << "a number in [" << lo << ", " << hi << "]";
      bad(source_, key(k), want.str(), describe(*n));
    }
    return *v;
  }

  int integer(const std::string& k, int def, int lo, int hi) {
    const toml::node* n = take(k);
    if (n == nullptr) return def;
    const auto v = n->is_integer() ? n->value<std::int64_t>() : std::nullopt;
    if (!v || *v < lo || *v > hi) {
      bad(source_, key(k),
          "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]", describe(*n));
    }
    return static_cast<int>(*v);
  }

  std::string string(const std::string& k, const std::string& def) {
    const toml::node* n = take(k);
    if (n == nullptr) return def;
    if (!n->is_string()) bad(source_, key(k), "a string", describe(*n));
    return n->value_or(std::string{});
  }

  std::string choice(const std::string& k, const std::string& def,
                     const std::set<std::string>& allowed) {
    const std::string v = string(k, def);
    if (allowed.count(v) == 0U) {
      std::string want = "one of";
      for (const auto& a : allowed) want += " '" + a + "'";
      bad(source_, key(k), want, "'" + pof::excerpt(v) + "'");
    }
    return v;
  }

  const toml::table* table(const std::string& k) {
    const toml::node* n = take(k);
    if (n == nullptr) return nullptr;
    if (!n->is_table()) bad(source_, key(k), "a table", describe(*n));
    return n->as_table();
  }

  void finish() const {
    for (const auto& [k, v] : t_) {
      if (used_.count(std::string(k.str())) == 0U) {
        throw ConfigError(source_ + ": unknown key '" + key(pof::excerpt(k.str())) + "'");
      }
    }
  }

 private:
  const toml::node* take(const std::string& k) {
    used_.insert(k);
    return t_.get(k);
  }

  const toml::table& t_;
  std::string source_;
  std::string prefix_;
  std::set<std::string> used_;
};

double max_aggregate_rate(const std::string& kind) {
  if (kind == "usb6008") return 10000.0;   // daq-protocols.md: 10 kS/s aggregate
  if (kind == "usb6009") return 48000.0;   // 48 kS/s aggregate
  if (kind == "usb1208ls") return mcc::kMaxContinuousRateHz;  // mcc_usb1208ls.hpp [8]
  return 1e6;                              // simulator
}

}  // namespace

std::vector<ChannelMap> DaqConfig::channels() const {
  std::vector<ChannelMap> out;
  if (sensor_ai >= 0) out.push_back({"sensor", sensor_ai});
  if (reference_ai >= 0) out.push_back({"reference", reference_ai});
  if (pot_ai >= 0) out.push_back({"pot", pot_ai});
  return out;
}

std::string DaqConfig::raw_channel() const { return bus::channel(bus::Stream::kRaw, sensor_id); }
std::string DaqConfig::status_channel() const { return bus::channel(bus::Stream::kDaqStatus, sensor_id); }

void apply_override(toml::table& table, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw ConfigError("command line: override '" + assignment + "': expected key.path=value");
  }
  const std::string path = assignment.substr(0, eq);
  const std::string value = assignment.substr(eq + 1);
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + value);
  } catch (const toml::parse_error&) {
    parsed.insert_or_assign("v", value);  // a bare word: a string
  }
  toml::table* t = &table;
  std::string rest = path;
  for (auto dot = rest.find('.'); dot != std::string::npos; dot = rest.find('.')) {
    const std::string part = rest.substr(0, dot);
    rest = rest.substr(dot + 1);
    if (!t->contains(part)) t->insert(part, toml::table{});
    toml::node* n = t->get(part);
    if (!n->is_table()) {
      throw ConfigError("command line: override '" + assignment + "': '" + part +
                        "' is not a table");
    }
    t = n->as_table();
  }
  t->insert_or_assign(rest, *parsed.get("v"));
}

toml::table read_config_file(const std::filesystem::path& path) {
  const std::string text = pof::read_text_file(path.string(), "DAQ configuration file");
  try {
    return toml::parse(text, path.string());
  } catch (const toml::parse_error& e) {
    std::ostringstream os;
    os << path.string() << ":" << e.source().begin.line << ": " << pof::bound_quotes(e.description());
    throw ConfigError(os.str());
  }
}

DaqConfig config_from_table(const toml::table& root, const std::string& source) {
  DaqConfig c;
  Reader r(root, source, "");
  const int schema = r.integer("schema_version", -1, -1, 1000);
  if (schema != kSchemaVersion) {
    bad(source, "schema_version", std::to_string(kSchemaVersion),
        schema < 0 ? "nothing" : std::to_string(schema));
  }
  if (const toml::table* t = r.table("device")) {
    Reader d(*t, source, "device");
    c.device_kind = d.string("kind", c.device_kind);
    if (!find_device_id(c.device_kind) && c.device_kind.rfind("sim:", 0) != 0) {
      bad(source, "device.kind", "'usb6008', 'usb6009', 'usb1208ls' or 'sim:<scenario>'",
          "'" + pof::excerpt(c.device_kind) + "'");
    }
    c.serial = d.string("serial", c.serial);
    d.finish();
  }
  const double max_rate = max_aggregate_rate(c.device_kind);
  const bool mcc = c.device_kind == "usb1208ls";
  // The USB-1208LS holds at most 1.2 kS/s aggregate continuously (mcc_usb1208ls.hpp [8]) and
  // scans 4 inputs for the 3 channels: 250 scans/s is 1000 S/s.
  if (mcc) c.scan_rate_hz = 250.0;
  if (const toml::table* t = r.table("channels")) {
    Reader ch(*t, source, "channels");
    const int max_ai = c.device_kind == "usb1208ls" ? 7 : 7;
    c.sensor_ai = ch.integer("sensor", c.sensor_ai, 0, max_ai);
    c.reference_ai = ch.integer("reference", c.reference_ai, -1, max_ai);
    c.pot_ai = ch.integer("pot", c.pot_ai, -1, max_ai);
    ch.finish();
  }
  if (const toml::table* t = r.table("acquisition")) {
    Reader a(*t, source, "acquisition");
    c.scan_rate_hz = a.number("scan_rate_hz", c.scan_rate_hz, 1.0, max_rate);
    c.decimate = a.integer("decimate", c.decimate, 1, 10000);
    c.block_scans = a.integer("block_scans", c.block_scans, 1, static_cast<int>(kMaxBlockScans));
    c.terminal = a.choice("terminal", "rse", {"rse", "differential"}) == "rse"
                     ? ni::Terminal::kRse
                     : ni::Terminal::kDifferential;
    c.range_v = a.number("range_v", c.range_v, 1.0, 20.0);
    c.transfers_in_flight = a.integer("transfers_in_flight", c.transfers_in_flight, 1, 64);
    c.transfer_bytes = a.integer("transfer_bytes", c.transfer_bytes, 0, 16384);
    c.segment_scans = static_cast<std::uint32_t>(
        a.number("segment_scans", 0, 0, 4294967295.0));
    const std::string order = a.choice("sample_byte_order", "auto", {"auto", "big", "little"});
    c.sample_byte_order_auto = order == "auto";
    c.sample_byte_order = order == "little" ? ni::ByteOrder::kLittle : ni::ByteOrder::kBig;
    c.mcc_single_reads = a.choice("mcc_mode", "scan", {"scan", "single"}) == "single";
    c.command_timeout_ms = a.integer("command_timeout_ms", c.command_timeout_ms, 10, 60000);
    c.data_timeout_ms = a.integer("data_timeout_ms", c.data_timeout_ms, 10, 60000);
    a.finish();
    if (c.transfer_bytes % 64 != 0) {
      bad(source, "acquisition.transfer_bytes", "0 or a multiple of 64 (the packet size)",
          std::to_string(c.transfer_bytes));
    }
  }
  if (const toml::table* t = r.table("lcm")) {
    Reader l(*t, source, "lcm");
    c.lcm_url = l.string("url", c.lcm_url);
    c.sensor_id = l.string("sensor_id", c.sensor_id);
    c.queue_blocks = l.integer("queue_blocks", c.queue_blocks, 2, 65536);
    l.finish();
    for (char ch : c.sensor_id) {
      if (!((ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_')) {
        bad(source, "lcm.sensor_id", "upper-case letters, digits and '_'", "'" + pof::excerpt(c.sensor_id) + "'");
      }
    }
  }
  if (const toml::table* t = r.table("daemon")) {
    Reader d(*t, source, "daemon");
    c.retry_ms = d.integer("retry_ms", c.retry_ms, 10, 600000);
    c.status_period_s = d.number("status_period_s", c.status_period_s, 0.05, 3600.0);
    d.finish();
  }
  r.finish();

  // Cross-key checks, each naming the key that has to change.
  const auto chans = c.channels();
  for (std::size_t i = 0; i < chans.size(); ++i) {
    for (std::size_t j = i + 1; j < chans.size(); ++j) {
      if (chans[i].ai == chans[j].ai) {
        bad(source, "channels." + chans[j].name, "an input not used by channels." + chans[i].name,
            std::to_string(chans[j].ai));
      }
    }
  }
  if (c.terminal == ni::Terminal::kDifferential) {
    for (const auto& ch : chans) {
      if (ch.ai > 3) bad(source, "channels." + ch.name, "0-3 in differential mode", std::to_string(ch.ai));
    }
  }
  // Inputs the device really scans: the USB-1208LS queue holds 1, 2, 4 or 8 (mcc_usb1208ls.hpp
  // [3][9]); 3, 5-7 channels are padded with unused inputs whose samples are dropped.
  const std::size_t scanned = mcc && !c.mcc_single_reads ? mcc::queue_length(chans.size()) : chans.size();
  const double aggregate = c.scan_rate_hz * static_cast<double>(scanned);
  auto per_scan = [&](double limit) {
    std::ostringstream os;
    os << limit / static_cast<double>(scanned);
    return os.str();
  };
  const std::string inputs =
      std::to_string(scanned) + " inputs scanned" +
      (scanned != chans.size() ? " (" + std::to_string(chans.size()) +
                                     " channels padded: the USB-1208LS queue holds 1, 2, 4 or 8)"
                               : "");
  if (mcc && c.mcc_single_reads) {
    // Software-paced AIn reads: about 50 S/s (MCC USB-1208LS user manual, p. 9).
    if (aggregate > mcc::kMaxSoftwarePacedHz) {
      bad(source, "acquisition.scan_rate_hz",
          "at most " + per_scan(mcc::kMaxSoftwarePacedHz) + " scans/s with acquisition.mcc_mode = "
          "'single' on usb1208ls (software-paced: 50 AIn reads/s, " + inputs + ")",
          std::to_string(c.scan_rate_hz));
    }
  } else if (aggregate > max_rate) {
    bad(source, "acquisition.scan_rate_hz",
        "at most " + per_scan(max_rate) + " scans/s on " + c.device_kind + " (" +
            std::to_string(static_cast<int>(max_rate)) + " S/s aggregate, " + inputs + ")",
        std::to_string(c.scan_rate_hz));
  } else if (mcc && aggregate < mcc::kMinTimerRateHz) {
    bad(source, "acquisition.scan_rate_hz",
        "at least " + per_scan(mcc::kMinTimerRateHz) + " scans/s on usb1208ls in scan mode (its "
        "scan timer runs 100-8191 S/s aggregate, " + inputs + "; slower: acquisition.mcc_mode = 'single')",
        std::to_string(c.scan_rate_hz));
  }
  if (c.segment_scans != 0 && c.segment_scans % static_cast<std::uint32_t>(c.decimate) != 0) {
    bad(source, "acquisition.segment_scans", "0 or a multiple of acquisition.decimate",
        std::to_string(c.segment_scans));
  }
  return c;
}

std::string to_toml(const DaqConfig& c) {
  toml::table t{
      {"schema_version", kSchemaVersion},
      {"device", toml::table{{"kind", c.device_kind}, {"serial", c.serial}}},
      {"channels",
       toml::table{{"sensor", c.sensor_ai}, {"reference", c.reference_ai}, {"pot", c.pot_ai}}},
      {"acquisition",
       toml::table{{"scan_rate_hz", c.scan_rate_hz},
                   {"decimate", c.decimate},
                   {"block_scans", c.block_scans},
                   {"terminal", c.terminal == ni::Terminal::kRse ? "rse" : "differential"},
                   {"range_v", c.range_v},
                   {"transfers_in_flight", c.transfers_in_flight},
                   {"transfer_bytes", c.transfer_bytes},
                   {"segment_scans", static_cast<std::int64_t>(c.segment_scans)},
                   {"sample_byte_order", c.sample_byte_order_auto                           ? "auto"
                                         : c.sample_byte_order == ni::ByteOrder::kBig ? "big"
                                                                                       : "little"},
                   {"mcc_mode", c.mcc_single_reads ? "single" : "scan"},
                   {"command_timeout_ms", c.command_timeout_ms},
                   {"data_timeout_ms", c.data_timeout_ms}}},
      {"lcm", toml::table{{"url", c.lcm_url}, {"sensor_id", c.sensor_id}, {"queue_blocks", c.queue_blocks}}},
      {"daemon", toml::table{{"retry_ms", c.retry_ms}, {"status_period_s", c.status_period_s}}},
  };
  std::ostringstream os;
  os << t << "\n";
  return os.str();
}

}  // namespace pof::daq
