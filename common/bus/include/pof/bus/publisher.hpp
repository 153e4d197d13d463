#pragma once
// pof::bus::Publisher: the one way pofkit's daemons put messages on the LCM bus. Without a bus key
// it is liblcm's publish(), byte for byte as before (stock lcm-spy and lcm-logger decode the
// traffic). With a key (the authenticated mode, pof/bus/auth.hpp) every message gets the trailer of
// pof/bus/auth_trailer.hpp: a MAC over channel and bytes, this process's sender id and a counter.
//
// Threads: one thread publishes (liblcm's rule too: docs/lcm.md). publish() never throws; it
// allocates only when a message is larger than every one before it (the signing buffer grows).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "pof/bus/auth.hpp"

namespace pof::bus {

class Publisher {
 public:
  /// `key` null: unauthenticated. The sender id is drawn here (auth::random_sender_id()).
  Publisher(lcm::LCM& lc, std::shared_ptr<const auth::Key> key);

  /// lcm::LCM::publish()'s result: 0 when published; -1 when liblcm refused it, it could not be
  /// encoded or signed (a saturated counter, no memory for the signing buffer).
  template <class Msg>
  int publish(const std::string& channel, const Msg& msg) noexcept {
    if (!signer_) return lc_.publish(channel, &msg);
    try {
      const int n = msg.getEncodedSize();
      if (n < 0) return -1;
      reserve(static_cast<std::size_t>(n));
      if (msg.encode(buf_.data(), 0, n) != n) return -1;
      return sign_and_publish(channel, static_cast<std::size_t>(n));
    } catch (...) {
      return -1;
    }
  }
  /// An encoded message: published as is, or copied and signed.
  int publish(const std::string& channel, const void* data, std::size_t size) noexcept;

  [[nodiscard]] bool authenticated() const { return signer_.has_value(); }
  /// The signer (authenticated mode only): its sender id, key id and last counter.
  [[nodiscard]] const auth::Signer* signer() const { return signer_ ? &*signer_ : nullptr; }

 private:
  void reserve(std::size_t message_bytes);
  int sign_and_publish(const std::string& channel, std::size_t size) noexcept;

  lcm::LCM& lc_;
  std::optional<auth::Signer> signer_;
  std::vector<unsigned char> buf_;
};

}  // namespace pof::bus
