// LCM log reader for pof.raw_block_t recordings (format in recording_reader.hpp; the event framing
// and its damage handling in lcmlog_scan.hpp).
#include <cmath>
#include <string>
#include <vector>

#include <pof/raw_block_t.hpp>

#include "pof/base/errors.hpp"
#include "pof/bus/channels.hpp"
#include "pof/io/lcmlog_scan.hpp"
#include "pof/io/recording_reader.hpp"

namespace pof::io {

namespace {
bool is_raw_channel(std::string_view c) {
  const auto name = bus::parse_channel(c);
  return name && name->stream == bus::Stream::kRaw;
}
}  // namespace

Recording read_lcmlog(const std::string& path, const std::string& channel) {
  LcmLogReader log(path);
  return read_lcmlog(log, channel);
}

Recording read_lcmlog(LcmLogReader& log, const std::string& channel) {
  const std::string& path = log.path();
  std::string chan = channel;
  std::vector<double> t, sensor, ref, pot, angle_ref, angle_true;
  bool has_pot = false, has_angle_ref = false, has_angle_true = false;
  std::int64_t utime0 = 0;
  bool first = true;
  int c_sensor = -1, c_ref = -1, c_pot = -1, c_aref = -1, c_atrue = -1;
  std::vector<std::string> names0;
  // The first content error stops the reading but not the scan, so that framing damage, which is
  // the likelier cause, is what gets reported when there is some.
  std::string content_error;
  auto fail = [&](const std::string& what) { content_error = what; };
  log.scan([&](const LcmEventRef& ev) {
    if (!content_error.empty()) return;
    if (chan.empty() && is_raw_channel(ev.channel)) chan = ev.channel;
    if (ev.channel != chan) return;
    auto at = [&] {
      return path + ": event " + std::to_string(ev.event_number) + " on " + excerpt(chan) + " (byte " +
             std::to_string(ev.offset) + "): ";
    };
    pof::raw_block_t b;
    if (auto why = decode_lcm_event(ev, b)) {
      // Not a raw block: damage (counted, reported with the rest once the scan is done).
      log.undecodable(ev, "not a pof.raw_block_t (" + *why + ")");
      return;
    }
    if (b.n_channels <= 0 || b.n_scans < 0 || !(b.scan_rate_hz > 0) || !std::isfinite(b.scan_rate_hz))
      return fail(at() + "n_channels " + std::to_string(b.n_channels) + ", n_scans " + std::to_string(b.n_scans) +
                      ", scan_rate_hz " + std::to_string(b.scan_rate_hz) + ": expected > 0");
    if (first) {
      first = false;
      utime0 = b.utime;
      names0 = b.channel_names;
      for (int c = 0; c < b.n_channels; ++c) {
        const std::string& nm = b.channel_names[static_cast<std::size_t>(c)];
        if (nm == "sensor") c_sensor = c;
        else if (nm == "reference") c_ref = c;
        else if (nm == "pot") c_pot = c;
        else if (nm == "angle_ref") c_aref = c;
        else if (nm == "angle_true") c_atrue = c;
      }
      std::string got;
      for (const auto& nm : b.channel_names) got += (got.empty() ? "" : ",") + nm;
      if (c_sensor < 0 || c_ref < 0)
        return fail(path + ": channel " + excerpt(chan) + ": raw blocks have channels [" + excerpt(got) +
                        "]; expected \"sensor\" and \"reference\"");
      if (c_pot < 0 && c_aref < 0)
        return fail(path + ": channel " + excerpt(chan) + ": raw blocks have channels [" + excerpt(got) +
                        "]; expected \"pot\" or \"angle_ref\" for the reference angle");
      has_pot = c_pot >= 0;
      has_angle_ref = c_aref >= 0;
      has_angle_true = c_atrue >= 0;
    } else if (b.channel_names != names0) {
      return fail(at() + "channel names changed mid-recording");
    }
    // utime is any int64 in a damaged file: subtract without overflow.
    std::int64_t dt_us = 0;
    if (__builtin_sub_overflow(b.utime, utime0, &dt_us))
      return fail(at() + "block utime " + std::to_string(b.utime) + " is out of range of the first block's");
    const double tb = static_cast<double>(dt_us) * 1e-6;
    if (!t.empty() && b.n_scans > 0 && !(tb > t.back()))
      return fail(at() + "block utime " + std::to_string(b.utime) +
                      " does not follow the previous block (scans out of order or repeated)");
    for (int k = 0; k < b.n_scans; ++k) {
      const auto& row = b.volts[static_cast<std::size_t>(k)];
      auto at_c = [&](int c) { return static_cast<double>(row[static_cast<std::size_t>(c)]); };
      t.push_back(tb + k / b.scan_rate_hz);
      sensor.push_back(at_c(c_sensor));
      ref.push_back(at_c(c_ref));
      if (has_pot) pot.push_back(at_c(c_pot));
      if (has_angle_ref) angle_ref.push_back(at_c(c_aref));
      if (has_angle_true) angle_true.push_back(at_c(c_atrue));
    }
  });
  // A recording with a hole would calibrate and score as if nothing were missing: refuse it whole.
  if (log.damaged()) throw DataError(log.damage_report());
  if (!content_error.empty()) throw DataError(content_error);
  if (first)
    throw DataError(path + ": no pof.raw_block_t events on " +
                    (chan.empty() ? std::string("a POF_RAW* channel") : "channel " + excerpt(chan)) + " among " +
                    std::to_string(log.result().events) + " event(s)");
  auto to_vec = [](const std::vector<double>& v) {
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  Recording r;
  r.source = path;
  r.t_s = to_vec(t);
  r.sensor_v = to_vec(sensor);
  r.reference_v = to_vec(ref);
  if (has_angle_ref) r.angle_ref_deg = to_vec(angle_ref);
  if (has_pot) r.pot_v = to_vec(pot);
  if (has_angle_true) r.angle_true_deg = to_vec(angle_true);
  return r;
}

}  // namespace pof::io
