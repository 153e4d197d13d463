// pof::bus::ErrorLog: the first error of a key in full, the rest as a count per period; keys bounded.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "pof/bus/error_log.hpp"

namespace {

struct Lines {
  std::vector<std::string> v;
  pof::bus::ErrorLog::Emit emit() {
    return [this](const std::string& s) { v.push_back(s); };
  }
};

}  // namespace

TEST(ErrorLog, FirstInFullThenACountPerPeriod) {
  Lines out;
  pof::bus::ErrorLog log(out.emit(), 10'000'000);
  log.note("POF_RAW", "POF_RAW: raw_block_t: first", 0);
  ASSERT_EQ(out.v.size(), 1u);
  EXPECT_EQ(out.v[0].rfind("POF_RAW: raw_block_t: first", 0), 0u) << out.v[0];
  for (int i = 0; i < 1000; ++i) log.note("POF_RAW", "POF_RAW: raw_block_t: error " + std::to_string(i), 1000 + i);
  log.tick(5'000'000);  // within the period: nothing
  EXPECT_EQ(out.v.size(), 1u);
  log.tick(10'000'000);
  ASSERT_EQ(out.v.size(), 2u);
  EXPECT_NE(out.v[1].find("1000 more"), std::string::npos) << out.v[1];
  EXPECT_NE(out.v[1].find("1001 in all"), std::string::npos) << out.v[1];
  EXPECT_NE(out.v[1].find("error 999"), std::string::npos) << out.v[1];  // the latest
  log.tick(30'000'000);  // nothing new: nothing said
  EXPECT_EQ(out.v.size(), 2u);
  EXPECT_EQ(log.count("POF_RAW"), 1001u);
}

TEST(ErrorLog, KeysAreIndependentAndBounded) {
  Lines out;
  pof::bus::ErrorLog log(out.emit(), 1'000'000, 2);
  log.note("A", "a", 0);
  log.note("B", "b", 0);
  log.note("C", "c", 0);  // a third key goes under "(other)"
  log.note("D", "d", 0);
  EXPECT_EQ(out.v.size(), 3u);  // A, B and the first of (other)
  EXPECT_EQ(log.count("(other)"), 2u);
  EXPECT_EQ(log.count("C"), 0u);
}

TEST(ErrorLog, AThrowingSinkIsContained) {
  pof::bus::ErrorLog log([](const std::string&) { throw std::runtime_error("journal gone"); });
  EXPECT_NO_THROW(log.note("X", "x", 0));
  EXPECT_NO_THROW(log.note("X", "x", 1));
  EXPECT_NO_THROW(log.tick(100'000'000));
  EXPECT_EQ(log.count("X"), 2u);
}
