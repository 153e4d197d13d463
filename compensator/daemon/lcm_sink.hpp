#pragma once
// pof-compensatord's Sink on the bus: publishes angles and cycle statistics through the daemon's
// pof::bus::Publisher (liblcm's publish(), signed in the authenticated mode). A message LCM refuses
// or the publisher cannot sign (publish() != 0, e.g. a channel name longer than
// LCM_MAX_CHANNEL_NAME_LENGTH) is
// reported to the pipeline, which counts it in compensator_status_t.publish_failures, and logged
// rate-limited through `errors`. The log lines are made at setup: publishing allocates nothing and
// never throws.
#include <string>

#include "pipeline.hpp"
#include "pof/bus/error_log.hpp"
#include "pof/bus/publisher.hpp"

namespace pof::compensatord {

class LcmSink final : public Sink {
 public:
  /// A channel and the line logged when LCM refuses a message on it.
  struct Out {
    explicit Out(std::string ch);
    std::string channel, refused;
  };

  LcmSink(bus::Publisher& pub, std::string angle_channel, std::string stats_channel, bus::ErrorLog& errors);
  bool angle(const pof::angle_t& m) override { return sent(pub_.publish(angle_.channel, m), angle_); }
  bool cycle(const pof::cycle_stats_t& m) override { return sent(pub_.publish(stats_.channel, m), stats_); }
  /// The publisher's result `rc` for a message on out.channel: true when published, else logged.
  bool sent(int rc, const Out& out) noexcept;

 private:
  bus::Publisher& pub_;
  Out angle_, stats_;
  bus::ErrorLog& errors_;
};

}  // namespace pof::compensatord
