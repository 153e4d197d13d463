#include "pof/bus/error_log.hpp"

#include <cstdio>
#include <utility>

namespace pof::bus {

ErrorLog::ErrorLog(Emit emit, int64_t period_us, std::size_t max_keys)
    : emit_(std::move(emit)), period_us_(period_us), max_keys_(max_keys == 0 ? 1 : max_keys) {}

void ErrorLog::emit(const std::string& line) noexcept {
  try {
    if (emit_) emit_(line);
  } catch (...) {  // a failing log sink loses the line, never the caller
  }
}

void ErrorLog::note(std::string_view key, std::string_view what, int64_t now_us) noexcept {
  try {
    auto it = keys_.find(key);
    if (it == keys_.end()) {
      if (keys_.size() >= max_keys_) key = "(other)";
      it = keys_.try_emplace(std::string(key)).first;
    }
    Entry& e = it->second;
    ++e.total;
    if (e.total == 1) {
      e.last_emit_us = now_us;
      char tail[96];
      std::snprintf(tail, sizeof tail, " (further errors of '%.*s' are summarised every %.0f s)",
                    static_cast<int>(key.size() > 40 ? 40 : key.size()), key.data(),
                    static_cast<double>(period_us_) / 1e6);
      emit(std::string(what) + tail);
      return;
    }
    ++e.pending;
    e.latest.assign(what);
  } catch (...) {  // out of memory: this error goes uncounted here (the receiver still counts it)
  }
}

void ErrorLog::tick(int64_t now_us) noexcept {
  for (auto& [key, e] : keys_) {
    if (e.pending == 0 || now_us - e.last_emit_us < period_us_) continue;
    char head[160];
    std::snprintf(head, sizeof head, "%s: %llu more in the last %.1f s (%llu in all); latest: ", key.c_str(),
                  static_cast<unsigned long long>(e.pending), static_cast<double>(now_us - e.last_emit_us) / 1e6,
                  static_cast<unsigned long long>(e.total));
    try {
      emit(head + e.latest);
    } catch (...) {
    }
    e.pending = 0;
    e.last_emit_us = now_us;
  }
}

uint64_t ErrorLog::count(std::string_view key) const {
  const auto it = keys_.find(key);
  return it == keys_.end() ? 0 : it->second.total;
}

}  // namespace pof::bus
