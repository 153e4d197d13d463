#pragma once
// pof-daqd settings: a plain struct (the habit of Drake's lcm/ settings structs), read from TOML
// (/etc/pof/daqd.toml in deployment; example in deploy/config/daqd.toml) and overridden from the
// command line. Every error names the file and key and throws pof::ConfigError (exit 78).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "pof/daq/protocol/ni_usb600x.hpp"

#include <toml++/toml.h>

namespace pof::daq {

inline constexpr int kSchemaVersion = 1;
inline constexpr std::size_t kMaxChannels = 3;       // sensor, reference, pot
inline constexpr std::size_t kMaxBlockScans = 4096;  // per published raw block

struct ChannelMap {
  std::string name;  // "sensor", "reference", "pot" (the raw_block_t contract)
  int ai = -1;       // device analog input
};

struct DaqConfig {
  // [device]
  std::string device_kind = "usb6008";  // usb6008 | usb6009 | usb1208ls | sim:<scenario>
  std::string serial;                   // pick this device when several are attached
  // [acquisition]
  double scan_rate_hz = 2000.0;         // device scan rate (all channels once per scan)
  int decimate = 10;                    // average this many scans into one published scan
  int block_scans = 1;                  // published scans per raw block
  ni::Terminal terminal = ni::Terminal::kRse;
  double range_v = 10.0;                // +- input range [V]
  int transfers_in_flight = 4;          // libusb bulk-IN transfers kept submitted
  int transfer_bytes = 0;               // bytes per transfer, 0 = auto (~4 ms of data)
  std::uint32_t segment_scans = 0;      // scans per finite segment, 0 = as many as allowed
  ni::ByteOrder sample_byte_order = ni::ByteOrder::kBig;  // USB-6008 only (see protocol [9])
  bool sample_byte_order_auto = true;   // USB-6008: tell the byte order from the data ("auto")
  bool mcc_single_reads = false;        // USB-1208LS: one AIn per channel per scan (else AInScan)
  bool mcc_fallback_single = false;     // USB-1208LS "auto": AInScan, or single AIn reads (45
                                        // reads/s) when the device refuses the scan's feature report
  int command_timeout_ms = 1000;        // per command round trip
  int data_timeout_ms = 2000;           // a data transfer with nothing for this long is an error
  // [channels] analog input per role; -1 = not wired
  int sensor_ai = 0;
  int reference_ai = 1;
  int pot_ai = 2;
  // [lcm]
  std::string lcm_url;                  // "": $LCM_DEFAULT_URL, else udpm on this host (pof/bus/url.hpp)
  std::string sensor_id;                // suffix of the channels: POF_RAW_<SENSOR_ID>
  int queue_blocks = 256;               // publisher queue depth [blocks]
  std::string auth_key_file;            // bus key: sign what is published (authenticated mode); "":
                                        // $POF_LCM_AUTH_KEY_FILE, else unauthenticated (pof/bus/auth_key.hpp)
  // [daemon]
  int retry_ms = 500;                   // wait between attempts to open the device
  double status_period_s = 1.0;
  int stall_ms = 0;                     // a stream without scans this long is reported stalled (and its
                                        // late blocks flagged); 0 = auto (pof/daq/stream/liveness.hpp)

  /// The wired channels in scan order, named per the raw_block_t contract.
  [[nodiscard]] std::vector<ChannelMap> channels() const;
  [[nodiscard]] std::string raw_channel() const;
  [[nodiscard]] std::string status_channel() const;
  [[nodiscard]] double published_rate_hz() const { return scan_rate_hz / decimate; }
};

/// Reads and validates every key of `table` (pof::TomlSection, pof/base/toml_reader.hpp);
/// `source` names it in errors where a value has no line of the file (a command-line override:
/// "daq.toml + command line"). Unknown keys are errors, with the nearest known key. Throws
/// pof::ConfigError.
DaqConfig config_from_table(const toml::table& table, const std::string& source);

/// Parses the file (at most pof::kMaxTextFileBytes). Throws NoInputError (missing), ConfigError
/// (bad TOML, "<file>:<line>: TOML syntax error: ...").
toml::table read_config_file(const std::filesystem::path& path);

/// The effective configuration as TOML (for --print-config).
std::string to_toml(const DaqConfig& cfg);

}  // namespace pof::daq
