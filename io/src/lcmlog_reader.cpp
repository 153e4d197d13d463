// LCM log reader for pof.raw_block_t recordings (format in recording_reader.hpp, lcm.md "Log
// format"). lcm_eventlog skips bytes until it finds a sync word and returns NULL both at the end
// and on a truncated event, so the reader checks that each event starts where the previous one
// ended and that the last one ends at the end of the file.
#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <pof/raw_block_t.hpp>

#include "pof/io/errors.hpp"
#include "pof/io/recording_reader.hpp"

namespace pof::io {

namespace {
constexpr long kEventHeaderBytes = 28;  // sync u32, eventnum i64, timestamp i64, chanlen u32, datalen u32
bool is_raw_channel(const std::string& c) { return c == "POF_RAW" || c.rfind("POF_RAW_", 0) == 0; }
}  // namespace

Recording read_lcmlog(const std::string& path, const std::string& channel) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw NoInputError(path + ": cannot open: " + std::strerror(errno));
  lcm::LogFile log(path, "r");
  if (!log.good()) throw NoInputError(path + ": cannot open as an LCM log");
  FILE* fp = log.getFilePtr();
  const long size = static_cast<long>(st.st_size);

  std::string chan = channel;
  std::vector<double> t, sensor, ref, pot, angle_ref, angle_true;
  bool has_pot = false, has_angle_ref = false, has_angle_true = false;
  std::int64_t utime0 = 0;
  bool first = true;
  long pos = std::ftell(fp);
  long n_events = 0;
  int c_sensor = -1, c_ref = -1, c_pot = -1, c_aref = -1, c_atrue = -1;
  std::vector<std::string> names0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    ++n_events;
    const long end = std::ftell(fp);
    const long expect = pos + kEventHeaderBytes + static_cast<long>(ev->channel.size()) + static_cast<long>(ev->datalen);
    if (end != expect)
      throw DataError(path + ": byte " + std::to_string(pos) + ": " + std::to_string(end - expect) +
                      " corrupt byte(s) before event " + std::to_string(n_events));
    pos = end;
    if (chan.empty() && is_raw_channel(ev->channel)) chan = ev->channel;
    if (ev->channel != chan) continue;
    pof::raw_block_t b;
    if (b.decode(ev->data, 0, ev->datalen) < 0)
      throw DataError(path + ": event " + std::to_string(n_events) + " on channel " + chan +
                      " (byte " + std::to_string(end - ev->datalen) + "): not a pof.raw_block_t (fingerprint or length mismatch)");
    if (b.n_channels <= 0 || b.n_scans < 0 || !(b.scan_rate_hz > 0))
      throw DataError(path + ": event " + std::to_string(n_events) + " on " + chan + ": n_channels " +
                      std::to_string(b.n_channels) + ", n_scans " + std::to_string(b.n_scans) + ", scan_rate_hz " +
                      std::to_string(b.scan_rate_hz) + ": expected > 0");
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
        throw DataError(path + ": channel " + chan + ": raw blocks have channels [" + got +
                        "]; expected \"sensor\" and \"reference\"");
      if (c_pot < 0 && c_aref < 0)
        throw DataError(path + ": channel " + chan + ": raw blocks have channels [" + got +
                        "]; expected \"pot\" or \"angle_ref\" for the reference angle");
      has_pot = c_pot >= 0;
      has_angle_ref = c_aref >= 0;
      has_angle_true = c_atrue >= 0;
    } else if (b.channel_names != names0) {
      throw DataError(path + ": event " + std::to_string(n_events) + " on " + chan + ": channel names changed mid-recording");
    }
    const double tb = static_cast<double>(b.utime - utime0) * 1e-6;
    if (!t.empty() && b.n_scans > 0 && !(tb > t.back()))
      throw DataError(path + ": event " + std::to_string(n_events) + " on " + chan + ": block utime " +
                      std::to_string(b.utime) + " does not follow the previous block (scans out of order or repeated)");
    for (int k = 0; k < b.n_scans; ++k) {
      const auto& row = b.volts[static_cast<std::size_t>(k)];
      auto at = [&](int c) { return static_cast<double>(row[static_cast<std::size_t>(c)]); };
      t.push_back(tb + k / b.scan_rate_hz);
      sensor.push_back(at(c_sensor));
      ref.push_back(at(c_ref));
      if (has_pot) pot.push_back(at(c_pot));
      if (has_angle_ref) angle_ref.push_back(at(c_aref));
      if (has_angle_true) angle_true.push_back(at(c_atrue));
    }
  }
  if (pos != size)
    throw DataError(path + ": byte " + std::to_string(pos) + ": truncated or corrupt LCM event after event " +
                    std::to_string(n_events) + " (file has " + std::to_string(size) + " bytes)");
  if (first)
    throw DataError(path + ": no pof.raw_block_t events on " + (chan.empty() ? std::string("a POF_RAW* channel") : "channel " + chan) +
                    " among " + std::to_string(n_events) + " event(s)");
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
