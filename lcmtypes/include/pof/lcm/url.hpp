#pragma once
// The LCM URL every pofkit process uses, and channel names with the sensor-id suffix.
//
// URL: the --lcm-url option, else $LCM_DEFAULT_URL (deploy/config/pof.env sets it), else udpm on
// the host only (ttl=0). A udpm:// URL without recv_buf_size gets one: LCM's default kernel buffer
// drops silently from ~50k msg/s (docs/lcm.md); hosts need the sysctl in
// deploy/sysctl.d for the kernel to grant it.
#include <cstdlib>
#include <string>

namespace pof::lcmutil {

inline constexpr const char* kHostOnlyUrl = "udpm://239.255.76.67:7667?ttl=0";

inline std::string resolve_url(const std::string& cli_url, int recv_buf_bytes = 8 << 20) {
  std::string url = cli_url;
  if (url.empty()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    url = env != nullptr && *env != '\0' ? env : kHostOnlyUrl;
  }
  const auto query = url.find('?');
  const bool has_buf = query != std::string::npos && url.find("recv_buf_size=", query) != std::string::npos;
  if (url.rfind("udpm://", 0) == 0 && !has_buf)
    url += (url.find('?') == std::string::npos ? "?" : "&") + std::string("recv_buf_size=") + std::to_string(recv_buf_bytes);
  return url;
}

/// "POF_ANGLE" + sensor id "LEFT_KNEE" -> "POF_ANGLE_LEFT_KNEE"; no suffix for an empty id.
inline std::string channel(const std::string& base, const std::string& sensor_id) {
  return sensor_id.empty() ? base : base + "_" + sensor_id;
}

}  // namespace pof::lcmutil
