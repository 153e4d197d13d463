#pragma once
// What the kernel knows about this process's UDP sockets: the receive buffer it really granted and
// the datagrams it dropped because that buffer was full. LCM 1.3.1 hides its udpm socket and counts
// nothing, so the only honest "LCM drops" figure on the receive side comes from the kernel:
// /proc/self/fd -> socket inode -> the `drops` column of /proc/net/udp (docs/deployment.md, "The
// UDP receive buffer": the default buffer loses messages from ~50k msg/s). The port of a URL:
// parse_udpm_url() (pof/bus/url.hpp).
#include <cstdint>
#include <vector>

namespace pof::bus {

struct UdpSocketInfo {
  int fd = -1;
  uint64_t inode = 0;
  uint16_t local_port = 0;
  int rcvbuf_bytes = 0;   // getsockopt(SO_RCVBUF): what the kernel granted (2x the request, capped by rmem_max)
  uint64_t drops = 0;     // datagrams dropped on this socket since it was opened
};

/// Every UDP (IPv4) socket of this process bound to `port` (0: any port). Never throws; an empty
/// result means none was found or /proc is unreadable.
std::vector<UdpSocketInfo> udp_sockets(uint16_t port = 0);

/// Sum of the drops of udp_sockets(port).
uint64_t udp_drops(uint16_t port = 0);

/// net.core.rmem_max [bytes], or -1 when unreadable.
long rmem_max();

}  // namespace pof::bus
