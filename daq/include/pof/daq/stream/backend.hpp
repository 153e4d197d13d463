#pragma once
// The one small interface every acquisition backend implements (usb6008, usb6009, usb1208ls,
// sim:<scenario>), in the style of ros2_control hardware interfaces: setup may allocate
// and report why it failed; the streaming path returns a small enum and never throws.
//
// Threads: every method runs on the daemon's acquisition thread (the one libusb event thread).
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace pof::daq {

struct DaqConfig;

/// Receives scans as they arrive. Called on the acquisition thread; must not block or allocate.
class ScanSink {
 public:
  virtual ~ScanSink() = default;
  ScanSink() = default;
  ScanSink(const ScanSink&) = delete;
  ScanSink& operator=(const ScanSink&) = delete;
  /// The device's scan clock (re)started between host times `earliest_us` and `latest_us`
  /// [us, CLOCK_REALTIME] (sending the start command and its acknowledgement).
  /// `continuous`: the scan index carries over (a re-armed segment, ni_usb600x.hpp [10]);
  /// otherwise scans since the last one received were lost (reconnect, error recovery).
  virtual void on_segment_start(std::int64_t earliest_us, std::int64_t latest_us,
                                bool continuous) noexcept = 0;
  /// `n_scans` scans, channel-interleaved volts in the configured channel order, whose newest scan
  /// arrived at host time `arrival_us`. `flags`: raw_block_t FLAG_* bits for these scans.
  virtual void on_scans(const float* volts, std::size_t n_scans, std::int64_t arrival_us,
                        std::int32_t flags) noexcept = 0;
  /// A failed, short or malformed transfer (counted; the backend decides whether to recover).
  virtual void on_usb_error() noexcept = 0;
  /// The protocol variants the device was seen to use (Variant bits, the full set each time).
  virtual void on_variant(std::uint32_t bits) noexcept = 0;
  /// `n` samples had padding bits set that no public source checks (counted, never dropped).
  virtual void on_padding_set(std::size_t n) noexcept = 0;
};

/// Protocol variants where the public sources disagree (docs/daq.md, "Protocol facts"): which
/// one the device used is published in daq_status_t.protocol_variant and logged.
enum Variant : std::uint32_t {
  kVariantHeader0000 = 1U << 0,         // NI replies begin 00 00 (comedi ni_usb6009.c)
  kVariantHeader0001 = 1U << 1,         // NI replies begin 00 01 (6008 sources, ni_usb6501.c)
  kVariantBigEndian = 1U << 2,          // NI samples big-endian
  kVariantLittleEndian = 1U << 3,       // NI samples little-endian (datalogger-rpi usb6008.py)
  kVariantOrderUndecided = 1U << 4,     // byte order not yet told from the data
  kVariantLayoutRecordFirst = 1U << 5,  // MCC report index at 102 (wjasper C)
  kVariantLayoutDataFirst = 1U << 6,    // MCC report index at 101 (wjasper Python, ryan-duve)
  kVariantPaddingSet = 1U << 7,         // NI samples with padding bits set were seen
  kVariantReport104 = 1U << 8,          // MCC scan reports of 104 bytes (no record number, wjasper Python)
  kVariantSeScanOffset = 1U << 9,       // MCC single-ended scan samples offset-coded (AIn probe)
  kVariantSeScanTwos = 1U << 10,        // MCC single-ended scan samples two's complement (AIn probe)
  kVariantSeScanUndecided = 1U << 11,   // MCC single-ended scan coding not told (blocks doubtful)
  kVariantSoftwarePaced = 1U << 12,     // MCC feature report refused: single AIn reads instead
};
/// Text for daq_status_t.protocol_variant, e.g. "reply header 00 01; samples big-endian".
std::string describe_variant(std::uint32_t bits);

enum class OpenStatus { kOk, kAbsent, kFault };
enum class StreamEnd { kStopped, kDisconnected, kError };

struct DeviceIdentity {
  std::string kind;
  int vendor_id = 0;
  int product_id = 0;
  std::string serial;
};

class Backend {
 public:
  virtual ~Backend() = default;
  Backend() = default;
  Backend(const Backend&) = delete;
  Backend& operator=(const Backend&) = delete;

  /// Finds, claims and configures the device. kAbsent: not attached (the daemon waits for it);
  /// kFault: attached but unusable. `why` names the device and the failing step. Never throws.
  virtual OpenStatus open(std::string& why) = 0;
  /// Streams until `stop` is set (kStopped), the device goes away (kDisconnected) or an error the
  /// daemon recovers from by re-opening (kError, `why` says what). Never throws.
  virtual StreamEnd stream(ScanSink& sink, const std::atomic<bool>& stop, std::string& why) = 0;
  /// Stops the acquisition (best effort) and releases the device. Safe to call twice.
  virtual void close() noexcept = 0;

  [[nodiscard]] virtual DeviceIdentity identity() const = 0;
  /// The scan rate the device really runs at (its clock divisor may round the configured one).
  [[nodiscard]] virtual double device_scan_rate_hz() const = 0;
};

/// Builds the backend `cfg.device_kind` names. Throws pof::ConfigError for an unknown kind.
std::unique_ptr<Backend> make_backend(const DaqConfig& cfg);

std::unique_ptr<Backend> make_usb600x_backend(const DaqConfig& cfg);
std::unique_ptr<Backend> make_usb1208ls_backend(const DaqConfig& cfg);
std::unique_ptr<Backend> make_sim_backend(const DaqConfig& cfg);

}  // namespace pof::daq
