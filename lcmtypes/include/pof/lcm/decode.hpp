#pragma once
// Bounded decoding of pofkit's LCM messages, for bytes nobody vouches for (the network, a file).
//
// Why: the decode() that lcm-gen 1.3.1 generates trusts the lengths on the wire. It resizes arrays
// to the length the message states before reading a single element (n_scans = 2^31-1 asks for
// 2^31 vectors; a negative length becomes a huge size_t), and copies `length - 1` bytes of a string
// whose length may be 0 or negative (std::length_error). Measured before this decoder: one 70-byte
// raw_block_t datagram took pof-compensatord to 1.18 GB and out with std::bad_alloc (exit 74).
//
// decode<T>() first walks the bytes against T's layout (the fields of lcmtypes/<T>.lcm in order,
// encoded as the LCM type specification says: big-endian integers and IEEE floats, a string as an
// int32 length that counts its terminating NUL, then the bytes and the NUL; arrays as their elements
// with no length prefix, the length being an earlier integer field). It checks
//   - the 8-byte fingerprint (T::getHash());
//   - every fixed-size field fits in the bytes left;
//   - every array length is >= 0 and its elements fit in the bytes left (a string element takes
//     at least 5 bytes);
//   - every string length is >= 1, within the bytes left, ends in NUL and has no NUL before that
//     (LCM strings are C strings: lcm-gen's C decoder stops at the first NUL, its C++ decoder keeps
//     what follows, so "LEFT_KNEE\0..." would mean two different things to two receivers);
//   - the message ends exactly where the layout ends (no trailing bytes), so what is accepted is
//     exactly what lcm-gen's encoder writes for the decoded message;
//   - the memory the generated decoder will allocate (vectors and strings) stays within
//     kHeapFloorBytes + kHeapPerByte x the message size, which bounds arrays of empty elements
//     (volts[n_scans][0] costs a vector per scan and no wire bytes);
// and only then runs the generated decoder, catching whatever it throws. So a message costs at most
// a bounded multiple of its own size in memory, and no input makes decode<T>() throw.
//
// The layouts cannot drift from the .lcm files unnoticed: each layout's fingerprint is computed from
// its field names, types and dimensions exactly as lcm-gen does (lcmgen.c, lcm_struct_hash; the
// generated _computeHash() then rotates it left by one bit) and compared with the generated
// T::getHash(). tests/unit/test_lcm_decode.cpp checks every type; decode<T>() refuses with
// kLayoutMismatch if they differ (e.g. a field appended to a .lcm file but not here).
//
// Thread safety: free functions; the layouts are immutable.
#include <algorithm>
#include <array>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include <pof/angle_t.hpp>
#include <pof/compensator_status_t.hpp>
#include <pof/cycle_stats_t.hpp>
#include <pof/daq_status_t.hpp>
#include <pof/raw_block_t.hpp>

namespace pof::lcmutil {

enum class FieldType : std::uint8_t { kInt8, kInt16, kInt32, kInt64, kFloat, kDouble, kString, kBoolean, kByte };

/// One field of an LCM struct: its name, primitive type and up to three array dimensions, each
/// the name of an earlier integer field (variable length) or a decimal constant (fixed length).
struct FieldSpec {
  std::string_view name;
  FieldType type = FieldType::kInt8;
  std::array<std::string_view, 3> dims{};
};

/// Layout<T>: kName and kFields, the fields of lcmtypes/<T>.lcm in declaration order.
template <class T>
struct Layout;

template <>
struct Layout<pof::raw_block_t> {
  static constexpr std::string_view kName = "raw_block_t";
  static constexpr FieldSpec kFields[] = {
      {"utime", FieldType::kInt64, {}},
      {"publish_utime", FieldType::kInt64, {}},
      {"seq", FieldType::kInt64, {}},
      {"first_scan", FieldType::kInt64, {}},
      {"scan_rate_hz", FieldType::kDouble, {}},
      {"sensor_id", FieldType::kString, {}},
      {"n_channels", FieldType::kInt16, {}},
      {"channel_names", FieldType::kString, {"n_channels"}},
      {"channel_units", FieldType::kString, {"n_channels"}},
      {"n_scans", FieldType::kInt32, {}},
      {"volts", FieldType::kFloat, {"n_scans", "n_channels"}},
      {"flags", FieldType::kInt32, {}},
  };
};

template <>
struct Layout<pof::angle_t> {
  static constexpr std::string_view kName = "angle_t";
  static constexpr FieldSpec kFields[] = {
      {"utime", FieldType::kInt64, {}},
      {"publish_utime", FieldType::kInt64, {}},
      {"seq", FieldType::kInt64, {}},
      {"scan_index", FieldType::kInt64, {}},
      {"angle_deg", FieldType::kFloat, {}},
      {"angle_uncomp_deg", FieldType::kFloat, {}},
      {"angle_ref_deg", FieldType::kFloat, {}},
      {"velocity_rad_s", FieldType::kFloat, {}},
      {"phase", FieldType::kInt8, {}},
      {"quality", FieldType::kInt32, {}},
      {"angle_sigma_deg", FieldType::kFloat, {}},
  };
};

template <>
struct Layout<pof::cycle_stats_t> {
  static constexpr std::string_view kName = "cycle_stats_t";
  static constexpr FieldSpec kFields[] = {
      {"utime", FieldType::kInt64, {}},
      {"seq", FieldType::kInt64, {}},
      {"cycle", FieldType::kInt32, {}},
      {"start_utime", FieldType::kInt64, {}},
      {"end_utime", FieldType::kInt64, {}},
      {"velocity_rad_s", FieldType::kFloat, {}},
      {"rmse_comp_deg", FieldType::kFloat, {}},
      {"rmse_uncomp_deg", FieldType::kFloat, {}},
      {"hysteresis_comp_pct", FieldType::kFloat, {}},
      {"hysteresis_uncomp_pct", FieldType::kFloat, {}},
      {"max_error_deg", FieldType::kFloat, {}},
      {"n_samples", FieldType::kInt32, {}},
  };
};

template <>
struct Layout<pof::daq_status_t> {
  static constexpr std::string_view kName = "daq_status_t";
  static constexpr FieldSpec kFields[] = {
      {"utime", FieldType::kInt64, {}},
      {"seq", FieldType::kInt64, {}},
      {"sensor_id", FieldType::kString, {}},
      {"device_kind", FieldType::kString, {}},
      {"vendor_id", FieldType::kInt32, {}},
      {"product_id", FieldType::kInt32, {}},
      {"serial", FieldType::kString, {}},
      {"state", FieldType::kInt8, {}},
      {"state_text", FieldType::kString, {}},
      {"scan_rate_hz", FieldType::kDouble, {}},
      {"n_channels", FieldType::kInt16, {}},
      {"scans", FieldType::kInt64, {}},
      {"blocks", FieldType::kInt64, {}},
      {"dropped_scans", FieldType::kInt64, {}},
      {"usb_errors", FieldType::kInt64, {}},
      {"overruns", FieldType::kInt64, {}},
      {"reconnects", FieldType::kInt64, {}},
      {"protocol_variant", FieldType::kString, {}},
      {"padding_set", FieldType::kInt64, {}},
      {"publish_failures", FieldType::kInt64, {}},
  };
};

template <>
struct Layout<pof::compensator_status_t> {
  static constexpr std::string_view kName = "compensator_status_t";
  static constexpr FieldSpec kFields[] = {
      {"utime", FieldType::kInt64, {}},
      {"seq", FieldType::kInt64, {}},
      {"sensor_id", FieldType::kString, {}},
      {"calibration_path", FieldType::kString, {}},
      {"calibration_sensor_id", FieldType::kString, {}},
      {"calibration_date", FieldType::kString, {}},
      {"blocks", FieldType::kInt64, {}},
      {"scans", FieldType::kInt64, {}},
      {"lost_blocks", FieldType::kInt64, {}},
      {"lost_scans", FieldType::kInt64, {}},
      {"rejected_blocks", FieldType::kInt64, {}},
      {"fault_scans", FieldType::kInt64, {}},
      {"angles", FieldType::kInt64, {}},
      {"cycles", FieldType::kInt64, {}},
      {"reloads", FieldType::kInt32, {}},
      {"reload_failures", FieldType::kInt32, {}},
      {"last_error", FieldType::kString, {}},
      {"decode_errors", FieldType::kInt64, {}},
      {"malformed_datagrams", FieldType::kInt64, {}},
      {"duplicate_blocks", FieldType::kInt64, {}},
      {"publish_failures", FieldType::kInt64, {}},
      {"authenticated", FieldType::kBoolean, {}},
      {"auth_unsigned", FieldType::kInt64, {}},
      {"auth_bad_mac", FieldType::kInt64, {}},
      {"auth_stale", FieldType::kInt64, {}},
      {"auth_replayed", FieldType::kInt64, {}},
      {"estimator_divergences", FieldType::kInt64, {}},
  };
};

enum class DecodeError : std::uint8_t {
  kOk,
  kTooShort,        // a field runs past the end of the message
  kHashMismatch,    // the fingerprint is not T's (another type, or not LCM at all)
  kBadLength,       // an array length is negative or its elements cannot fit in the bytes left
  kBadString,       // a string length is < 1 or past the end, or the string lacks its NUL or has one inside
  kTrailingBytes,   // bytes left after the last field
  kTooLarge,        // the message (> INT_MAX bytes) or what decoding it would allocate is too large
  kLayoutMismatch,  // Layout<T> does not describe the generated T (a build error, not input)
  kDecoderFailed,   // the generated decoder refused or threw although the walk passed
};

/// What decode<T>() found. Converts to true when the message was decoded.
struct DecodeResult {
  DecodeError error = DecodeError::kOk;
  std::string_view type;   // Layout<T>::kName
  std::string_view field;  // the field where decoding stopped ("" for whole-message errors)
  std::size_t offset = 0;  // its byte offset in the message
  std::int64_t value = 0;  // the offending length, or the bytes needed
  std::size_t left = 0;    // bytes left at that offset
  std::size_t size = 0;    // message size [bytes]
  std::int64_t expected = 0;  // kHashMismatch: T's fingerprint
  // A multi-dimensional array has an inner dimension of 0: lcm-gen's decoder then leaves the inner
  // vectors as they were, so decode() starts from a fresh message instead of reusing `out`.
  bool empty_inner = false;
  explicit operator bool() const { return error == DecodeError::kOk; }
  /// One line naming the type, field, offset and what was expected (no payload bytes).
  [[nodiscard]] std::string describe() const;
};

// Heap budget of one decode: the generated decoder may allocate up to this much. A raw_block_t
// with one channel costs 28 heap bytes (a 24-byte vector header + 4 bytes) per 4 wire bytes, the
// largest legitimate ratio among our types, so 16 x leaves room; the floor covers short messages.
inline constexpr std::uint64_t kHeapFloorBytes = 64 * 1024;
inline constexpr std::uint64_t kHeapPerByte = 16;

namespace detail {

constexpr std::string_view lcm_type_name(FieldType t) {
  switch (t) {
    case FieldType::kInt8: return "int8_t";
    case FieldType::kInt16: return "int16_t";
    case FieldType::kInt32: return "int32_t";
    case FieldType::kInt64: return "int64_t";
    case FieldType::kFloat: return "float";
    case FieldType::kDouble: return "double";
    case FieldType::kString: return "string";
    case FieldType::kBoolean: return "boolean";
    case FieldType::kByte: return "byte";
  }
  return "";
}

constexpr std::size_t wire_size(FieldType t) {
  switch (t) {
    case FieldType::kInt8:
    case FieldType::kBoolean:
    case FieldType::kByte: return 1;
    case FieldType::kInt16: return 2;
    case FieldType::kInt32:
    case FieldType::kFloat: return 4;
    case FieldType::kInt64:
    case FieldType::kDouble: return 8;
    case FieldType::kString: return 0;  // variable
  }
  return 0;
}

constexpr bool is_integer(FieldType t) {
  return t == FieldType::kInt8 || t == FieldType::kInt16 || t == FieldType::kInt32 || t == FieldType::kInt64;
}

// lcmgen.c: v = ((v << 8) ^ (v >> 55)) + c on an int64_t (arithmetic right shift, wrapping add).
constexpr std::int64_t hash_update(std::int64_t v, char c) {
  const std::uint64_t u = (static_cast<std::uint64_t>(v) << 8) ^ static_cast<std::uint64_t>(v >> 55);
  return static_cast<std::int64_t>(u + static_cast<std::uint64_t>(static_cast<std::int64_t>(c)));
}
constexpr std::int64_t hash_string_update(std::int64_t v, std::string_view s) {
  v = hash_update(v, static_cast<char>(s.size()));
  for (const char c : s) v = hash_update(v, c);
  return v;
}
constexpr bool is_decimal(std::string_view s) {
  if (s.empty()) return false;
  for (const char c : s)
    if (c < '0' || c > '9') return false;
  return true;
}
constexpr int ndims(const FieldSpec& f) {
  int n = 0;
  while (n < 3 && !f.dims[static_cast<std::size_t>(n)].empty()) ++n;
  return n;
}

/// The fingerprint lcm-gen gives a struct of these fields (what T::getHash() returns).
template <std::size_t N>
constexpr std::int64_t layout_hash(const FieldSpec (&fields)[N]) {
  std::int64_t v = 0x12345678;
  for (const FieldSpec& f : fields) {
    v = hash_string_update(v, f.name);
    v = hash_string_update(v, lcm_type_name(f.type));  // every member of ours is primitive
    const int nd = ndims(f);
    v = hash_update(v, static_cast<char>(nd));
    for (int j = 0; j < nd; ++j) {
      const std::string_view d = f.dims[static_cast<std::size_t>(j)];
      v = hash_update(v, is_decimal(d) ? 0 : 1);  // LCM_CONST = 0, LCM_VAR = 1
      v = hash_string_update(v, d);
    }
  }
  const auto u = static_cast<std::uint64_t>(v);
  return static_cast<std::int64_t>((u << 1) + ((u >> 63) & 1));
}

// A dimension resolved: the index of the integer field holding it, or a constant.
struct Dim {
  int field = -1;
  std::int64_t constant = 0;
};
template <std::size_t N>
struct Compiled {
  std::array<std::array<Dim, 3>, N> dims{};
  bool ok = true;
};
template <std::size_t N>
constexpr Compiled<N> compile(const FieldSpec (&fields)[N]) {
  Compiled<N> c;
  for (std::size_t i = 0; i < N; ++i) {
    for (int j = 0; j < ndims(fields[i]); ++j) {
      const std::string_view d = fields[i].dims[static_cast<std::size_t>(j)];
      Dim& out = c.dims[i][static_cast<std::size_t>(j)];
      if (is_decimal(d)) {
        for (const char ch : d) out.constant = out.constant * 10 + (ch - '0');
        continue;
      }
      for (std::size_t k = 0; k < i; ++k)
        if (fields[k].name == d && ndims(fields[k]) == 0 && is_integer(fields[k].type)) out.field = static_cast<int>(k);
      if (out.field < 0) c.ok = false;  // LCM requires an earlier scalar integer member
    }
  }
  return c;
}

inline std::int64_t read_be(const unsigned char* p, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < n; ++i) v = (v << 8) | p[i];
  const unsigned bits = static_cast<unsigned>(n * 8);
  if (bits < 64 && (v >> (bits - 1)) != 0) v |= ~std::uint64_t{0} << bits;  // sign-extend
  return static_cast<std::int64_t>(v);
}

inline std::uint64_t sat_mul(std::uint64_t a, std::uint64_t b) {
  std::uint64_t r = 0;
  return __builtin_mul_overflow(a, b, &r) ? UINT64_MAX : r;
}
inline std::uint64_t sat_add(std::uint64_t a, std::uint64_t b) {
  std::uint64_t r = 0;
  return __builtin_add_overflow(a, b, &r) ? UINT64_MAX : r;
}

// sizeof of the C++ element the generated code stores (lcm-gen: boolean -> int8_t, byte -> uint8_t).
constexpr std::uint64_t heap_elem_size(FieldType t) {
  return t == FieldType::kString ? sizeof(std::string) : wire_size(t);
}
// Heap a string of wire length len costs beyond its std::string object (SSO holds up to 15 chars).
inline std::uint64_t string_heap(std::int64_t len) { return len - 1 > 15 ? static_cast<std::uint64_t>(len) : 0; }

/// The walk described at the top of the file. Fills r (error kOk when the bytes fit the layout).
template <std::size_t N>
void walk(const FieldSpec (&fields)[N], const Compiled<N>& dims, const unsigned char* p, std::size_t size,
          DecodeResult& r) {
  const std::uint64_t budget = sat_add(kHeapFloorBytes, sat_mul(kHeapPerByte, size));
  std::uint64_t heap = 0;
  std::array<std::int64_t, N> value{};
  std::size_t pos = 8;
  auto fail = [&](DecodeError e, const FieldSpec& f, std::int64_t v) {
    r.error = e;
    r.field = f.name;
    r.offset = pos;
    r.value = v;
    r.left = size - pos;
  };
  // One string at pos; false (with r filled) when it does not fit.
  auto string_at = [&](const FieldSpec& f) {
    if (size - pos < 4) {
      fail(DecodeError::kTooShort, f, 4);
      return false;
    }
    const std::int64_t len = read_be(p + pos, 4);
    if (len < 1 || static_cast<std::uint64_t>(len) > size - pos - 4 || p[pos + 4 + static_cast<std::size_t>(len) - 1] != 0 ||
        std::memchr(p + pos + 4, 0, static_cast<std::size_t>(len) - 1) != nullptr) {
      fail(DecodeError::kBadString, f, len);
      return false;
    }
    heap = sat_add(heap, string_heap(len));
    pos += 4 + static_cast<std::size_t>(len);
    return true;
  };
  for (std::size_t i = 0; i < N; ++i) {
    const FieldSpec& f = fields[i];
    const int nd = ndims(f);
    if (nd == 0) {
      if (f.type == FieldType::kString) {
        if (!string_at(f)) return;
        continue;
      }
      const std::size_t w = wire_size(f.type);
      if (size - pos < w) return fail(DecodeError::kTooShort, f, static_cast<std::int64_t>(w));
      value[i] = read_be(p + pos, w);
      pos += w;
      continue;
    }
    // An array: every dimension >= 0; count the vectors and elements it allocates.
    std::uint64_t count = 1;
    for (int j = 0; j < nd; ++j) {
      const Dim& d = dims.dims[i][static_cast<std::size_t>(j)];
      const std::int64_t n = d.field >= 0 ? value[static_cast<std::size_t>(d.field)] : d.constant;
      if (n < 0) return fail(DecodeError::kBadLength, f, n);
      if (n == 0 && j > 0 && count > 0) r.empty_inner = true;
      count = sat_mul(count, static_cast<std::uint64_t>(n));
      heap = sat_add(heap, sat_mul(count, j + 1 < nd ? sizeof(std::vector<int>) : heap_elem_size(f.type)));
    }
    // Elements beyond the bytes left first (the plainer fault), then the allocation budget.
    const std::uint64_t min_bytes = sat_mul(count, f.type == FieldType::kString ? 5 : wire_size(f.type));
    if (min_bytes > size - pos)
      return fail(DecodeError::kBadLength, f, static_cast<std::int64_t>(std::min<std::uint64_t>(count, INT64_MAX)));
    if (heap > budget) return fail(DecodeError::kTooLarge, f, static_cast<std::int64_t>(std::min<std::uint64_t>(heap, INT64_MAX)));
    if (f.type == FieldType::kString) {
      for (std::uint64_t k = 0; k < count; ++k)
        if (!string_at(f)) return;
      if (heap > budget) return fail(DecodeError::kTooLarge, f, static_cast<std::int64_t>(std::min<std::uint64_t>(heap, INT64_MAX)));
      continue;
    }
    const std::uint64_t bytes = min_bytes;
    pos += static_cast<std::size_t>(bytes);
  }
  if (pos != size) {
    r.error = DecodeError::kTrailingBytes;
    r.offset = pos;
    r.value = static_cast<std::int64_t>(size - pos);
    r.left = size - pos;
  }
}

}  // namespace detail

/// True when Layout<T> describes the generated type T (same fingerprint, dimensions resolvable).
template <class T>
bool layout_matches() {
  static const bool ok = detail::compile(Layout<T>::kFields).ok &&
                         detail::layout_hash(Layout<T>::kFields) == T::getHash();
  return ok;
}

/// Checks `data` against T's layout without decoding it (see the file comment). Never throws.
template <class T>
DecodeResult check(const void* data, std::size_t size) noexcept {
  DecodeResult r;
  r.type = Layout<T>::kName;
  r.size = size;
  if (!layout_matches<T>()) {
    r.error = DecodeError::kLayoutMismatch;
    return r;
  }
  if (size > static_cast<std::size_t>(INT_MAX)) {
    r.error = DecodeError::kTooLarge;
    r.value = static_cast<std::int64_t>(size);
    return r;
  }
  const auto* p = static_cast<const unsigned char*>(data);
  if (size < 8) {
    r.error = DecodeError::kTooShort;
    r.value = 8;
    r.left = size;
    return r;
  }
  if (detail::read_be(p, 8) != T::getHash()) {
    r.error = DecodeError::kHashMismatch;
    r.value = detail::read_be(p, 8);
    r.expected = T::getHash();
    return r;
  }
  static constexpr auto kCompiled = detail::compile(Layout<T>::kFields);
  detail::walk(Layout<T>::kFields, kCompiled, p, size, r);
  return r;
}

/// Decodes `data` into `out` when check<T>() passes; `out` is unspecified after a failure.
/// Reusing one `out` across calls reuses its vectors' storage (and gives the same message as a
/// fresh `out` would). Never throws.
template <class T>
DecodeResult decode(const void* data, std::size_t size, T& out) noexcept {
  DecodeResult r = check<T>(data, size);
  if (!r) return r;
  try {
    if (r.empty_inner) out = T{};
    const int n = out.decode(data, 0, static_cast<int>(size));
    if (n != static_cast<int>(size)) {
      r.error = DecodeError::kDecoderFailed;
      r.value = n;
    }
  } catch (...) {  // cannot happen after the walk but for memory exhaustion; never let it escape
    r.error = DecodeError::kDecoderFailed;
  }
  return r;
}

inline std::string DecodeResult::describe() const {
  char b[320];
  const int nf = static_cast<int>(field.size());
  const int nt = static_cast<int>(type.size());
  const auto ll = [](auto v) { return static_cast<long long>(v); };
  const auto ull = [](auto v) { return static_cast<unsigned long long>(v); };
  switch (error) {
    case DecodeError::kOk: std::snprintf(b, sizeof b, "%.*s: decoded (%zu bytes)", nt, type.data(), size); break;
    case DecodeError::kTooShort:
      std::snprintf(b, sizeof b, "%.*s: truncated: field '%.*s' at byte %zu needs %lld bytes, %zu left (message %zu bytes)",
                    nt, type.data(), nf, field.data(), offset, ll(value), left, size);
      break;
    case DecodeError::kHashMismatch:
      std::snprintf(b, sizeof b, "not a %.*s: fingerprint %016llx, expected %016llx (%zu bytes)", nt, type.data(),
                    ull(value), ull(expected), size);
      break;
    case DecodeError::kBadLength:
      std::snprintf(b, sizeof b,
                    "%.*s: array '%.*s' at byte %zu: %lld elements (expected >= 0, and within the %zu bytes left)",
                    nt, type.data(), nf, field.data(), offset, ll(value), left);
      break;
    case DecodeError::kBadString:
      std::snprintf(b, sizeof b,
                    "%.*s: string '%.*s' at byte %zu: length %lld (expected 1..%zu with one NUL, at the end)", nt,
                    type.data(), nf, field.data(), offset, ll(value), left >= 4 ? left - 4 : 0);
      break;
    case DecodeError::kTrailingBytes:
      std::snprintf(b, sizeof b, "%.*s: %lld bytes after the last field (at byte %zu of %zu)", nt, type.data(), ll(value),
                    offset, size);
      break;
    case DecodeError::kTooLarge:
      if (field.empty())
        std::snprintf(b, sizeof b, "%.*s: message of %zu bytes is too large", nt, type.data(), size);
      else
        std::snprintf(b, sizeof b, "%.*s: array '%.*s' at byte %zu would allocate %lld bytes for a %zu-byte message",
                      nt, type.data(), nf, field.data(), offset, ll(value), size);
      break;
    case DecodeError::kLayoutMismatch:
      std::snprintf(b, sizeof b, "%.*s: pof/lcm/decode.hpp's layout does not match the generated type (a build error)",
                    nt, type.data());
      break;
    case DecodeError::kDecoderFailed:
      std::snprintf(b, sizeof b, "%.*s: the generated decoder failed (returned %lld) on a %zu-byte message", nt,
                    type.data(), ll(value), size);
      break;
  }
  return b;
}

}  // namespace pof::lcmutil
