#pragma once
// A receive-only implementation of LCM's udpm:// transport, under pof::bus::Receiver (the one
// receive path of pofkit's processes: it decodes for typed subscribers, and hands the raw messages
// to raw ones such as `pof record`).
//
// Why not liblcm's receiver: liblcm 1.3.1 moves every datagram through its own receive thread, a
// ring buffer and a pipe write/read to the thread calling handle(): two context switches and ~6
// syscalls per message. Measured on the 2-core target with `pof record` on liblcm: lossless to ~50k
// msg/s alone, but 5 % lost at 50k msg/s and 3-8 % at 65-100k msg/s once the host is busy
// (BENCHMARKS.md). And it is not total: a fragment with offset 0xFFFFFFFF makes it write outside
// its reassembly buffer (pof-compensatord died with SIGSEGV, exit 139). Here one thread takes up to
// 64 datagrams per recvmmsg(2) and timestamps them in the kernel (SO_TIMESTAMP), so the cost per
// message is a memcpy, and every header field is checked before it is used.
//
// Wire format (lcm/lcm_udpm.c, protocol version 2, all integers big-endian):
//   short message:  u32 magic 0x4C433032 ("LC02"), u32 sequence, channel '\0', payload
//   fragment:       u32 magic 0x4C433033 ("LC03"), u32 sequence, u32 message size,
//                   u32 fragment offset, u16 fragment number, u16 fragment count;
//                   fragment 0 then carries channel '\0' before its payload bytes.
// Fragments of one message come from one sender with one sequence number; a sender starting a new
// message abandons its incomplete one (counted in incomplete_messages), as liblcm does.
//
// Bounds (UdpmLimits), so no datagram can make the receiver's memory grow without limit: a message
// larger than max_message_bytes is not reassembled (malformed); at most max_senders senders may have
// a message in reassembly, and their declared sizes together at most max_partial_bytes: a new one
// beyond either bound evicts the sender heard from least recently (its message is incomplete).
// Reassembly buffers are allocated without being written, so a fragment that declares a large
// message costs resident memory only for the bytes that actually arrive.
//
// Socket: SO_REUSEADDR and IP_ADD_MEMBERSHIP as liblcm does, so it coexists with liblcm processes on
// the same port, and SO_RCVBUF from recv_buf_size. Unlike liblcm it binds to the group address,
// not INADDR_ANY: a unicast datagram sent to one of the host's own addresses on the LCM port is not
// delivered to it (docs/deployment.md, "Threat model"); IP_MULTICAST_ALL=0 keeps out datagrams for
// other groups that share the port.
//
// Threads: receive() is called from one thread. Setup errors throw pof::ConfigError naming the
// URL; receive() never throws (the sink must not throw either).
#include <netinet/in.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "pof/bus/url.hpp"

namespace pof::bus {

/// One datagram of the wire format above, its header checked: what parse_udpm_datagram() found.
/// Pointers and views point into the datagram.
struct UdpmDatagram {
  enum class Kind : uint8_t {
    kMalformed,  // too short, an unknown magic, no channel or one longer than liblcm allows, or a
                 // fragment header that cannot be (size 0 or above the limit, number >= count,
                 // count 0, bytes beyond the declared message size)
    kShort,      // LC02: a whole message
    kFragment,   // LC03: one fragment of a message
  };
  Kind kind = Kind::kMalformed;
  uint32_t seq = 0;
  std::string_view channel;                // kShort, and fragment 0; empty for the other fragments
  const unsigned char* payload = nullptr;  // the message (kShort) or this fragment's bytes of it
  std::size_t payload_size = 0;
  uint32_t message_size = 0;  // kFragment: the whole message's
  uint32_t offset = 0;        // kFragment: where payload goes in the message
  uint16_t fragment = 0;      // kFragment: number, below `fragments`
  uint16_t fragments = 0;
};

/// Parses the `n` bytes of one datagram. Pure and total: it reads only p[0, n), allocates nothing,
/// and a kFragment always fits its message (offset + payload_size <= message_size <=
/// max_message_bytes), so the reassembly may copy it without further checks.
UdpmDatagram parse_udpm_datagram(const unsigned char* p, std::size_t n, uint32_t max_message_bytes);

struct UdpmLimits {
  uint32_t max_message_bytes = 16u << 20;   // largest message reassembled from fragments
  std::size_t max_senders = 64;             // senders with a message in reassembly at once
  uint64_t max_partial_bytes = 64u << 20;   // their declared message sizes together
};

class UdpmReceiver {
 public:
  /// (receive time [us since the epoch, kernel timestamp], channel, payload)
  using Sink = std::function<void(int64_t, std::string_view, const unsigned char*, uint32_t)>;

  /// `url`: udpm://... as pof/bus/url.hpp reads it. Throws pof::ConfigError naming the URL when it
  /// is not a valid udpm:// URL or the socket cannot be set up.
  explicit UdpmReceiver(const std::string& url, UdpmLimits limits = {});
  ~UdpmReceiver();
  UdpmReceiver(const UdpmReceiver&) = delete;
  UdpmReceiver& operator=(const UdpmReceiver&) = delete;

  /// Waits up to timeout_ms for datagrams, then delivers the complete messages among the next
  /// (at most 1024) datagrams to `sink`. Returns the number of messages delivered (0 on timeout), -1 on a socket error.
  int receive(int timeout_ms, const Sink& sink);

  [[nodiscard]] int fd() const { return fd_; }
  [[nodiscard]] uint64_t datagrams() const { return datagrams_; }
  [[nodiscard]] uint64_t malformed() const { return malformed_; }
  [[nodiscard]] uint64_t incomplete_messages() const { return incomplete_; }
  /// Senders with a message in reassembly now (at most UdpmLimits::max_senders).
  [[nodiscard]] std::size_t partial_senders() const { return partial_.size(); }

 private:
  struct Partial {
    uint32_t seq = 0;
    uint32_t size = 0;
    uint32_t received = 0;
    uint16_t fragments = 0;
    uint16_t got = 0;
    uint64_t last_heard = 0;  // datagram count when this sender was last heard
    std::string channel;
    std::unique_ptr<unsigned char[]> data;  // `size` bytes, not value-initialised (see the bounds)
    // (offset, bytes) of every fragment taken: at completion they must tile [0, size) exactly, or
    // bytes no fragment wrote (uninitialised heap) would be delivered as the message.
    std::vector<std::pair<uint32_t, uint32_t>> pieces;
  };
  // Starts reassembly of a `size`-byte message for `key`, evicting as the bounds require.
  Partial& start_partial(uint64_t key, uint32_t seq, uint32_t size, uint16_t frags);
  void drop_partial(std::map<uint64_t, Partial>::iterator it);
  void handle_datagram(const unsigned char* p, std::size_t n, const sockaddr_in& from, int64_t utime, const Sink& sink,
                       int& delivered);

  UdpmLimits limits_;
  int fd_ = -1;
  static constexpr int kBatch = 64;
  static constexpr int kMaxBatches = 16;
  static constexpr std::size_t kDatagramBytes = 65536;
  std::vector<unsigned char> buf_;
  std::vector<unsigned char> ctrl_;
  std::map<uint64_t, Partial> partial_;  // by sender address:port
  uint64_t partial_bytes_ = 0;            // sum of partial_[*].size
  uint64_t datagrams_ = 0;
  uint64_t malformed_ = 0;
  uint64_t incomplete_ = 0;
};

}  // namespace pof::bus
