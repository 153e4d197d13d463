#include "pof/bus/udp_socket.hpp"

#include <dirent.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace pof::bus {

std::vector<UdpSocketInfo> udp_sockets(uint16_t port) {
  std::vector<UdpSocketInfo> socks;
  // 1. Our socket fds and their inodes.
  DIR* d = ::opendir("/proc/self/fd");
  if (d == nullptr) return socks;
  while (const dirent* e = ::readdir(d)) {
    char* end = nullptr;
    const long fd = std::strtol(e->d_name, &end, 10);
    if (end == e->d_name || *end != '\0') continue;
    struct stat st {};
    if (::fstat(static_cast<int>(fd), &st) != 0 || !S_ISSOCK(st.st_mode)) continue;
    int type = 0;
    socklen_t len = sizeof type;
    if (::getsockopt(static_cast<int>(fd), SOL_SOCKET, SO_TYPE, &type, &len) != 0 || type != SOCK_DGRAM) continue;
    UdpSocketInfo s;
    s.fd = static_cast<int>(fd);
    s.inode = st.st_ino;
    len = sizeof s.rcvbuf_bytes;
    ::getsockopt(s.fd, SOL_SOCKET, SO_RCVBUF, &s.rcvbuf_bytes, &len);
    socks.push_back(s);
  }
  ::closedir(d);
  // 2. /proc/net/udp: "sl local_address rem_address st tx_queue:rx_queue tr:tm->when retrnsmt uid
  //    timeout inode ref pointer drops", addresses as HEX_IP:HEX_PORT.
  std::ifstream in("/proc/net/udp");
  std::string line;
  std::getline(in, line);
  std::vector<UdpSocketInfo> out;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string sl, local, remote, st, queues, timer, retr, uid, timeout, inode, ref, ptr, drops;
    if (!(ls >> sl >> local >> remote >> st >> queues >> timer >> retr >> uid >> timeout >> inode >> ref >> ptr >> drops))
      continue;
    const uint64_t ino = std::strtoull(inode.c_str(), nullptr, 10);
    for (UdpSocketInfo s : socks) {
      if (s.inode != ino) continue;
      const auto colon = local.find(':');
      s.local_port = colon == std::string::npos
                         ? 0
                         : static_cast<uint16_t>(std::strtoul(local.c_str() + colon + 1, nullptr, 16));
      s.drops = std::strtoull(drops.c_str(), nullptr, 10);
      if (port == 0 || s.local_port == port) out.push_back(s);
    }
  }
  return out;
}

uint64_t udp_drops(uint16_t port) {
  uint64_t n = 0;
  for (const auto& s : udp_sockets(port)) n += s.drops;
  return n;
}

long rmem_max() {
  std::ifstream in("/proc/sys/net/core/rmem_max");
  long v = -1;
  if (!(in >> v)) return -1;
  return v;
}

}  // namespace pof::bus
