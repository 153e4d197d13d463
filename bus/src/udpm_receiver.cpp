#include "pof/bus/udpm_receiver.hpp"

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

void UdpmReceiver::drop_partial(std::map<uint64_t, Partial>::iterator it) {
  partial_bytes_ -= it->second.size;
  partial_.erase(it);
}

void UdpmReceiver::handle_datagram(const unsigned char* p, std::size_t n, const sockaddr_in& from, int64_t utime,
                                   const Sink& sink, int& delivered) {
  if (n < 8) {
    ++malformed_;
    return;
  }
  const uint32_t magic = get_be32(p);
  if (magic == kMagicShort) {
    const auto* ch = reinterpret_cast<const char*>(p + 8);
    const std::size_t max = n - 8;
    const std::size_t len = strnlen(ch, max);
    if (len == max || len == 0 || len > kMaxChannelBytes) {
      ++malformed_;
      return;
    }
    const std::string_view channel(ch, len);
    // liblcm 1.3.1 publishes LCM_SELF_TEST when a process first subscribes, to check its own
    // multicast loopback: an internal probe, not application traffic.
    if (channel == "LCM_SELF_TEST") return;
    sink(utime, channel, p + 8 + len + 1, static_cast<uint32_t>(n - 8 - len - 1));
    ++delivered;
    return;
  }
  if (magic != kMagicFrag || n < 20) {
    ++malformed_;
    return;
  }
  const uint32_t seq = get_be32(p + 4);
  const uint32_t size = get_be32(p + 8);
  const uint32_t offset = get_be32(p + 12);
  const uint16_t frag_no = get_be16(p + 16);
  const uint16_t frags = get_be16(p + 18);
  const unsigned char* body = p + 20;
  std::size_t body_len = n - 20;
  const uint64_t key = (uint64_t{from.sin_addr.s_addr} << 16) | from.sin_port;
  // The header alone must be possible: a message within the limit, a fragment inside it, a number
  // below the count. Nothing is allocated for a datagram that fails these.
  if (size == 0 || size > limits_.max_message_bytes || frags == 0 || frag_no >= frags) {
    ++malformed_;
    return;
  }
  std::string_view channel;
  if (frag_no == 0) {
    const auto* ch = reinterpret_cast<const char*>(body);
    const std::size_t len = strnlen(ch, body_len);
    if (len == body_len || len == 0 || len > kMaxChannelBytes) {
      ++malformed_;
      return;
    }
    channel = std::string_view(ch, len);
    body += len + 1;
    body_len -= len + 1;
  }
  if (uint64_t{offset} + body_len > size) {  // e.g. offset 0xFFFFFFFF
    ++malformed_;
    return;
  }
  auto it = partial_.find(key);
  if (it != partial_.end() && it->second.seq != seq) {
    ++incomplete_;  // the sender moved on: liblcm drops the incomplete message too
    drop_partial(it);
    it = partial_.end();
  }
  if (it != partial_.end() && (size != it->second.size || frags != it->second.fragments)) {
    ++malformed_;  // one message, two shapes: neither can be trusted
    drop_partial(it);
    return;
  }
  Partial& m = it != partial_.end() ? it->second : start_partial(key, seq, size, frags);
  m.last_heard = datagrams_;
  if (!channel.empty()) m.channel.assign(channel);
  std::memcpy(m.data.get() + offset, body, body_len);
  m.received += static_cast<uint32_t>(body_len);
  ++m.got;
  if (m.got == m.fragments) {
    const auto done = partial_.find(key);
    if (m.received == m.size && !m.channel.empty()) {
      sink(utime, m.channel, m.data.get(), m.size);
      ++delivered;
    } else {
      ++malformed_;  // duplicated fragments, or fragment 0 never came
    }
    drop_partial(done);
  }
}

}  // namespace pof::bus
