#include "pof/bus/udpm_receiver.hpp"

#include <algorithm>

#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include <lcm/lcm.h>

#include "pof/base/errors.hpp"

namespace pof::bus {
namespace {

constexpr uint32_t kMagicShort = 0x4C433032;  // "LC02"
constexpr uint32_t kMagicFrag = 0x4C433033;   // "LC03"

uint16_t get_be16(const unsigned char* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }
uint32_t get_be32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}
// lcm.h: liblcm refuses longer channel names.
constexpr std::size_t kMaxChannelBytes = LCM_MAX_CHANNEL_NAME_LENGTH;

}  // namespace

UdpmDatagram parse_udpm_datagram(const unsigned char* p, std::size_t n, uint32_t max_message_bytes) {
  UdpmDatagram d;
  if (n < 8) return d;
  // A channel name: up to the first '\0' of `len` bytes, which must come, and not first.
  const auto channel_at = [](const unsigned char* at, std::size_t len) -> std::string_view {
    const auto* ch = reinterpret_cast<const char*>(at);
    const std::size_t l = strnlen(ch, len);
    if (l == len || l == 0 || l > kMaxChannelBytes) return {};
    return {ch, l};
  };
  const uint32_t magic = get_be32(p);
  d.seq = get_be32(p + 4);
  if (magic == kMagicShort) {
    d.channel = channel_at(p + 8, n - 8);
    if (d.channel.empty()) return d;
    d.payload = p + 8 + d.channel.size() + 1;
    d.payload_size = n - 8 - d.channel.size() - 1;
    d.kind = UdpmDatagram::Kind::kShort;
    return d;
  }
  if (magic != kMagicFrag || n < 20) return d;
  d.message_size = get_be32(p + 8);
  d.offset = get_be32(p + 12);
  d.fragment = get_be16(p + 16);
  d.fragments = get_be16(p + 18);
  // The header alone must be possible: a message within the limit, a fragment inside it, a number
  // below the count. Nothing is allocated for a datagram that fails these.
  if (d.message_size == 0 || d.message_size > max_message_bytes || d.fragments == 0 || d.fragment >= d.fragments)
    return d;
  d.payload = p + 20;
  d.payload_size = n - 20;
  if (d.fragment == 0) {
    d.channel = channel_at(d.payload, d.payload_size);
    if (d.channel.empty()) return d;
    d.payload += d.channel.size() + 1;
    d.payload_size -= d.channel.size() + 1;
  }
  if (uint64_t{d.offset} + d.payload_size > d.message_size) return d;  // e.g. offset 0xFFFFFFFF
  d.kind = UdpmDatagram::Kind::kFragment;
  return d;
}

UdpmReceiver::UdpmReceiver(const std::string& lcm_url, UdpmLimits limits) : limits_(limits) {
  const UdpmUrl url = parse_udpm_url(lcm_url);
  if (!url.ok()) throw pof::ConfigError("LCM URL '" + lcm_url + "': " + url.error);
  if (limits_.max_senders == 0) limits_.max_senders = 1;
  const std::string where = "udpm://" + url.group + ":" + std::to_string(url.port);
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw pof::ConfigError(where + ": socket: " + std::strerror(errno));
  auto fail = [&](const char* what) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    throw pof::ConfigError(where + ": " + what + ": " + std::strerror(err) +
                          (err == ENODEV || err == ENETUNREACH ? " (no multicast route? see docs/deployment.md)" : ""));
  };
  const int one = 1;
  const int zero = 0;
  if (::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0) fail("SO_REUSEADDR");
  // SO_RCVBUFFORCE passes net.core.rmem_max when we hold CAP_NET_ADMIN (root, or a unit granting
  // it); otherwise SO_RCVBUF, capped at rmem_max (deploy/sysctl.d/60-pof-lcm.conf raises that).
  if (url.recv_buf_size > 0 &&
      ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &url.recv_buf_size, sizeof url.recv_buf_size) != 0)
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &url.recv_buf_size, sizeof url.recv_buf_size);
  if (::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &one, sizeof one) != 0) fail("SO_TIMESTAMP");
  ::setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_ALL, &zero, sizeof zero);
  // Bound to the group, not INADDR_ANY (liblcm's choice): Linux hands a UDP datagram only to
  // sockets bound to its destination address or to INADDR_ANY, so unicast sent to one of the
  // host's addresses on this port stays out (tests/functional/test_bus_receiver_udpm.cpp checks it).
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  inet_aton(url.group.c_str(), &addr.sin_addr);
  addr.sin_port = htons(url.port);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) fail("bind");
  ip_mreq mreq{};
  mreq.imr_multiaddr = addr.sin_addr;
  mreq.imr_interface.s_addr = htonl(INADDR_ANY);
  if (::setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) != 0) fail("IP_ADD_MEMBERSHIP");
  buf_.resize(kBatch * kDatagramBytes);
  ctrl_.resize(kBatch * CMSG_SPACE(sizeof(timeval)));
}

UdpmReceiver::~UdpmReceiver() {
  if (fd_ >= 0) ::close(fd_);
}

int UdpmReceiver::receive(int timeout_ms, const Sink& sink) {
  pollfd p{fd_, POLLIN, 0};
  const int r = ::poll(&p, 1, timeout_ms);
  if (r <= 0) return r < 0 && errno != EINTR ? -1 : 0;
  mmsghdr msgs[kBatch];
  iovec iov[kBatch];
  sockaddr_in from[kBatch];
  int delivered = 0;
  // At most kMaxBatches batches per call: a flood must not keep the caller from its other duties
  // (status, watchdog, signals); what is left stays in the kernel buffer for the next call.
  for (int batch = 0; batch < kMaxBatches; ++batch) {
    for (int i = 0; i < kBatch; ++i) {
      iov[i] = {buf_.data() + static_cast<std::size_t>(i) * kDatagramBytes, kDatagramBytes};
      msgs[i] = {};
      msgs[i].msg_hdr.msg_iov = &iov[i];
      msgs[i].msg_hdr.msg_iovlen = 1;
      msgs[i].msg_hdr.msg_name = &from[i];
      msgs[i].msg_hdr.msg_namelen = sizeof from[i];
      msgs[i].msg_hdr.msg_control = ctrl_.data() + static_cast<std::size_t>(i) * CMSG_SPACE(sizeof(timeval));
      msgs[i].msg_hdr.msg_controllen = CMSG_SPACE(sizeof(timeval));
    }
    const int n = ::recvmmsg(fd_, msgs, kBatch, MSG_DONTWAIT, nullptr);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) break;
      return -1;
    }
    for (int i = 0; i < n; ++i) {
      int64_t utime = 0;
      for (cmsghdr* c = CMSG_FIRSTHDR(&msgs[i].msg_hdr); c != nullptr; c = CMSG_NXTHDR(&msgs[i].msg_hdr, c)) {
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMP) {
          timeval tv{};
          std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
          utime = static_cast<int64_t>(tv.tv_sec) * 1000000 + tv.tv_usec;
        }
      }
      if (utime == 0) {
        timeval tv{};
        ::gettimeofday(&tv, nullptr);
        utime = static_cast<int64_t>(tv.tv_sec) * 1000000 + tv.tv_usec;
      }
      ++datagrams_;
      handle_datagram(static_cast<const unsigned char*>(iov[i].iov_base), msgs[i].msg_len, from[i], utime, sink, delivered);
    }
    if (n < kBatch) break;
  }
  return delivered;
}

UdpmReceiver::Partial& UdpmReceiver::start_partial(uint64_t key, uint32_t seq, uint32_t size, uint16_t frags) {
  // Make room: a sender beyond the count, or bytes beyond the budget, evict the sender heard from
  // least recently (a forger cycling source ports cannot grow the table or starve it forever:
  // a live sender is heard again and again).
  auto oldest = [this] {
    auto o = partial_.begin();
    for (auto it = partial_.begin(); it != partial_.end(); ++it)
      if (it->second.last_heard < o->second.last_heard) o = it;
    return o;
  };
  while (!partial_.empty() &&
         (partial_.size() >= limits_.max_senders || partial_bytes_ + size > limits_.max_partial_bytes)) {
    ++incomplete_;
    drop_partial(oldest());
  }
  Partial& m = partial_[key];
  m.seq = seq;
  m.size = size;
  m.fragments = frags;
  m.last_heard = datagrams_;
  m.data.reset(new unsigned char[size == 0 ? 1 : size]);  // default-initialised: untouched pages
  partial_bytes_ += size;
  return m;
}

namespace {
// Whether the fragments cover [0, size) once each: counts and byte totals can agree while two
// fragments overlap and leave a hole (two halves both at offset 0).
bool tiles(std::vector<std::pair<uint32_t, uint32_t>>& pieces, uint32_t size) {
  std::sort(pieces.begin(), pieces.end());
  uint64_t at = 0;
  for (const auto& [offset, bytes] : pieces) {
    if (offset != at) return false;
    at += bytes;
  }
  return at == size;
}
}  // namespace

void UdpmReceiver::drop_partial(std::map<uint64_t, Partial>::iterator it) {
  partial_bytes_ -= it->second.size;
  partial_.erase(it);
}

void UdpmReceiver::handle_datagram(const unsigned char* p, std::size_t n, const sockaddr_in& from, int64_t utime,
                                   const Sink& sink, int& delivered) {
  const UdpmDatagram d = parse_udpm_datagram(p, n, limits_.max_message_bytes);
  if (d.kind == UdpmDatagram::Kind::kMalformed) {
    ++malformed_;
    return;
  }
  if (d.kind == UdpmDatagram::Kind::kShort) {
    // liblcm 1.3.1 publishes LCM_SELF_TEST when a process first subscribes, to check its own
    // multicast loopback: an internal probe, not application traffic.
    if (d.channel == "LCM_SELF_TEST") return;
    sink(utime, d.channel, d.payload, static_cast<uint32_t>(d.payload_size));
    ++delivered;
    return;
  }
  const uint64_t key = (uint64_t{from.sin_addr.s_addr} << 16) | from.sin_port;
  auto it = partial_.find(key);
  if (it != partial_.end() && it->second.seq != d.seq) {
    ++incomplete_;  // the sender moved on: liblcm drops the incomplete message too
    drop_partial(it);
    it = partial_.end();
  }
  if (it != partial_.end() && (d.message_size != it->second.size || d.fragments != it->second.fragments)) {
    ++malformed_;  // one message, two shapes: neither can be trusted
    drop_partial(it);
    return;
  }
  Partial& m = it != partial_.end() ? it->second : start_partial(key, d.seq, d.message_size, d.fragments);
  m.last_heard = datagrams_;
  if (!d.channel.empty()) m.channel.assign(d.channel);
  std::memcpy(m.data.get() + d.offset, d.payload, d.payload_size);  // inside: parse_udpm_datagram
  m.received += static_cast<uint32_t>(d.payload_size);
  m.pieces.emplace_back(d.offset, static_cast<uint32_t>(d.payload_size));
  ++m.got;
  if (m.got == m.fragments) {
    const auto done = partial_.find(key);
    if (m.received == m.size && !m.channel.empty() && tiles(m.pieces, m.size)) {
      sink(utime, m.channel, m.data.get(), m.size);
      ++delivered;
    } else {
      ++malformed_;  // duplicated or overlapping fragments, or fragment 0 never came
    }
    drop_partial(done);
  }
}

}  // namespace pof::bus
