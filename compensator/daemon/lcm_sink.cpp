#include "lcm_sink.hpp"

#include <utility>

#include "pof/lcm/utime.hpp"

namespace pof::compensatord {

LcmSink::Out::Out(std::string ch)
    : channel(std::move(ch)), refused("LCM refused to publish on " + channel + " (counted in publish_failures)") {}

LcmSink::LcmSink(bus::Publisher& pub, std::string angle_channel, std::string stats_channel, bus::ErrorLog& errors)
    : pub_(pub), angle_(std::move(angle_channel)), stats_(std::move(stats_channel)), errors_(errors) {}

bool LcmSink::sent(int rc, const Out& out) noexcept {
  if (rc != 0) errors_.note(out.channel, out.refused, lcmutil::now_utime());
  return rc == 0;
}

}  // namespace pof::compensatord
