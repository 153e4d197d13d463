#pragma once
// Bounded wait-free single-producer/single-consumer ring (the habit of ros2_control's realtime_tools): the
// acquisition thread pushes, the publisher thread pops; when full, push() fails and the producer
// counts an overrun instead of blocking or allocating. Slots are preallocated at construction.
#include <atomic>
#include <cstddef>
#include <memory>
#include <new>

namespace pof::daq {

template <typename T>
class SpscQueue {
 public:
  /// Allocates `capacity` slots (setup time). Throws std::bad_alloc.
  explicit SpscQueue(std::size_t capacity) : cap_(capacity + 1), slots_(new T[capacity + 1]) {}

  /// Producer thread only. Returns the slot to fill, or nullptr when full. Call commit() after.
  T* producer_slot() noexcept {
    const std::size_t h = head_.load(std::memory_order_relaxed);
    const std::size_t next = h + 1 == cap_ ? 0 : h + 1;
    if (next == tail_.load(std::memory_order_acquire)) return nullptr;
    return &slots_[h];
  }
  /// Producer thread only: publishes the slot returned by producer_slot().
  void commit() noexcept {
    const std::size_t h = head_.load(std::memory_order_relaxed);
    head_.store(h + 1 == cap_ ? 0 : h + 1, std::memory_order_release);
  }

  /// Consumer thread only. The oldest element, or nullptr when empty. Call pop() when done with it.
  T* front() noexcept {
    const std::size_t t = tail_.load(std::memory_order_relaxed);
    if (t == head_.load(std::memory_order_acquire)) return nullptr;
    return &slots_[t];
  }
  /// Consumer thread only.
  void pop() noexcept {
    const std::size_t t = tail_.load(std::memory_order_relaxed);
    tail_.store(t + 1 == cap_ ? 0 : t + 1, std::memory_order_release);
  }

  [[nodiscard]] std::size_t capacity() const noexcept { return cap_ - 1; }

 private:
  const std::size_t cap_;
  std::unique_ptr<T[]> slots_;
  alignas(64) std::atomic<std::size_t> head_{0};
  alignas(64) std::atomic<std::size_t> tail_{0};
};

}  // namespace pof::daq
