#pragma once
// The one reader of pofkit's TOML files: the calibration and potentiometer files (common/io/), the
// pof-daqd configuration (daq/) and the simulator scenarios (daq/sim/). toml++ parses; TomlSection
// reads one table key by key, typed and checked, and finish() refuses every key the caller did
// not read, suggesting the nearest one it did: a typo such as `tua_s` must not silently fall back
// to a default. Every error is a ConfigError (exit 78) that says where, as
//   "cal.toml:12: key 'model.c9': expected a number > 0, got -3"
//   "cal.toml:14: unknown key 'c9x' in [model] (did you mean 'c9'?)"
// Text quoted from the file goes through excerpt(), so a damaged file cannot flood stderr.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <toml++/toml.h>

#include "pof/base/format.hpp"  // format_number, used with every message here

namespace pof {

/// Parses TOML text. `source` names the document in every message and is stored in each node
/// (toml++'s source().path), so TomlSection errors say "<source>:<line>". A syntax error is a
/// ConfigError "<source>:<line>: TOML syntax error: <toml++'s description>".
toml::table parse_toml(std::string_view text, const std::string& source);

/// read_text_file(path, what) (bounded: kMaxTextFileBytes), then parse_toml(text, path).
toml::table read_toml_file(const std::string& path, const std::string& what);

/// The table that holds `dotted_key` ("acquisition.decimate" -> [acquisition], created when
/// missing) and the key's last part. ConfigError naming `what` when a part is a value, not a table.
std::pair<toml::table*, std::string> toml_parent(toml::table& table, const std::string& dotted_key,
                                                 const std::string& what);

/// Sets `dotted_key` in `table` to `value` (a string, number or bool), creating the tables on the
/// way: a command-line option that overrides a configuration file's key.
template <class V>
void set_toml_path(toml::table& table, const std::string& dotted_key, V&& value) {
  auto [parent, key] = toml_parent(table, dotted_key, "command line: option for '" + dotted_key + "'");
  parent->insert_or_assign(key, std::forward<V>(value));
}

/// Applies a `key.path=value` override (`-s` on a command line) to `table`: the value is read as
/// a TOML value (5, 2.5, true, "text"), and a bare word that is no TOML value is taken as a string.
/// ConfigError on a malformed assignment.
void apply_toml_override(toml::table& table, const std::string& assignment);

/// The type a value is checked as: integers as std::int64_t (before narrowing), floats as double.
template <class T>
struct toml_check_type {
  using type = std::conditional_t<std::is_integral_v<T> && !std::is_same_v<T, bool>, std::int64_t,
                                  std::conditional_t<std::is_floating_point_v<T>, double, T>>;
};
template <class T>
using toml_check_t = typename toml_check_type<T>::type;

/// A rule on a value: want(v) is "" when v is acceptable, else what was expected ("a number > 0"),
/// which the message completes as "expected <want>, got <v>". Built from any callable taking the
/// checked type; not callable itself, so a check on one type does not silently convert to another.
template <class T>
class TomlCheck {
 public:
  TomlCheck() = default;
  template <class F>
    requires(!std::is_same_v<std::remove_cvref_t<F>, TomlCheck> && std::is_invocable_r_v<std::string, const F&, const T&>)
  TomlCheck(F f) : fn_(std::move(f)) {}  // implicit: a lambda is passed where a check is asked

  [[nodiscard]] std::string want(const T& v) const { return fn_ ? fn_(v) : std::string{}; }

 private:
  std::function<std::string(const T&)> fn_;
};

/// The common rules, worded as every reader words them.
namespace toml_check {
TomlCheck<double> positive();                             // "a number > 0"
TomlCheck<double> non_negative();                         // "a number >= 0"
TomlCheck<double> non_zero();                             // "a non-zero number"
TomlCheck<double> number_in(double lo, double hi);        // "a number in [lo, hi]"
TomlCheck<std::int64_t> integer_in(std::int64_t lo, std::int64_t hi);  // "an integer in [lo, hi]"
}  // namespace toml_check


class TomlArray;

/// One TOML table being read. get/find/get_or mark a key as read (also when absent, so finish()
/// can suggest it); finish() then refuses any key of the table that was not read. Sub-tables are
/// TomlSections of their own, each finished by whoever reads it (with_section does).
class TomlSection {
 public:
  /// The root table of a document. `source` names it where a node carries no file of its own
  /// (a value set on the command line), e.g. "daq.toml + command line".
  TomlSection(const toml::table& root, std::string source);

  /// "" at the root, else "model.flexion", "trajectory[0]", ...
  [[nodiscard]] const std::string& path() const { return path_; }
  /// `key` with this section's path in front ("model.c9").
  [[nodiscard]] std::string key_path(std::string_view key) const;
  /// Whether the table has `key`; does not count as reading it.
  [[nodiscard]] bool has(std::string_view key) const;
  /// The table's keys in file order, for a free-form table whose keys are data (each is then read
  /// with get/find like any other key, so finish() still checks them all).
  [[nodiscard]] std::vector<std::string> keys() const;
  /// The line the table starts at in its file; 0 when unknown (the root, a table made in memory).
  [[nodiscard]] int line() const;

  /// Value types T: bool, int, std::int64_t, std::uint32_t, double, std::string. A double takes a
  /// TOML integer or float and must be finite; an integer type takes a TOML integer in its range.
  /// Required: absent is "missing".
  template <class T>
  [[nodiscard]] T get(std::string_view key, const TomlCheck<toml_check_t<T>>& check = {});
  /// Optional: nullopt when absent.
  template <class T>
  [[nodiscard]] std::optional<T> find(std::string_view key, const TomlCheck<toml_check_t<T>>& check = {});
  /// Optional with a default (the check applies to the file's value only).
  template <class T>
  [[nodiscard]] T get_or(std::string_view key, T fallback, const TomlCheck<toml_check_t<T>>& check = {}) {
    std::optional<T> v = find<T>(key, check);
    return v ? std::move(*v) : std::move(fallback);
  }

  /// A string that must be one of `options` (its position in the list), nullopt when absent.
  std::optional<std::size_t> find_choice(std::string_view key, const std::vector<std::string_view>& options);
  /// A string that must name one of `options`: "expected one of 'rse', 'differential', got 'x'".
  template <class E>
  [[nodiscard]] std::optional<E> find_enum(std::string_view key, std::initializer_list<std::pair<std::string_view, E>> options) {
    std::vector<std::string_view> names;
    for (const auto& o : options) names.push_back(o.first);
    const std::optional<std::size_t> i = find_choice(key, names);
    if (!i) return std::nullopt;
    return (options.begin() + *i)->second;
  }
  template <class E>
  [[nodiscard]] E get_enum_or(std::string_view key, E fallback, std::initializer_list<std::pair<std::string_view, E>> options) {
    return find_enum(key, options).value_or(fallback);
  }
  template <class E>
  [[nodiscard]] E get_enum(std::string_view key, std::initializer_list<std::pair<std::string_view, E>> options) {
    if (std::optional<E> v = find_enum(key, options)) return *v;
    fail(key, "missing (one of " + choice_list(options) + ")");
  }

  /// An array (absent: nullopt; not an array: an error). Its elements are read through TomlArray.
  [[nodiscard]] std::optional<TomlArray> find_array(std::string_view key);
  [[nodiscard]] TomlArray array(std::string_view key);

  /// A sub-table (absent: nullopt; not a table: an error). The caller finish()es it.
  [[nodiscard]] std::optional<TomlSection> find_section(std::string_view key);
  [[nodiscard]] TomlSection section(std::string_view key);
  /// Reads the sub-table `key` with `read(TomlSection&)` and finishes it; false when absent.
  template <class F>
  bool with_section(std::string_view key, F&& read) {
    std::optional<TomlSection> s = find_section(key);
    if (!s) return false;
    std::forward<F>(read)(*s);
    s->finish();
    return true;
  }

  /// The document's schema_version, one of `supported` (required).
  int schema_version(std::initializer_list<int> supported);
  /// Reads `key` without using it: a section another program owns (say why where it is called).
  void ignore(std::string_view key);

  /// "<file>:<line>: key '<path.key>': <what>", at the key's line (the section's when absent).
  /// `key` may be dotted ("acquisition.scan_rate_hz"), for a check that spans sections.
  [[noreturn]] void fail(std::string_view key, const std::string& what) const;
  /// The same about the whole section: "key '<path>': <what>".
  [[noreturn]] void fail(const std::string& what) const;

  /// Refuses the first key (in file order) that was not read:
  /// "<file>:<line>: unknown key 'c9x' in [model] (did you mean 'c9'?)".
  void finish() const;

 private:
  friend class TomlArray;
  TomlSection(const toml::table& table, std::string source, std::string path, const toml::node* at);
  const toml::node* take(std::string_view key);
  template <class E>
  static std::string choice_list(std::initializer_list<std::pair<std::string_view, E>> options) {
    std::vector<std::string_view> names;
    for (const auto& o : options) names.push_back(o.first);
    return quoted_list(names);
  }
  static std::string quoted_list(const std::vector<std::string_view>& names);

  const toml::table* table_;
  std::string source_;
  std::string path_;
  const toml::node* at_;  // where "missing" errors point: the table, or nothing for the root
  std::set<std::string, std::less<>> read_;
  std::vector<std::string> read_order_;  // the candidates of a suggestion, in the order asked
};

/// One TOML array; element i is named "<path>[i]" in messages.
class TomlArray {
 public:
  [[nodiscard]] std::size_t size() const { return array_->size(); }
  [[nodiscard]] bool empty() const { return array_->empty(); }
  [[nodiscard]] const std::string& path() const { return path_; }

  /// Element i as T (the types of TomlSection::get).
  template <class T>
  [[nodiscard]] T get(std::size_t i, const TomlCheck<toml_check_t<T>>& check = {}) const;
  /// Every element as T.
  template <class T>
  [[nodiscard]] std::vector<T> values(const TomlCheck<toml_check_t<T>>& check = {}) const {
    std::vector<T> out;
    out.reserve(size());
    for (std::size_t i = 0; i < size(); ++i) out.push_back(get<T>(i, check));
    return out;
  }
  /// Element i, which must be an array / a table (the caller finish()es the table).
  [[nodiscard]] TomlArray array(std::size_t i) const;
  [[nodiscard]] TomlSection section(std::size_t i) const;

  [[noreturn]] void fail(const std::string& what) const;
  [[noreturn]] void fail(std::size_t i, const std::string& what) const;

 private:
  friend class TomlSection;
  TomlArray(const toml::array& array, std::string source, std::string path);
  [[nodiscard]] std::string element_path(std::size_t i) const;

  const toml::array* array_;
  std::string source_;
  std::string path_;
};

}  // namespace pof
