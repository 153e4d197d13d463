#pragma once
// The LCM URL every pofkit process uses, and what a udpm:// URL says: the one implementation.
// Header-only C++17 without pofkit libraries, so that a controller built against the installed SDK
// (examples/cpp_client) follows the same rule. lcmtypes/python/pofkit/udpm.py mirrors it (Python cannot
// share this code); tests/python/test_pofkit.py compares the two on a list of URLs.
//
// Which URL: the --lcm-url option (pof-daqd: also lcm.url of its configuration file), else
// $LCM_DEFAULT_URL (deploy/config/pof.env sets it for every unit), else udpm on this host only
// (ttl=0). A udpm:// URL without recv_buf_size gets one: with the kernel's default receive buffer
// LCM receivers lose messages from ~50k msg/s, and raw blocks of 300 KB-1 MB do not fit at all;
// hosts need deploy/sysctl.d for the kernel to grant more (docs/deployment.md, "The UDP receive
// buffer").
//
// What a udpm:// URL says, in liblcm's syntax (lcm/lcm_udpm.c): udpm://GROUP:PORT?ttl=N&recv_buf_size=N
//   GROUP          an IPv4 multicast address as inet_aton(3) reads it; default 239.255.76.67
//   PORT           decimal digits, 1..65535; default 7667
//   ttl            decimal digits, 0..255; default 0
//   recv_buf_size  decimal digits, 0..2^30 bytes; default 0 (the kernel's default)
// A key given twice takes its last value; other options (liblcm's transmit-only ones) are ignored.
#include <arpa/inet.h>
#include <netinet/in.h>

#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

namespace pof::bus {

inline constexpr const char* kHostOnlyUrl = "udpm://239.255.76.67:7667?ttl=0";
/// What pofkit's receivers ask the kernel for [bytes] (granted up to net.core.rmem_max).
inline constexpr int kRecvBufBytes = 8 << 20;

/// The URL a process uses: `cli_url`, else $LCM_DEFAULT_URL, else kHostOnlyUrl; recv_buf_size added
/// to a udpm:// URL that has none.
inline std::string resolve_url(const std::string& cli_url, int recv_buf_bytes = kRecvBufBytes) {
  std::string url = cli_url;
  if (url.empty()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    url = env != nullptr && *env != '\0' ? env : kHostOnlyUrl;
  }
  const auto query = url.find('?');
  const bool has_buf = query != std::string::npos && url.find("recv_buf_size=", query) != std::string::npos;
  if (url.rfind("udpm://", 0) == 0 && !has_buf)
    url += (query == std::string::npos ? "?" : "&") + std::string("recv_buf_size=") + std::to_string(recv_buf_bytes);
  return url;
}

/// The fields of a udpm:// URL, or what is wrong with it.
struct UdpmUrl {
  std::string group = "239.255.76.67";
  std::uint16_t port = 7667;
  int ttl = 0;
  int recv_buf_size = 0;  // 0: the kernel's default
  /// "" for a valid URL, else what is wrong, e.g. "port: expected 1..65535" (without the URL: the
  /// caller names it, as in "LCM URL 'udpm://...': port: expected 1..65535").
  std::string error;
  [[nodiscard]] bool ok() const { return error.empty(); }
};

namespace detail {
// Decimal digits only (no sign, space or base prefix), at most `max`.
inline bool decimal(std::string_view s, long max, long& out) {
  if (s.empty() || s.size() > 10) return false;
  long v = 0;
  for (const char c : s) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  if (v > max) return false;
  out = v;
  return true;
}
}  // namespace detail

/// udpm://GROUP:PORT?ttl=N&recv_buf_size=N -> its fields; `error` says what is wrong otherwise.
inline UdpmUrl parse_udpm_url(std::string_view url) {
  UdpmUrl u;
  constexpr std::string_view kScheme = "udpm://";
  if (url.substr(0, kScheme.size()) != kScheme) {
    u.error = "not a udpm:// URL";
    return u;
  }
  std::string_view rest = url.substr(kScheme.size());
  std::string_view query;
  if (const auto q = rest.find('?'); q != std::string_view::npos) {
    query = rest.substr(q + 1);
    rest = rest.substr(0, q);
  }
  if (!rest.empty()) {
    const auto colon = rest.find(':');
    u.group = std::string(rest.substr(0, colon));
    if (colon != std::string_view::npos) {
      long port = 0;
      if (!detail::decimal(rest.substr(colon + 1), 65535, port) || port == 0) {
        u.error = "port: expected 1..65535";
        return u;
      }
      u.port = static_cast<std::uint16_t>(port);
    }
  }
  in_addr a{};
  if (inet_aton(u.group.c_str(), &a) == 0 || !IN_MULTICAST(ntohl(a.s_addr))) {
    u.error = "'" + u.group + "' is not an IPv4 multicast address";
    return u;
  }
  while (!query.empty()) {
    const auto amp = query.find('&');
    const std::string_view kv = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view{} : query.substr(amp + 1);
    const auto eq = kv.find('=');
    const std::string_view k = kv.substr(0, eq);
    const std::string_view v = eq == std::string_view::npos ? std::string_view{} : kv.substr(eq + 1);
    long n = 0;
    if (k == "ttl") {
      if (!detail::decimal(v, 255, n)) {
        u.error = "ttl: expected 0..255";
        return u;
      }
      u.ttl = static_cast<int>(n);
    } else if (k == "recv_buf_size") {
      if (!detail::decimal(v, 1L << 30, n)) {
        u.error = "recv_buf_size: expected 0..1073741824 bytes";
        return u;
      }
      u.recv_buf_size = static_cast<int>(n);
    }
  }
  return u;
}

}  // namespace pof::bus
