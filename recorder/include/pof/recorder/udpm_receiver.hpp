#pragma once
// A receive-only implementation of LCM's udpm:// transport for the recorder.
//
// Why: liblcm 1.3.1 moves every datagram through its own receive thread, a ring buffer and a pipe
// write/read to the thread calling handle(): two context switches and ~6 syscalls per message.
// Measured on the 2-core target with `pof record` on liblcm: lossless to ~50k msg/s alone, but 5 %
// lost at 50k msg/s and 3-8 % at 65-100k msg/s once the host is busy (BENCHMARKS.md). Here one
// thread takes up to 64 datagrams per recvmmsg(2) and timestamps them in the kernel (SO_TIMESTAMP),
// so the cost per message is a memcpy.
//
// Wire format (lcm/lcm_udpm.c, protocol version 2, all integers big-endian):
//   short message:  u32 magic 0x4C433032 ("LC02"), u32 sequence, channel '\0', payload
//   fragment:       u32 magic 0x4C433033 ("LC03"), u32 sequence, u32 message size,
//                   u32 fragment offset, u16 fragment number, u16 fragment count;
//                   fragment 0 then carries channel '\0' before its payload bytes.
// Fragments of one message come from one sender with one sequence number; a sender starting a new
// message abandons its incomplete one (counted in incomplete_messages), as liblcm does.
//
// Socket options follow liblcm (SO_REUSEADDR, bind INADDR_ANY:port, IP_ADD_MEMBERSHIP, SO_RCVBUF
// from recv_buf_size) so it coexists with LCM processes on the same port; in addition
// IP_MULTICAST_ALL=0 keeps out datagrams for other groups that share the port.
//
// Threads: receive() is called from one thread. Setup errors throw pof::io::ConfigError naming the
// URL; receive() never throws.
#include <netinet/in.h>

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace pof::recorder {

struct UdpmUrl {
  std::string group = "239.255.76.67";
  uint16_t port = 7667;
  int ttl = 0;
  int recv_buf_size = 0;  // 0: kernel default
};

/// Parses udpm://GROUP:PORT?ttl=N&recv_buf_size=N (liblcm's syntax). Throws pof::io::ConfigError.
UdpmUrl parse_udpm_url(const std::string& url);

class UdpmReceiver {
 public:
  /// (receive time [us since the epoch, kernel timestamp], channel, payload)
  using Sink = std::function<void(int64_t, std::string_view, const unsigned char*, uint32_t)>;

  explicit UdpmReceiver(const UdpmUrl& url);
  ~UdpmReceiver();
  UdpmReceiver(const UdpmReceiver&) = delete;
  UdpmReceiver& operator=(const UdpmReceiver&) = delete;

  /// Waits up to timeout_ms for datagrams, then delivers every complete message received so far
  /// to `sink`. Returns the number of messages delivered (0 on timeout), -1 on a socket error.
  int receive(int timeout_ms, const Sink& sink);

  [[nodiscard]] int fd() const { return fd_; }
  [[nodiscard]] uint64_t datagrams() const { return datagrams_; }
  [[nodiscard]] uint64_t malformed() const { return malformed_; }
  [[nodiscard]] uint64_t incomplete_messages() const { return incomplete_; }

 private:
  struct Partial {
    uint32_t seq = 0;
    uint32_t size = 0;
    uint32_t received = 0;
    uint16_t fragments = 0;
    uint16_t got = 0;
    std::string channel;
    std::vector<unsigned char> data;
  };
  void handle_datagram(const unsigned char* p, std::size_t n, const sockaddr_in& from, int64_t utime, const Sink& sink,
                       int& delivered);

  int fd_ = -1;
  static constexpr int kBatch = 64;
  static constexpr std::size_t kDatagramBytes = 65536;
  std::vector<unsigned char> buf_;
  std::vector<unsigned char> ctrl_;
  std::map<uint64_t, Partial> partial_;  // by sender address:port
  uint64_t datagrams_ = 0;
  uint64_t malformed_ = 0;
  uint64_t incomplete_ = 0;
};

}  // namespace pof::recorder
