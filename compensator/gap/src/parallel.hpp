#pragma once
// One way to spread independent pieces of work over threads in pof_gap: the candidates of a step,
// the values of a coordinate search. Internal to pof_gap.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <future>
#include <vector>

namespace pof::gap {

/// Calls fn(i) for i in [0, n) on `threads` workers (this one among them); workers pull the next i
/// off a shared counter, so pieces of unequal cost balance. fn must not touch another i's state.
template <class Fn>
void parallel_for(std::size_t n, int threads, Fn fn) {
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t i = next++; i < n; i = next++) fn(i);
  };
  std::vector<std::future<void>> pool;
  for (int t = 1; t < std::max(1, threads); ++t) pool.push_back(std::async(std::launch::async, worker));
  worker();
  for (auto& f : pool) f.get();
}

}  // namespace pof::gap
