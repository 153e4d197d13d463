// fuzz-link: pof_bus
// The header parser of our udpm:// receive path (pof::bus::parse_udpm_datagram, which
// UdpmReceiver runs on every datagram before it copies anything). Properties: it reads only the
// datagram (ASan), and what it accepts is the datagram exactly: the fields written back in the
// wire format (tests/support/udpm_wire.hpp) give the same bytes, the payload ends where the
// datagram ends, a channel is 1..63 bytes without '\0', and a fragment lies inside a message no
// larger than the limit it was parsed with (which is what makes UdpmReceiver's memcpy safe).
// Seeds: tests/fuzz/corpus/udpm_datagram/ (fuzz_seeds writes them).
#include <cstdint>
#include <cstring>
#include <string_view>
#include <vector>

#include "fuzz_check.hpp"
#include "pof/bus/udpm_receiver.hpp"
#include "udpm_wire.hpp"

namespace {

using pof::bus::UdpmDatagram;

void check(const std::uint8_t* data, std::size_t size, std::uint32_t limit) {
  const UdpmDatagram d = pof::bus::parse_udpm_datagram(data, size, limit);
  if (d.kind == UdpmDatagram::Kind::kMalformed) return;
  FUZZ_CHECK(d.payload >= data && d.payload + d.payload_size == data + size);
  const bool named = d.kind == UdpmDatagram::Kind::kShort || d.fragment == 0;
  FUZZ_CHECK(named != d.channel.empty());
  FUZZ_CHECK(d.channel.size() <= 63 && d.channel.find('\0') == std::string_view::npos);
  std::vector<unsigned char> payload(d.payload, d.payload + d.payload_size);
  std::vector<unsigned char> again;
  if (d.kind == UdpmDatagram::Kind::kShort) {
    again = pof::test::udpm_short(d.seq, d.channel, payload);
  } else {
    FUZZ_CHECK(d.message_size > 0 && d.message_size <= limit);
    FUZZ_CHECK(d.fragment < d.fragments);
    FUZZ_CHECK(std::uint64_t{d.offset} + d.payload_size <= d.message_size);
    again = pof::test::udpm_fragment(d.seq, d.message_size, d.offset, d.fragment, d.fragments, d.channel, payload);
    // The limit is the only bound that depends on the caller: one byte less refuses the message.
    FUZZ_CHECK(pof::bus::parse_udpm_datagram(data, size, d.message_size - 1).kind == UdpmDatagram::Kind::kMalformed);
  }
  FUZZ_CHECK(again.size() == size && std::memcmp(again.data(), data, size) == 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  check(data, size, pof::bus::UdpmLimits{}.max_message_bytes);  // UdpmReceiver's default
  check(data, size, 1000);  // a small limit, so that accepted and refused sizes both come up
  return 0;
}
