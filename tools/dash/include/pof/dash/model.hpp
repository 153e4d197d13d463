#pragma once
// The model behind `pof dash` (docs/dashboard.md): every
// POF_ANGLE/POF_STATS/POF_DAQ_STATUS/ POF_COMPENSATOR_STATUS message in, per
// sensor; JSON frames out, one per browser per tick. No LCM, no sockets:
// unit-tested with bytes and a clock.
//
// The bus runs at up to 3,333 angles/s per sensor; a chart needs ~100 points/s.
// Angles are thinned to one point per display bucket (the bucket's last angle,
// with the quality bits of every angle in it OR-ed in, so a flagged scan is
// never hidden by the thinning) and kept in a fixed ring of the display window.
// Each browser has a Cursor: a frame carries what that browser has not seen
// yet, so a slow browser that skipped frames catches up from the ring, and one
// that fell out of it gets the whole window again ("reset"). The model's memory
// is bounded by construction: the rings, the cycles kept and kMaxSensors;
// everything beyond is counted, not stored.
//
// Thread safety: none. cmd_dash.cpp holds one mutex around the receive thread's
// on_message() and the web server's frame().
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>
#include <pof/angle_t.hpp>
#include <pof/compensator_status_t.hpp>
#include <pof/cycle_stats_t.hpp>
#include <pof/daq_status_t.hpp>

namespace pof::dash {

struct ModelSettings {
  double display_hz = 100;  // chart points per second and sensor
  double window_s = 60;     // history a browser can show
  std::size_t cycles_kept = 64;
};

/// One chart point: a display bucket's last angle.
struct Point {
  int64_t utime = 0;  // scan time of the angle [us]
  float angle_deg = 0, uncomp_deg = 0, ref_deg = 0, sigma_deg = 0;
  int32_t quality = 0;  // OR over every angle of the bucket
};

/// What the process around the model knows and the model cannot: the receiver's
/// counters and the web server's. Shown on the page's health panel.
struct BusHealth {
  std::string url;
  bool authenticated = false;
  uint64_t auth_dropped = 0;  // unsigned + bad MAC + stale + replayed
  uint64_t malformed_datagrams = 0;
  uint64_t decode_errors = 0;
  uint64_t kernel_drops = 0;  // datagrams the kernel dropped on the receive socket
  uint64_t clients = 0;
  uint64_t frames_sent = 0;
  uint64_t frames_skipped = 0;  // a browser's send buffer was full: it catches up later
};

/// Where one browser is: the next point and cycle it has not been sent, per
/// sensor.
struct Cursor {
  std::map<std::string, uint64_t, std::less<>> next_point;
  std::map<std::string, uint64_t, std::less<>> next_cycle;
};

class Model {
 public:
  /// More sensors than this are counted in ignored_sensors(), not shown (any
  /// local process can publish POF_ANGLE_<anything>; the model must not grow
  /// with it).
  static constexpr std::size_t kMaxSensors = 32;

  explicit Model(ModelSettings s = {});

  /// One message off the bus. Channels that are not
  /// POF_ANGLE/STATS/DAQ_STATUS/COMPENSATOR_STATUS are ignored; what does not
  /// decode is counted per sensor. Never throws.
  void on_message(std::string_view channel, const void* data, std::size_t size, int64_t recv_utime) noexcept;
  /// Closes display buckets older than a bucket (a stream that stopped still
  /// shows its last point) and updates the angle rates. Call at the frame rate
  /// with the current time [us].
  void tick(int64_t now_utime);
  void set_bus(const BusHealth& b) { bus_ = b; }

  /// What `c`'s browser has not seen, and the health of every sensor, as JSON
  /// (docs/dashboard.md, "Frames"); advances `c`.
  [[nodiscard]] nlohmann::json frame(Cursor& c, int64_t now_utime) const;

  [[nodiscard]] std::size_t sensors() const { return sensors_.size(); }
  [[nodiscard]] uint64_t ignored_sensors() const { return ignored_sensors_; }
  /// Points ever added for `sensor_id` (0 for an unknown sensor).
  [[nodiscard]] uint64_t points_added(std::string_view sensor_id) const;
  [[nodiscard]] std::size_t ring_capacity() const { return ring_capacity_; }

 private:
  struct Sensor {
    std::vector<Point> ring;       // ring_capacity_ points; index i lives at ring[i % size]
    uint64_t points = 0;           // points ever added: the next point's index
    std::optional<Point> pending;  // the open bucket
    int64_t bucket_end = 0;
    std::optional<pof::angle_t> angle;  // the latest angle, unthinned
    int64_t angle_recv_utime = 0;
    uint64_t angles = 0, flagged = 0;
    uint64_t missing = 0;  // angles missing from the seq sequence
    int64_t last_seq = -1;
    double rate_hz = 0;
    int64_t rate_utime = 0;
    uint64_t rate_angles = 0;
    std::vector<pof::cycle_stats_t> cycles;  // the last cycles_kept, cycle i at cycles[i % size]
    uint64_t cycles_total = 0;
    std::optional<pof::daq_status_t> daq;
    int64_t daq_recv_utime = 0;
    std::optional<pof::compensator_status_t> compensator;
    int64_t compensator_recv_utime = 0;
    uint64_t decode_errors = 0;
  };

  Sensor* sensor(const std::string& id) noexcept;
  void add_angle(Sensor& s, const pof::angle_t& a, int64_t recv_utime);
  void close_bucket(Sensor& s);
  [[nodiscard]] nlohmann::json sensor_frame(const std::string& id, const Sensor& s, Cursor& c, int64_t now) const;

  ModelSettings settings_;
  int64_t bucket_us_ = 10'000;
  std::size_t ring_capacity_ = 6000;
  std::map<std::string, Sensor, std::less<>> sensors_;
  uint64_t ignored_sensors_ = 0;
  int64_t epoch_utime_ = 0;  // the first angle's scan time: chart times are seconds since it
  BusHealth bus_;
};

}  // namespace pof::dash
