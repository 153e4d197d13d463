// pof-daqd configuration: TOML + command-line overrides, validated key by key (exit 78 names it).
#include "pof/daq/stream/config.hpp"

#include <sstream>

#include "pof/bus/channels.hpp"
#include "pof/daq/device_ids.hpp"
#include "pof/base/errors.hpp"
#include "pof/base/toml_reader.hpp"
#include "pof/daq/protocol/mcc_usb1208ls.hpp"

namespace pof::daq {
namespace {

using pof::ConfigError;

double max_aggregate_rate(const std::string& kind) {
  if (kind == "usb6008") return 10000.0;   // docs/daq.md, "Protocol facts": 10 kS/s aggregate
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

toml::table read_config_file(const std::filesystem::path& path) {
  return pof::read_toml_file(path.string(), "DAQ configuration file");
}

DaqConfig config_from_table(const toml::table& root, const std::string& source) {
  using pof::toml_check::integer_in;
  using pof::toml_check::number_in;
  DaqConfig c;
  pof::TomlSection r(root, source);
  (void)r.schema_version({kSchemaVersion});
  r.with_section("device", [&](pof::TomlSection& d) {
    c.device_kind = d.get_or("kind", c.device_kind);
    if (!find_device_id(c.device_kind) && c.device_kind.rfind("sim:", 0) != 0) {
      d.fail("kind", "expected 'usb6008', 'usb6009', 'usb1208ls' or 'sim:<scenario>', got '" +
                         pof::excerpt(c.device_kind) + "'");
    }
    c.serial = d.get_or("serial", c.serial);
  });
  const double max_rate = max_aggregate_rate(c.device_kind);
  const bool mcc = c.device_kind == "usb1208ls";
  // The USB-1208LS holds at most 1.2 kS/s aggregate continuously (mcc_usb1208ls.hpp [8]) and
  // scans 4 inputs for the 3 channels: 250 scans/s is 1000 S/s.
  if (mcc) c.scan_rate_hz = 250.0;
  r.with_section("channels", [&](pof::TomlSection& ch) {
    const int max_ai = 7;
    c.sensor_ai = ch.get_or("sensor", c.sensor_ai, integer_in(0, max_ai));
    c.reference_ai = ch.get_or("reference", c.reference_ai, integer_in(-1, max_ai));
    c.pot_ai = ch.get_or("pot", c.pot_ai, integer_in(-1, max_ai));
  });
  r.with_section("acquisition", [&](pof::TomlSection& a) {
    c.scan_rate_hz = a.get_or("scan_rate_hz", c.scan_rate_hz, number_in(1.0, max_rate));
    c.decimate = a.get_or("decimate", c.decimate, integer_in(1, 10000));
    c.block_scans = a.get_or("block_scans", c.block_scans, integer_in(1, static_cast<std::int64_t>(kMaxBlockScans)));
    c.terminal = a.get_enum_or("terminal", ni::Terminal::kRse,
                               {{"rse", ni::Terminal::kRse}, {"differential", ni::Terminal::kDifferential}});
    c.range_v = a.get_or("range_v", c.range_v, number_in(1.0, 20.0));
    c.transfers_in_flight = a.get_or("transfers_in_flight", c.transfers_in_flight, integer_in(1, 64));
    c.transfer_bytes = a.get_or("transfer_bytes", c.transfer_bytes, integer_in(0, 16384));
    c.segment_scans = static_cast<std::uint32_t>(a.get_or("segment_scans", 0.0, number_in(0, 4294967295.0)));
    enum class Order { kAuto, kBig, kLittle };
    const Order order = a.get_enum_or("sample_byte_order", Order::kAuto,
                                      {{"auto", Order::kAuto}, {"big", Order::kBig}, {"little", Order::kLittle}});
    c.sample_byte_order_auto = order == Order::kAuto;
    c.sample_byte_order = order == Order::kLittle ? ni::ByteOrder::kLittle : ni::ByteOrder::kBig;
    enum class MccMode { kScan, kSingle, kAuto };
    const MccMode mode = a.get_enum_or("mcc_mode", MccMode::kScan,
                                       {{"scan", MccMode::kScan}, {"single", MccMode::kSingle}, {"auto", MccMode::kAuto}});
    c.mcc_single_reads = mode == MccMode::kSingle;
    c.mcc_fallback_single = mode == MccMode::kAuto;
    c.command_timeout_ms = a.get_or("command_timeout_ms", c.command_timeout_ms, integer_in(10, 60000));
    c.data_timeout_ms = a.get_or("data_timeout_ms", c.data_timeout_ms, integer_in(10, 60000));
    if (c.transfer_bytes % 64 != 0) {
      a.fail("transfer_bytes", "expected 0 or a multiple of 64 (the packet size), got " + std::to_string(c.transfer_bytes));
    }
  });
  r.with_section("lcm", [&](pof::TomlSection& l) {
    c.lcm_url = l.get_or("url", c.lcm_url);
    c.sensor_id = l.get_or("sensor_id", c.sensor_id);
    c.queue_blocks = l.get_or("queue_blocks", c.queue_blocks, integer_in(2, 65536));
    c.auth_key_file = l.get_or("auth_key_file", c.auth_key_file);
    if (const std::string why = bus::sensor_id_problem(c.sensor_id); !why.empty())
      l.fail("sensor_id", why + ", got '" + pof::excerpt(c.sensor_id) + "'");
  });
  r.with_section("daemon", [&](pof::TomlSection& d) {
    c.retry_ms = d.get_or("retry_ms", c.retry_ms, integer_in(10, 600000));
    c.status_period_s = d.get_or("status_period_s", c.status_period_s, number_in(0.05, 3600.0));
    c.stall_ms = d.get_or("stall_ms", c.stall_ms, integer_in(0, 3600000));
  });
  r.finish();

  // Cross-key checks, each naming the key that has to change (at its line when the file has it).
  auto bad = [&r](const std::string& key, const std::string& want, const std::string& got) {
    r.fail(key, "expected " + want + ", got " + got);
  };
  const auto chans = c.channels();
  for (std::size_t i = 0; i < chans.size(); ++i) {
    for (std::size_t j = i + 1; j < chans.size(); ++j) {
      if (chans[i].ai == chans[j].ai) {
        bad("channels." + chans[j].name, "an input not used by channels." + chans[i].name,
            std::to_string(chans[j].ai));
      }
    }
  }
  if (c.terminal == ni::Terminal::kDifferential) {
    for (const auto& ch : chans) {
      if (ch.ai > 3) bad("channels." + ch.name, "0-3 in differential mode", std::to_string(ch.ai));
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
      bad("acquisition.scan_rate_hz",
          "at most " + per_scan(mcc::kMaxSoftwarePacedHz) + " scans/s with acquisition.mcc_mode = "
          "'single' on usb1208ls (software-paced: 50 AIn reads/s, " + inputs + ")",
          std::to_string(c.scan_rate_hz));
    }
  } else if (aggregate > max_rate) {
    bad("acquisition.scan_rate_hz",
        "at most " + per_scan(max_rate) + " scans/s on " + c.device_kind + " (" +
            std::to_string(static_cast<int>(max_rate)) + " S/s aggregate, " + inputs + ")",
        std::to_string(c.scan_rate_hz));
  } else if (mcc && aggregate < mcc::kMinTimerRateHz) {
    bad("acquisition.scan_rate_hz",
        "at least " + per_scan(mcc::kMinTimerRateHz) + " scans/s on usb1208ls in scan mode (its "
        "scan timer runs 100-8191 S/s aggregate, " + inputs + "; slower: acquisition.mcc_mode = 'single')",
        std::to_string(c.scan_rate_hz));
  }
  if (c.segment_scans != 0 && c.segment_scans % static_cast<std::uint32_t>(c.decimate) != 0) {
    bad("acquisition.segment_scans", "0 or a multiple of acquisition.decimate",
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
                   {"mcc_mode", c.mcc_single_reads ? "single" : c.mcc_fallback_single ? "auto" : "scan"},
                   {"command_timeout_ms", c.command_timeout_ms},
                   {"data_timeout_ms", c.data_timeout_ms}}},
      {"lcm", toml::table{{"url", c.lcm_url},
                          {"sensor_id", c.sensor_id},
                          {"queue_blocks", c.queue_blocks},
                          {"auth_key_file", c.auth_key_file}}},
      {"daemon", toml::table{{"retry_ms", c.retry_ms}, {"status_period_s", c.status_period_s}, {"stall_ms", c.stall_ms}}},
  };
  std::ostringstream os;
  os << t << "\n";
  return os.str();
}

}  // namespace pof::daq
