#pragma once
// Opening liblcm on a URL, the one way every pofkit process does it. liblcm reports a URL it cannot
// use only through good() (on udpm:// most often: no multicast route, docs/lcm.md "Transports").
// That is an I/O condition of the host, not a configuration error: exit 74 (IoError), so systemd's
// Restart= tries again once the network is up (a malformed URL is refused earlier, by
// parse_udpm_url, as a ConfigError).
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "pof/base/errors.hpp"

namespace pof::bus {

/// Throws IoError naming `url` unless `lcm` is usable.
inline void require_usable(const lcm::LCM& lcm, const std::string& url) {
  if (!lcm.good()) {
    throw IoError("LCM URL '" + url +
                  "': cannot open (is there a multicast route? docs/deployment.md, ./pofkit setup)");
  }
}

}  // namespace pof::bus
