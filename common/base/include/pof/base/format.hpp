#pragma once
// Numbers as text, one home for every message, report and file pofkit writes. Header-only, so
// the pure libraries (pof_core) use it without linking anything.
#include <charconv>
#include <cstdio>
#include <ios>
#include <sstream>
#include <string>

namespace pof {

/// The shortest text that reads back to the same double (std::to_chars): values in messages.
inline std::string format_number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

/// v with `digits` significant digits (printf's %.*g): 17 reads back exactly, 9 a float.
inline std::string format_significant(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

/// v with `decimals` digits after the point (fixed notation): progress lines and reasons.
inline std::string format_fixed(double v, int decimals) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(decimals);
  o << v;
  return o.str();
}

}  // namespace pof
