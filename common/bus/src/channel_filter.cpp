#include "pof/bus/channel_filter.hpp"

#include <glib.h>

#include "pof/base/errors.hpp"

namespace pof::bus {

ChannelFilter::ChannelFilter(const std::string& regex) {
  const std::string anchored = "^" + regex + "$";
  GError* err = nullptr;
  GRegex* re = g_regex_new(anchored.c_str(), static_cast<GRegexCompileFlags>(0), static_cast<GRegexMatchFlags>(0), &err);
  if (re == nullptr) {
    const std::string why = err != nullptr ? err->message : "unknown error";
    if (err != nullptr) g_error_free(err);
    throw pof::ConfigError("channel regex '" + regex + "': " + why);
  }
  re_ = re;
}

ChannelFilter::~ChannelFilter() {
  if (re_ != nullptr) g_regex_unref(static_cast<GRegex*>(re_));
}

bool ChannelFilter::matches(std::string_view channel) {
  auto it = cache_.find(channel);
  if (it != cache_.end()) return it->second;
  if (cache_.size() > 4096) cache_.clear();  // a storm of distinct names must not grow memory
  const std::string name(channel);
  const bool m = g_regex_match(static_cast<GRegex*>(re_), name.c_str(), static_cast<GRegexMatchFlags>(0), nullptr) != 0;
  cache_.emplace(name, m);
  return m;
}

}  // namespace pof::bus
