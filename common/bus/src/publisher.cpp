#include "pof/bus/publisher.hpp"

#include <cstring>
#include <limits>

#include "pof/lcm/utime.hpp"

namespace pof::bus {

Publisher::Publisher(lcm::LCM& lc, std::shared_ptr<const auth::Key> key) : lc_(lc) {
  if (key) signer_.emplace(std::move(key), auth::random_sender_id());
}

void Publisher::reserve(std::size_t message_bytes) {
  if (buf_.size() < message_bytes + auth::kTrailerBytes) buf_.resize(message_bytes + auth::kTrailerBytes);
}

int Publisher::publish(const std::string& channel, const void* data, std::size_t size) noexcept {
  if (!signer_) {
    if (size > std::numeric_limits<unsigned>::max()) return -1;
    return lc_.publish(channel, data, static_cast<unsigned>(size));
  }
  try {
    reserve(size);
  } catch (...) {
    return -1;
  }
  if (size > 0) std::memcpy(buf_.data(), data, size);
  return sign_and_publish(channel, size);
}

int Publisher::sign_and_publish(const std::string& channel, std::size_t size) noexcept {
  if (size + auth::kTrailerBytes > std::numeric_limits<unsigned>::max()) return -1;
  if (!signer_->sign(channel, buf_.data(), size, auth::counter_time(lcmutil::now_utime()))) return -1;
  return lc_.publish(channel, buf_.data(), static_cast<unsigned>(size + auth::kTrailerBytes));
}

}  // namespace pof::bus
