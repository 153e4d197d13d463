#include "pof/base/toml_reader.hpp"

#include <cstdio>

#include <algorithm>
#include <charconv>
#include <climits>
#include <cmath>
#include <limits>

#include "pof/base/errors.hpp"
#include "pof/base/text_file.hpp"

namespace pof {

namespace {

// "<file>:<line>" of a node or key: the file toml++ recorded for it (parse_toml stores the
// document's name), else `source` (a value set on the command line has neither file nor line).
std::string location(const std::string& source, const toml::source_region& r) {
  std::string out = r.path ? *r.path : source;
  if (r.begin.line > 0) out += ":" + std::to_string(r.begin.line);
  return out;
}
std::string location(const std::string& source, const toml::node* n) {
  return n != nullptr ? location(source, n->source()) : source;
}

[[noreturn]] void fail_key(const std::string& where, const std::string& key_path, const std::string& what) {
  if (key_path.empty()) throw ConfigError(where + ": " + what);
  throw ConfigError(where + ": key '" + key_path + "': " + what);
}

std::string float_text(double v) {
  std::string s = format_number(v);
  // 2.0 must not read as the integer 2 in "expected an integer, got 2.0".
  if (s.find_first_not_of("-0123456789") == std::string::npos) s += ".0";
  return s;
}

// The value a node holds, as "got <this>" in a type error.
std::string describe(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string '" + excerpt(n.as_string()->get()) + "'";
    case toml::node_type::integer: return std::to_string(n.as_integer()->get());
    case toml::node_type::floating_point: return float_text(n.as_floating_point()->get());
    case toml::node_type::boolean: return n.as_boolean()->get() ? "true" : "false";
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    default: return "a date/time";
  }
}

// Where a value is read from, for its messages.
struct Spot {
  const std::string& source;
  std::string key_path;
  const toml::node* node;
  [[noreturn]] void fail(const std::string& what) const { fail_key(location(source, node), key_path, what); }
  void check(const std::string& want, const std::string& got) const {
    if (!want.empty()) fail("expected " + want + ", got " + got);
  }
};

template <class T>
T read_value(const toml::node& n, const TomlCheck<toml_check_t<T>>& check, const Spot& at) {
  if constexpr (std::is_same_v<T, bool>) {
    if (!n.is_boolean()) at.fail("expected true or false, got " + describe(n));
    const bool v = n.as_boolean()->get();
    at.check(check.want(v), v ? "true" : "false");
    return v;
  } else if constexpr (std::is_integral_v<T>) {
    if (!n.is_integer()) at.fail("expected an integer, got " + describe(n));
    const std::int64_t v = n.as_integer()->get();
    if (!std::in_range<T>(v)) {
      at.fail("expected an integer in [" + std::to_string(std::numeric_limits<T>::min()) + ", " +
              std::to_string(std::numeric_limits<T>::max()) + "], got " + std::to_string(v));
    }
    at.check(check.want(v), std::to_string(v));
    return static_cast<T>(v);
  } else if constexpr (std::is_same_v<T, double>) {
    if (!n.is_number()) at.fail("expected a number, got " + describe(n));
    const double v = n.is_integer() ? static_cast<double>(n.as_integer()->get()) : n.as_floating_point()->get();
    if (!std::isfinite(v)) at.fail("expected a finite number, got " + format_number(v));
    at.check(check.want(v), format_number(v));
    return v;
  } else {
    static_assert(std::is_same_v<T, std::string>, "TOML values are read as bool, integers, double or std::string");
    if (!n.is_string()) at.fail("expected a string, got " + describe(n));
    std::string v = n.as_string()->get();
    // No value of ours (a URL, an id, a path, an effect name) holds a control character, and one
    // that starts with a newline does not survive our own writer: toml++ writes it as a
    // multi-line literal string, whose first newline TOML trims on reading (found by fuzz_daq_config).
    for (std::size_t i = 0; i < v.size(); ++i) {
      const auto c = static_cast<unsigned char>(v[i]);
      if (c < 0x20 || c == 0x7f) {
        char code[8];
        std::snprintf(code, sizeof code, "U+%04X", c);
        at.fail(std::string("expected a string without control characters, got ") + code + " at character " +
                std::to_string(i + 1));
      }
    }
    at.check(check.want(v), "'" + excerpt(v) + "'");
    return v;
  }
}

// Optimal string alignment distance (Levenshtein plus adjacent transpositions: "widht" is one
// edit from "width").
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

// The known key nearest to `unknown`, if it is near enough to be a typo of it: at most one edit
// in three characters, or one is the other with something added ("scan_rate" for "scan_rate_hz").
std::optional<std::string> nearest(std::string_view unknown, const std::vector<std::string>& known) {
  constexpr std::size_t kLongestCompared = 64;  // a damaged file's "key" can be megabytes long
  if (unknown.size() > kLongestCompared) return std::nullopt;
  std::optional<std::string> best;
  std::size_t best_distance = SIZE_MAX;
  for (const std::string& k : known) {
    const std::size_t d = edit_distance(unknown, k);
    const std::size_t shorter = std::min(unknown.size(), k.size());
    const bool extended = shorter >= 3 && (k.starts_with(unknown) || unknown.starts_with(k));
    if ((d <= std::max<std::size_t>(1, std::max(unknown.size(), k.size()) / 3) || extended) && d < best_distance) {
      best = k;
      best_distance = d;
    }
  }
  return best;
}

}  // namespace

toml::table parse_toml(std::string_view text, const std::string& source) {
  try {
    return toml::parse(text, std::string_view{source});
  } catch (const toml::parse_error& e) {
    throw ConfigError(source + ":" + std::to_string(e.source().begin.line) + ": TOML syntax error: " +
                      bound_quotes(e.description()));
  }
}

toml::table read_toml_file(const std::string& path, const std::string& what) {
  return parse_toml(read_text_file(path, what), path);
}

std::pair<toml::table*, std::string> toml_parent(toml::table& table, const std::string& dotted_key,
                                                 const std::string& what) {
  toml::table* t = &table;
  std::string rest = dotted_key;
  for (auto dot = rest.find('.'); dot != std::string::npos; dot = rest.find('.')) {
    const std::string part = rest.substr(0, dot);
    rest = rest.substr(dot + 1);
    if (!t->contains(part)) t->insert(part, toml::table{});
    toml::node* n = t->get(part);
    if (!n->is_table()) throw ConfigError(what + ": '" + excerpt(part) + "' is not a table");
    t = n->as_table();
  }
  return {t, rest};
}

void apply_toml_override(toml::table& table, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw ConfigError("command line: override '" + excerpt(assignment) + "': expected key.path=value");
  }
  const std::string value = assignment.substr(eq + 1);
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + value);
  } catch (const toml::parse_error&) {
    parsed.insert_or_assign("v", value);  // a bare word: a string
  }
  auto [parent, key] = toml_parent(table, assignment.substr(0, eq), "command line: override '" + excerpt(assignment) + "'");
  parent->insert_or_assign(key, *parsed.get("v"));
}

namespace toml_check {
TomlCheck<double> positive() {
  return [](double v) { return v > 0 ? std::string{} : std::string("a number > 0"); };
}
TomlCheck<double> non_negative() {
  return [](double v) { return v >= 0 ? std::string{} : std::string("a number >= 0"); };
}
TomlCheck<double> non_zero() {
  return [](double v) { return v != 0 ? std::string{} : std::string("a non-zero number"); };
}
TomlCheck<double> number_in(double lo, double hi) {
  return [lo, hi](double v) {
    return v >= lo && v <= hi ? std::string{} : "a number in [" + format_number(lo) + ", " + format_number(hi) + "]";
  };
}
TomlCheck<std::int64_t> integer_in(std::int64_t lo, std::int64_t hi) {
  return [lo, hi](std::int64_t v) {
    return v >= lo && v <= hi ? std::string{} : "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  };
}
}  // namespace toml_check

// --- TomlSection ---------------------------------------------------------------------------------

TomlSection::TomlSection(const toml::table& root, std::string source)
    : TomlSection(root, std::move(source), {}, nullptr) {}

TomlSection::TomlSection(const toml::table& table, std::string source, std::string path, const toml::node* at)
    : table_(&table), source_(std::move(source)), path_(std::move(path)), at_(at) {}

std::string TomlSection::key_path(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

bool TomlSection::has(std::string_view key) const { return table_->contains(key); }

std::vector<std::string> TomlSection::keys() const {
  std::vector<const toml::key*> in_order;
  for (const auto& [k, v] : *table_) in_order.push_back(&k);
  // toml++ keeps a table's keys sorted by name; the file's order is the order of their lines (and
  // columns, for an inline table).
  std::stable_sort(in_order.begin(), in_order.end(), [](const toml::key* a, const toml::key* b) {
    const auto& x = a->source().begin;
    const auto& y = b->source().begin;
    return x.line != y.line ? x.line < y.line : x.column < y.column;
  });
  std::vector<std::string> out;
  out.reserve(in_order.size());
  for (const toml::key* k : in_order) out.emplace_back(k->str());
  return out;
}

int TomlSection::line() const { return at_ != nullptr ? static_cast<int>(at_->source().begin.line) : 0; }

const toml::node* TomlSection::take(std::string_view key) {
  if (read_.insert(std::string(key)).second) read_order_.emplace_back(key);
  return table_->get(key);
}

template <class T>
std::optional<T> TomlSection::find(std::string_view key, const TomlCheck<toml_check_t<T>>& check) {
  const toml::node* n = take(key);
  if (n == nullptr) return std::nullopt;
  return read_value<T>(*n, check, Spot{source_, key_path(key), n});
}

template <class T>
T TomlSection::get(std::string_view key, const TomlCheck<toml_check_t<T>>& check) {
  std::optional<T> v = find<T>(key, check);
  if (!v) fail(key, "missing");
  return std::move(*v);
}

std::string TomlSection::quoted_list(const std::vector<std::string_view>& names) {
  std::string list;
  for (const std::string_view n : names) list += (list.empty() ? "'" : ", '") + std::string(n) + "'";
  return list;
}

std::optional<std::size_t> TomlSection::find_choice(std::string_view key, const std::vector<std::string_view>& options) {
  const toml::node* n = take(key);
  if (n == nullptr) return std::nullopt;
  const Spot at{source_, key_path(key), n};
  if (!n->is_string()) at.fail("expected one of " + quoted_list(options) + ", got " + describe(*n));
  const std::string& v = n->as_string()->get();
  for (std::size_t i = 0; i < options.size(); ++i)
    if (v == options[i]) return i;
  at.fail("expected one of " + quoted_list(options) + ", got '" + excerpt(v) + "'");
}

std::optional<TomlArray> TomlSection::find_array(std::string_view key) {
  const toml::node* n = take(key);
  if (n == nullptr) return std::nullopt;
  if (!n->is_array()) Spot{source_, key_path(key), n}.fail("expected an array, got " + describe(*n));
  return TomlArray(*n->as_array(), source_, key_path(key));
}

TomlArray TomlSection::array(std::string_view key) {
  std::optional<TomlArray> a = find_array(key);
  if (!a) fail(key, "missing");
  return std::move(*a);
}

std::optional<TomlSection> TomlSection::find_section(std::string_view key) {
  const toml::node* n = take(key);
  if (n == nullptr) return std::nullopt;
  if (!n->is_table()) Spot{source_, key_path(key), n}.fail("expected a table, got " + describe(*n));
  return TomlSection(*n->as_table(), source_, key_path(key), n);
}

TomlSection TomlSection::section(std::string_view key) {
  std::optional<TomlSection> s = find_section(key);
  if (!s) fail(key, "missing (expected a table [" + key_path(key) + "])");
  return std::move(*s);
}

int TomlSection::schema_version(std::initializer_list<int> supported) {
  std::string list;
  std::size_t i = 0;
  for (const int v : supported) {
    list += (i == 0 ? "" : i + 1 == supported.size() ? " or " : ", ") + std::to_string(v);
    ++i;
  }
  const std::optional<std::int64_t> v = find<std::int64_t>("schema_version");
  if (!v) fail("schema_version", "missing (this program reads schema_version " + list + ")");
  for (const int s : supported)
    if (*v == s) return s;
  fail("schema_version", "expected " + list + ", got " + std::to_string(*v));
}

void TomlSection::ignore(std::string_view key) { (void)take(key); }

void TomlSection::fail(std::string_view key, const std::string& what) const {
  // at_path: a check across sections names a dotted key ("acquisition.scan_rate_hz") from the root.
  const toml::node* n = table_->at_path(key).node();
  fail_key(location(source_, n != nullptr ? n : at_), key_path(key), what);
}

void TomlSection::fail(const std::string& what) const { fail_key(location(source_, at_), path_, what); }

void TomlSection::finish() const {
  const toml::key* first = nullptr;
  auto line_of = [](const toml::key& k) { return k.source().begin.line > 0 ? k.source().begin.line : UINT_MAX; };
  for (const auto& [k, v] : *table_) {
    if (read_.contains(k.str())) continue;
    if (first == nullptr || line_of(k) < line_of(*first)) first = &k;
  }
  if (first == nullptr) return;
  // "[daq]" as the file writes the table; an element of an array of tables by its index.
  const std::string in = path_.empty()          ? std::string(" at the top level")
                         : path_.ends_with(']') ? " in " + path_
                                                : " in [" + path_ + "]";
  std::string msg = location(source_, first->source()) + ": unknown key '" + excerpt(first->str()) + "'" + in;
  if (const std::optional<std::string> s = nearest(first->str(), read_order_)) msg += " (did you mean '" + *s + "'?)";
  throw ConfigError(msg);
}

// --- TomlArray -----------------------------------------------------------------------------------

TomlArray::TomlArray(const toml::array& array, std::string source, std::string path)
    : array_(&array), source_(std::move(source)), path_(std::move(path)) {}

std::string TomlArray::element_path(std::size_t i) const { return path_ + "[" + std::to_string(i) + "]"; }

template <class T>
T TomlArray::get(std::size_t i, const TomlCheck<toml_check_t<T>>& check) const {
  const toml::node& e = *array_->get(i);
  return read_value<T>(e, check, Spot{source_, element_path(i), &e});
}

TomlArray TomlArray::array(std::size_t i) const {
  const toml::node& e = *array_->get(i);
  if (!e.is_array()) Spot{source_, element_path(i), &e}.fail("expected an array, got " + describe(e));
  return TomlArray(*e.as_array(), source_, element_path(i));
}

TomlSection TomlArray::section(std::size_t i) const {
  const toml::node& e = *array_->get(i);
  if (!e.is_table()) Spot{source_, element_path(i), &e}.fail("expected a table, got " + describe(e));
  return TomlSection(*e.as_table(), source_, element_path(i), &e);
}

void TomlArray::fail(const std::string& what) const { fail_key(location(source_, array_), path_, what); }

void TomlArray::fail(std::size_t i, const std::string& what) const {
  fail_key(location(source_, array_->get(i)), element_path(i), what);
}

// The value types of the readers (toml_reader.hpp).
#define POF_TOML_VALUE_TYPE(T)                                                                           \
  template std::optional<T> TomlSection::find<T>(std::string_view, const TomlCheck<toml_check_t<T>>&); \
  template T TomlSection::get<T>(std::string_view, const TomlCheck<toml_check_t<T>>&);                \
  template T TomlArray::get<T>(std::size_t, const TomlCheck<toml_check_t<T>>&) const;
POF_TOML_VALUE_TYPE(bool)
POF_TOML_VALUE_TYPE(int)
POF_TOML_VALUE_TYPE(std::int64_t)
POF_TOML_VALUE_TYPE(std::uint32_t)
POF_TOML_VALUE_TYPE(double)
POF_TOML_VALUE_TYPE(std::string)
#undef POF_TOML_VALUE_TYPE

}  // namespace pof
