// The LCM log scanner (common/io/include/pof/io/lcmlog_scan.hpp) on logs built in memory: clean logs,
// truncation at every byte, huge lengths, every single-bit flip, lost sync, zero-filled files.
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <pof/raw_block_t.hpp>

#include "pof/base/errors.hpp"
#include "pof/bus/auth_trailer.hpp"
#include "pof/io/lcmlog_scan.hpp"

using pof::io::LcmEventRef;
using pof::io::LcmLogScan;
using pof::io::scan_lcmlog;

namespace {

using Bytes = std::vector<unsigned char>;

void append_event(Bytes& b, std::int64_t number, std::int64_t utime, const std::string& channel, const Bytes& data) {
  unsigned char h[pof::io::kLcmLogHeaderBytes];
  pof::io::put_be32(h, pof::io::kLcmLogSync);
  pof::io::put_be64(h + 4, static_cast<std::uint64_t>(number));
  pof::io::put_be64(h + 12, static_cast<std::uint64_t>(utime));
  pof::io::put_be32(h + 20, static_cast<std::uint32_t>(channel.size()));
  pof::io::put_be32(h + 24, static_cast<std::uint32_t>(data.size()));
  b.insert(b.end(), h, h + sizeof h);
  b.insert(b.end(), channel.begin(), channel.end());
  b.insert(b.end(), data.begin(), data.end());
}

Bytes payload(std::size_t n, unsigned seed) {
  Bytes v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<unsigned char>((i * 31 + seed) & 0xff);
  return v;
}

// `n` events numbered 0.. on two channels; `ends` gets each event's end offset.
Bytes make_log(int n, std::vector<std::uint64_t>* ends = nullptr) {
  Bytes b;
  for (int i = 0; i < n; ++i) {
    append_event(b, i, 1000 + i, i % 2 ? "POF_RAW" : "POF_ANGLE", payload(static_cast<std::size_t>(20 + i * 7), static_cast<unsigned>(i)));
    if (ends != nullptr) ends->push_back(b.size());
  }
  return b;
}

struct Seen {
  std::vector<std::int64_t> numbers;
  std::vector<bool> after_damage;
  std::uint64_t event_bytes = 0;
};

LcmLogScan scan(const Bytes& b, Seen* seen = nullptr) {
  return scan_lcmlog(b, [&](const LcmEventRef& e) {
    // Every event lies inside the buffer (the scanner's promise to its callers).
    EXPECT_LE(e.end(), b.size());
    EXPECT_EQ(e.data, b.data() + e.offset + pof::io::kLcmLogHeaderBytes + e.channel.size());
    if (seen != nullptr) {
      seen->numbers.push_back(e.event_number);
      seen->after_damage.push_back(e.after_damage);
      seen->event_bytes += e.end() - e.offset;
    }
  });
}

}  // namespace

TEST(LcmLogScan, CleanLogYieldsEveryEventInOrder) {
  const Bytes b = make_log(12);
  Seen seen;
  const LcmLogScan s = scan(b, &seen);
  EXPECT_TRUE(s.clean());
  EXPECT_EQ(s.events, 12u);
  EXPECT_EQ(s.events_before_damage, 12u);
  EXPECT_EQ(s.first_damage, b.size());
  EXPECT_EQ(s.lost_events, 0u);
  EXPECT_EQ(seen.event_bytes, b.size());
  for (int i = 0; i < 12; ++i) EXPECT_EQ(seen.numbers[static_cast<std::size_t>(i)], i);
  EXPECT_TRUE(scan_lcmlog({}, {}).clean());  // an empty file is an empty log
}

TEST(LcmLogScan, TruncationAtEveryByteLosesOnlyThePartialEvent) {
  std::vector<std::uint64_t> ends;
  const Bytes full = make_log(6, &ends);
  for (std::size_t cut = 0; cut <= full.size(); ++cut) {
    const Bytes b(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(cut));
    std::uint64_t whole = 0;
    while (whole < ends.size() && ends[whole] <= cut) ++whole;
    const std::uint64_t good = whole > 0 ? ends[whole - 1] : 0;
    const LcmLogScan s = scan(b);
    ASSERT_EQ(s.events, whole) << "cut at " << cut;
    EXPECT_EQ(s.clean(), good == cut) << "cut at " << cut;
    if (good != cut) {
      EXPECT_EQ(s.first_damage, good) << "cut at " << cut;
      EXPECT_EQ(s.damaged_bytes, cut - good) << "cut at " << cut;
      EXPECT_EQ(s.damaged_regions, 1u);
      EXPECT_EQ(s.lost_events, 1u) << "a torn tail is one event";
      EXPECT_FALSE(s.problem.empty());
    }
  }
}

TEST(LcmLogScan, HugeDataLengthIsDamageNotAnAllocation) {
  // 0x7fffffff crashed liblcm's reader (calloc(datalen + 1) overflows, fread into NULL).
  for (const std::uint32_t bad : {0x7fffffffu, 0xffffffffu, 0x80000000u, 0x00100000u}) {
    std::vector<std::uint64_t> ends;
    Bytes b = make_log(8, &ends);
    const std::uint64_t at = ends[2];  // event 3
    pof::io::put_be32(b.data() + at + 24, bad);
    Seen seen;
    const LcmLogScan s = scan(b, &seen);
    EXPECT_EQ(s.events, 7u) << std::hex << bad;
    EXPECT_EQ(s.events_before_damage, 3u);
    EXPECT_EQ(s.first_damage, at);
    EXPECT_EQ(s.damaged_bytes, ends[3] - ends[2]);
    EXPECT_EQ(s.lost_events, 1u);
    EXPECT_EQ(seen.numbers, (std::vector<std::int64_t>{0, 1, 2, 4, 5, 6, 7}));
    EXPECT_EQ(seen.after_damage[3], true);
    EXPECT_NE(s.problem.find(bad > pof::io::kLcmLogMaxDataBytes ? "implausible data length" : "event truncated"), std::string::npos)
        << s.problem;
  }
}

TEST(LcmLogScan, ALengthTooLargeDoesNotSwallowTheEventsAfterIt) {
  // A flipped bit can make a data length larger and still inside the file: the events it would
  // swallow are found inside it, and the event with the wrong length is the damage.
  std::vector<std::uint64_t> ends;
  Bytes b = make_log(8, &ends);
  const std::uint64_t at = ends[1];  // event 2
  pof::io::put_be32(b.data() + at + 24, pof::io::get_be32(b.data() + at + 24) + 200);
  Seen seen;
  const LcmLogScan s = scan(b, &seen);
  EXPECT_EQ(seen.numbers, (std::vector<std::int64_t>{0, 1, 3, 4, 5, 6, 7}));
  EXPECT_EQ(s.first_damage, at);
  EXPECT_EQ(s.damaged_bytes, ends[2] - ends[1]);
  EXPECT_EQ(s.lost_events, 1u);
  EXPECT_NE(s.problem.find("event 2 claims"), std::string::npos) << s.problem;
}

// Property: whatever single bit is flipped, the scan ends, every event it returns lies inside the
// file, the events and damaged bytes never overlap, and events read + events counted lost account
// for every event of the original (a damaged event is never silently dropped).
TEST(LcmLogScan, EverySingleBitFlipIsAccountedFor) {
  std::vector<std::uint64_t> ends;
  const Bytes good = make_log(5, &ends);
  int damaged = 0;
  for (std::size_t byte = 0; byte < good.size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      Bytes b = good;
      b[byte] = static_cast<unsigned char>(b[byte] ^ (1u << bit));
      Seen seen;
      const LcmLogScan s = scan(b, &seen);
      ASSERT_EQ(seen.event_bytes + s.damaged_bytes, b.size()) << "byte " << byte << " bit " << bit;
      EXPECT_GE(s.events + s.lost_events, 5u) << "byte " << byte << " bit " << bit;
      EXPECT_EQ(s.clean(), s.lost_events == 0 && s.damaged_regions == 0);
      damaged += s.clean() ? 0 : 1;
    }
  }
  EXPECT_GT(damaged, 5 * 8 * 8) << "flips in sync words and lengths are found";
}

TEST(LcmLogScan, ResynchronisesAfterGarbageAndCountsLostEventsFromTheirNumbers) {
  std::vector<std::uint64_t> ends;
  const Bytes good = make_log(10, &ends);
  // Garbage inserted between events 4 and 5: no event lost.
  Bytes ins(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(ends[4]));
  const Bytes junk = {'g', 'a', 'r', 'b', 'a', 'g', 'e', 0xED, 0xA1};
  ins.insert(ins.end(), junk.begin(), junk.end());
  ins.insert(ins.end(), good.begin() + static_cast<std::ptrdiff_t>(ends[4]), good.end());
  LcmLogScan s = scan(ins);
  EXPECT_EQ(s.events, 10u);
  EXPECT_EQ(s.damaged_bytes, junk.size());
  EXPECT_EQ(s.lost_events, 0u);
  EXPECT_EQ(s.first_damage, ends[4]);
  // Events 3..6 overwritten with zeros (a lost block on disk): 4 events lost, found by number.
  Bytes zeroed = good;
  std::fill(zeroed.begin() + static_cast<std::ptrdiff_t>(ends[2]), zeroed.begin() + static_cast<std::ptrdiff_t>(ends[6]), 0);
  Seen seen;
  s = scan(zeroed, &seen);
  EXPECT_EQ(s.events, 6u);
  EXPECT_EQ(s.lost_events, 4u);
  EXPECT_EQ(s.damaged_regions, 1u);
  EXPECT_EQ(seen.numbers, (std::vector<std::int64_t>{0, 1, 2, 7, 8, 9}));
  // Two separate regions.
  Bytes two = good;
  two[ends[1]] = 'X';
  two[ends[7]] = 'Y';
  s = scan(two);
  EXPECT_EQ(s.damaged_regions, 2u);
  EXPECT_EQ(s.lost_events, 2u);
  EXPECT_EQ(s.events, 8u);
}

TEST(LcmLogScan, ZeroFileIsOneDamagedRegion) {
  const Bytes zeros(1 << 16, 0);
  const LcmLogScan s = scan(zeros);
  EXPECT_EQ(s.events, 0u);
  EXPECT_EQ(s.first_damage, 0u);
  EXPECT_EQ(s.damaged_bytes, zeros.size());
  EXPECT_EQ(s.damaged_regions, 1u);
  EXPECT_NE(s.problem.find("bad sync word 0x00000000"), std::string::npos);
}

TEST(LcmLogScan, ImplausibleEventNumbersCountOneLostEvent) {
  std::vector<std::uint64_t> ends;
  Bytes b = make_log(5, &ends);
  pof::io::put_be64(b.data() + ends[1] + 4, 0x7fffffffffffffffULL);  // event 2's number: +1 overflows
  b[ends[2]] = 0;                                                     // event 3's sync word
  LcmLogScan s = scan(b);
  EXPECT_EQ(s.events, 4u);
  EXPECT_EQ(s.lost_events, 1u);
  b = make_log(5, &ends);
  pof::io::put_be64(b.data() + ends[3] + 4, 1'000'000'000'000ULL);  // event 4: a gap no region holds
  b[ends[2]] = 0;
  s = scan(b);
  EXPECT_EQ(s.lost_events, 1u);
}

TEST(LcmLogReader, DamageReportNamesFileOffsetAndCounts) {
  std::vector<std::uint64_t> ends;
  Bytes b = make_log(10, &ends);
  pof::io::put_be32(b.data() + ends[3] + 24, 0x7fffffffu);
  pof::io::LcmLogReader log("run.lcmlog", b);
  int n = 0;
  log.scan([&](const LcmEventRef& e) {
    if (++n == 2) log.undecodable(e, "not a pof.raw_block_t");
  });
  ASSERT_TRUE(log.damaged());
  const std::string r = log.damage_report();
  EXPECT_EQ(r.rfind("run.lcmlog: damaged LCM log: first damage at byte " + std::to_string(ends[0]) + ": event 1 on channel POF_RAW", 0), 0u) << r;
  EXPECT_NE(r.find("1 damaged region (" + std::to_string(ends[4] - ends[3]) + " bytes) skipped, at least 1 event lost"), std::string::npos) << r;
  EXPECT_NE(r.find("; 1 event not decodable; 9 complete events read"), std::string::npos) << r;
}

TEST(LcmLogReader, ASignedMessageIsNamedAsSuch) {
  // An event whose data ends in an authenticated-mode trailer (pof/bus/auth_trailer.hpp): a log of
  // signed messages as they were on the bus, which pofkit's readers refuse (trailing bytes).
  Bytes data = payload(40, 3);
  data.resize(40 + pof::bus::auth::kTrailerBytes);
  pof::bus::auth::put_trailer_header(data.data() + 40, 1, 2, 3);
  Bytes b;
  append_event(b, 0, 1000, "POF_ANGLE", data);
  append_event(b, 1, 1001, "POF_ANGLE", payload(40, 4));
  for (const bool signed_first : {true, false}) {
    pof::io::LcmLogReader log("signed.lcmlog", b);
    int n = 0;
    log.scan([&](const LcmEventRef& e) {
      if (++n == (signed_first ? 1 : 2)) log.undecodable(e, "angle_t: 60 bytes after the last field");
    });
    const std::string r = log.damage_report();
    EXPECT_EQ(r.find("ends in an authenticated-mode trailer") != std::string::npos, signed_first) << r;
  }
}

TEST(DecodeLcmEvent, RawBlockCountsAreCheckedBeforeTheDecoderAllocates) {
  pof::raw_block_t b{};
  b.sensor_id = "LEFT_KNEE";
  b.n_channels = 2;
  b.channel_names = {"sensor", "reference"};
  b.channel_units = {"V", "V"};
  b.n_scans = 3;
  b.volts.assign(3, std::vector<float>(2, 1.5f));
  Bytes buf(static_cast<std::size_t>(b.getEncodedSize()));
  ASSERT_EQ(b.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  LcmEventRef ev;
  ev.data = buf.data();
  ev.data_size = static_cast<std::uint32_t>(buf.size());
  pof::raw_block_t out;
  EXPECT_FALSE(pof::io::decode_lcm_event(ev, out).has_value());
  EXPECT_EQ(out.volts, b.volts);
  // n_scans sits before the 3 x 2 floats and the flags.
  const std::size_t at = buf.size() - 4 - 3 * 2 * 4 - 4;
  ASSERT_EQ(pof::io::get_be32(buf.data() + at), 3u);
  for (const std::uint32_t bad : {0x7fffffffu, 0xffffffffu, 4u, 0x10000000u}) {
    pof::io::put_be32(buf.data() + at, bad);
    const auto why = pof::io::decode_lcm_event(ev, out);
    ASSERT_TRUE(why.has_value()) << bad;
    EXPECT_NE(why->find("array 'volts'"), std::string::npos) << *why;
  }
  // String lengths below 1 (the decoder computes length - 1: INT32_MIN overflows).
  pof::io::put_be32(buf.data() + at, 3);
  const std::size_t sensor_id_len = 8 + 4 * 8 + 8;
  for (const std::uint32_t bad : {0x80000000u, 0u, 0xfffffffbu}) {
    pof::io::put_be32(buf.data() + sensor_id_len, bad);
    const auto why = pof::io::decode_lcm_event(ev, out);
    ASSERT_TRUE(why.has_value()) << bad;
    EXPECT_NE(why->find("string 'sensor_id' at byte 48: length " + std::to_string(static_cast<std::int32_t>(bad))),
              std::string::npos) << *why;
  }
  pof::io::put_be32(buf.data() + sensor_id_len, 10);  // "LEFT_KNEE" and its NUL
  EXPECT_FALSE(pof::io::decode_lcm_event(ev, out).has_value());
  // Another fingerprint is not a raw_block_t.
  buf[0] ^= 1;
  EXPECT_TRUE(pof::io::decode_lcm_event(ev, out).has_value());
}

TEST(Excerpt, IsBoundedAndPrintable) {
  EXPECT_EQ(pof::excerpt("t_s,sensor_v"), "t_s,sensor_v");
  const std::string big(8'000'000, 'x');
  const std::string e = pof::excerpt(big);
  EXPECT_EQ(e, std::string(pof::kExcerptBytes, 'x') + "\u2026");
  EXPECT_EQ(pof::excerpt(std::string("a\0b\x1b[2J", 7)), "a\\x00b\\x1b[2J");
  EXPECT_LE(pof::excerpt(std::string(100, '\0')).size(), pof::kExcerptBytes + 3);
  // Quotations inside a parser's message.
  const std::string k(100, 'k');
  EXPECT_EQ(pof::bound_quotes("cannot redefine existing integer '" + k + "' here, saw 'x'"),
            "cannot redefine existing integer '" + std::string(40, 'k') + "\u2026' here, saw 'x'");
  EXPECT_EQ(pof::bound_quotes("unterminated '" + k), "unterminated '" + std::string(40, 'k') + "\u2026");
  EXPECT_EQ(pof::bound_quotes("no quotes"), "no quotes");
}
