#pragma once
// LCM helpers of the tests: a udpm:// URL of their own, and a message's encoded bytes.
#include <cstddef>
#include <random>
#include <string>
#include <vector>

namespace pof::test {

/// The loopback multicast group on a random port, so that runs on one host (parallel ctest jobs,
/// other worktrees) do not receive each other's messages. `query`: liblcm URL options.
inline std::string random_udpm_url(const std::string& query = "ttl=0") {
  std::random_device rd;
  const unsigned port = 20000 + rd() % 30000;
  return "udpm://239.255.76.67:" + std::to_string(port) + "?" + query;
}

/// The bytes liblcm would send for `m` (an lcm-gen type).
template <class T>
std::vector<unsigned char> encode(const T& m) {
  std::vector<unsigned char> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

}  // namespace pof::test
