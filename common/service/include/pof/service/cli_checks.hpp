#pragma once
// Checks of numbers on every pofkit command line (CLI11 validators). CLI11's NonNegativeNumber and
// PositiveNumber let NaN and infinity through (NaN compares false with 0): `--duration nan` never
// ended and `--duration inf` overflowed the deadline. These refuse both, and a value above `most`,
// with exit 2 and the option's name, as any parse error.
#include <cmath>
#include <limits>
#include <string>

#include <CLI/CLI.hpp>

#include "pof/base/format.hpp"
#include "pof/bus/channels.hpp"

namespace pof::service {

/// The longest duration a program may be asked to run or wait [s] (~31 years): beyond ~292 years
/// the steady clock's nanoseconds overflow.
inline constexpr double kMaxSeconds = 1e9;

namespace detail {
inline CLI::Validator finite_number(bool zero_allowed, double most) {
  const std::string desc = zero_allowed ? "NONNEGATIVE" : "POSITIVE";
  return CLI::Validator(
      [zero_allowed, most](std::string& text) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(text, v)) return "Failed parsing number: " + text;
        if (!std::isfinite(v)) return "expected a finite number, got " + text;
        if (zero_allowed ? v < 0 : !(v > 0)) return std::string("expected a number ") + (zero_allowed ? ">= 0" : "> 0") + ", got " + text;
        if (v > most) return "expected at most " + format_number(most) + ", got " + text;
        return {};
      },
      desc, desc);
}
}  // namespace detail

/// A finite number >= 0 and <= most.
inline CLI::Validator non_negative(double most = std::numeric_limits<double>::max()) {
  return detail::finite_number(true, most);
}
/// A finite number > 0 and <= most.
inline CLI::Validator positive(double most = std::numeric_limits<double>::max()) {
  return detail::finite_number(false, most);
}

/// A sensor id that can suffix pofkit's channels (pof::bus::sensor_id_problem): a 60-character id
/// was taken and then every publish refused.
inline CLI::Validator sensor_id() {
  return CLI::Validator(
      [](std::string& id) -> std::string {
        const std::string why = bus::sensor_id_problem(id);
        return why.empty() ? why : why + ", got '" + id + "'";
      },
      "SENSOR_ID", "SENSOR_ID");
}

}  // namespace pof::service
