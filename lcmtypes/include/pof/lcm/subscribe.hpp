#pragma once
// Typed LCM subscription to a callable, for every pofkit subscriber.
//
// Why not lcm::LCM::subscribe(channel, &Class::method, obj)? With GCC 12, UBSan reports a false
// "member access within null pointer" inside lcm-cpp-impl.hpp's pointer-to-member call
// (LCMMHSubscription::cb_func), which aborts our ASan/UBSan test build. subscribeFunction() takes
// a plain function pointer and a context and has no pointer-to-member call, so we route through it.
//
// Threading: the callable runs on the thread that calls lcm::LCM::handle*(). Exceptions must not
// cross LCM's C callback: catch inside the callable (see ../shared/notes/style.md).
#include <lcm/lcm-cpp.hpp>

#include <memory>
#include <string>
#include <utility>

namespace pof::lcmutil {

/// Keeps the callable alive for as long as the subscription; unsubscribes on destruction.
template <typename Msg, typename Fn>
class TypedSubscription {
 public:
  TypedSubscription(lcm::LCM& lc, const std::string& channel, Fn fn)
      : lc_(&lc), fn_(std::make_unique<Fn>(std::move(fn))) {
    sub_ = lc.subscribeFunction<Msg, Fn*>(channel, &TypedSubscription::dispatch, fn_.get());
  }
  TypedSubscription(const TypedSubscription&) = delete;
  TypedSubscription& operator=(const TypedSubscription&) = delete;
  ~TypedSubscription() {
    if (sub_ != nullptr) lc_->unsubscribe(sub_);
  }

  /// Null when the LCM instance was not good(); check before relying on messages.
  [[nodiscard]] lcm::Subscription* get() const { return sub_; }

 private:
  static void dispatch(const lcm::ReceiveBuffer* rbuf, const std::string& channel, const Msg* msg, Fn* fn) {
    (*fn)(*msg, *rbuf, channel);
  }

  lcm::LCM* lc_;
  std::unique_ptr<Fn> fn_;
  lcm::Subscription* sub_ = nullptr;
};

/// subscribe<Msg>(lc, "POF_RAW", [](const Msg& m, const lcm::ReceiveBuffer& rb, const std::string& ch) {...})
template <typename Msg, typename Fn>
std::unique_ptr<TypedSubscription<Msg, Fn>> subscribe(lcm::LCM& lc, const std::string& channel, Fn fn) {
  return std::make_unique<TypedSubscription<Msg, Fn>>(lc, channel, std::move(fn));
}

}  // namespace pof::lcmutil
