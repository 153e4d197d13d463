// The authenticated mode's pure code (common/bus/include/pof/bus/auth.hpp, auth_trailer.hpp): the trailer
// a Signer writes, what a Verifier accepts and why it refuses the rest (unsigned, bad MAC, stale,
// replayed), the counter that never goes back nor wraps, and the bounded replay state; the key
// file (pof/bus/auth_key.hpp): its formats, and who may own and read it.
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "pof/base/errors.hpp"
#include "pof/bus/auth.hpp"
#include "pof/bus/auth_key.hpp"
#include "pof/bus/auth_trailer.hpp"
#include "temp_dir.hpp"

namespace {

using pof::bus::auth::Key;
using pof::bus::auth::kTrailerBytes;
using pof::bus::auth::Signer;
using pof::bus::auth::Verdict;
using pof::bus::auth::Verifier;
using pof::bus::auth::VerifierSettings;

constexpr std::uint64_t kNow = 1'800'000'000'000'000;  // 2027, in us since the epoch
constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();

std::shared_ptr<const Key> key(unsigned char fill) {
  std::vector<unsigned char> k(Key::kBytes);
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<unsigned char>(fill + i);
  return std::make_shared<const Key>(k.data(), k.size());
}

// A message of `n` bytes, signed on `channel` at `now` by `s`.
std::vector<unsigned char> signed_message(Signer& s, const std::string& channel, std::uint64_t now, std::size_t n = 100,
                                          unsigned char fill = 7) {
  std::vector<unsigned char> b(n + kTrailerBytes);
  for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<unsigned char>(fill + i);
  EXPECT_TRUE(s.sign(channel, b.data(), n, now));
  return b;
}

Verdict verdict(Verifier& v, const std::string& channel, const std::vector<unsigned char>& m, std::uint64_t now) {
  return v.verify(channel, m.data(), m.size(), now).verdict;
}

}  // namespace

TEST(BusAuth, SignedMessageVerifiesAndTheTrailerSaysWhoAndWhen) {
  const auto k = key(1);
  Signer s(k, 0x0123456789abcdefULL);
  const auto m = signed_message(s, "POF_RAW", kNow, 100);
  ASSERT_EQ(m.size(), 100 + kTrailerBytes);
  const auto t = pof::bus::auth::parse_trailer(m.data(), m.size());
  ASSERT_TRUE(t);
  EXPECT_EQ(t->message_size, 100u);
  EXPECT_EQ(t->sender, 0x0123456789abcdefULL);
  EXPECT_EQ(t->counter, kNow);
  EXPECT_EQ(t->key_id, k->id());
  EXPECT_EQ(m[100], 'P');  // magic "POFA", big-endian
  EXPECT_EQ(m[103], 'A');
  Verifier v(k);
  const auto r = v.verify("POF_RAW", m.data(), m.size(), kNow + 500);
  EXPECT_EQ(r.verdict, Verdict::kOk) << r.describe();
  EXPECT_EQ(r.message_size, 100u);
  EXPECT_EQ(v.count(Verdict::kOk), 1u);
  // The message in front of the trailer is untouched.
  for (std::size_t i = 0; i < 100; ++i) ASSERT_EQ(m[i], static_cast<unsigned char>(7 + i));
}

TEST(BusAuth, AnyChangedByteOrAnotherChannelIsRefused) {
  const auto k = key(1);
  Signer s(k, 42);
  const auto good = signed_message(s, "POF_RAW", kNow, 40);
  for (std::size_t i = 0; i < good.size(); ++i) {
    auto m = good;
    m[i] ^= 0x01;
    Verifier v(k);  // fresh: a refusal must come from the byte, not from the replay state
    const Verdict got = verdict(v, "POF_RAW", m, kNow);
    // Bytes 0..7 of the trailer are its magic and version: changed, it is no trailer of ours.
    const bool magic_or_version = i >= 40 && i < 48;
    EXPECT_EQ(got, magic_or_version ? Verdict::kUnsigned : Verdict::kBadMac) << "byte " << i;
  }
  Verifier v(k);
  EXPECT_EQ(verdict(v, "POF_RAW_LEFT_KNEE", good, kNow), Verdict::kBadMac);  // moved to another channel
  auto cut = good;
  cut.erase(cut.begin() + 3);  // a byte removed from the message
  EXPECT_EQ(verdict(v, "POF_RAW", cut, kNow), Verdict::kBadMac);
  EXPECT_EQ(verdict(v, "POF_RAW", good, kNow), Verdict::kOk);
  EXPECT_EQ(v.count(Verdict::kBadMac), 2u);
}

TEST(BusAuth, AnotherKeyIsABadMacNamedAsSuch) {
  Signer s(key(2), 42);
  const auto m = signed_message(s, "POF_RAW", kNow);
  Verifier v(key(1));
  const auto r = v.verify("POF_RAW", m.data(), m.size(), kNow);
  EXPECT_EQ(r.verdict, Verdict::kBadMac);
  EXPECT_NE(r.describe().find("signed with another key"), std::string::npos) << r.describe();
  EXPECT_NE(key(1)->id(), key(2)->id());
  // The same key id with other key bytes (a forger copying the id) fails on the MAC itself.
  auto forged = m;
  const std::uint32_t ours = key(1)->id();
  for (unsigned i = 0; i < 4; ++i) forged[100 + 8 + i] = static_cast<unsigned char>(ours >> (24 - 8 * i));
  const auto r2 = v.verify("POF_RAW", forged.data(), forged.size(), kNow);
  EXPECT_EQ(r2.verdict, Verdict::kBadMac);
  EXPECT_NE(r2.describe().find("forged or altered"), std::string::npos) << r2.describe();
}

TEST(BusAuth, UnsignedAndShortMessagesAreUnsigned) {
  Verifier v(key(1));
  const std::vector<unsigned char> plain(200, 0x55);
  EXPECT_EQ(verdict(v, "POF_RAW", plain, kNow), Verdict::kUnsigned);
  EXPECT_EQ(verdict(v, "POF_RAW", std::vector<unsigned char>(kTrailerBytes - 1, 0), kNow), Verdict::kUnsigned);
  EXPECT_EQ(v.verify("POF_RAW", nullptr, 0, kNow).verdict, Verdict::kUnsigned);
  EXPECT_EQ(v.count(Verdict::kUnsigned), 3u);
  // An empty message can be signed: the trailer alone.
  Signer s(key(1), 1);
  std::vector<unsigned char> empty(kTrailerBytes);
  ASSERT_TRUE(s.sign("X", empty.data(), 0, kNow));
  EXPECT_EQ(verdict(v, "X", empty, kNow), Verdict::kOk);
}

TEST(BusAuth, ReplaysAreRefusedPerSenderAndChannel) {
  const auto k = key(1);
  Signer a(k, 1), b(k, 2);
  Verifier v(k);
  const auto a1 = signed_message(a, "POF_RAW", kNow);
  const auto a2 = signed_message(a, "POF_RAW", kNow + 10);
  EXPECT_EQ(verdict(v, "POF_RAW", a1, kNow), Verdict::kOk);
  EXPECT_EQ(verdict(v, "POF_RAW", a1, kNow), Verdict::kReplayed);  // the same message again
  EXPECT_EQ(verdict(v, "POF_RAW", a2, kNow), Verdict::kOk);
  EXPECT_EQ(verdict(v, "POF_RAW", a1, kNow), Verdict::kReplayed);  // an older one, within the window
  const auto r = v.verify("POF_RAW", a2.data(), a2.size(), kNow);
  EXPECT_EQ(r.verdict, Verdict::kReplayed);
  EXPECT_EQ(r.last_counter, kNow + 10);
  EXPECT_NE(r.describe().find("not beyond the last one accepted"), std::string::npos) << r.describe();
  // Another sender has counters of its own; so has another channel of the same sender.
  const auto b1 = signed_message(b, "POF_RAW", kNow - 5);
  EXPECT_EQ(verdict(v, "POF_RAW", b1, kNow), Verdict::kOk);
  const auto a3 = signed_message(a, "POF_STATUS", kNow + 11);
  EXPECT_EQ(verdict(v, "POF_STATUS", a3, kNow), Verdict::kOk);
  EXPECT_EQ(v.streams(), 3u);
  EXPECT_EQ(v.count(Verdict::kReplayed), 3u);
  EXPECT_EQ(v.count(Verdict::kOk), 4u);
}

TEST(BusAuth, CountersOutsideTheWindowEitherWayAreStale) {
  const auto k = key(1);
  Verifier v(k, VerifierSettings{2'000'000, 16});
  Signer old(k, 1), edge(k, 2), ahead(k, 3), late(k, 4);
  EXPECT_EQ(verdict(v, "C", signed_message(old, "C", kNow - 2'000'001), kNow), Verdict::kStale);
  EXPECT_EQ(verdict(v, "C", signed_message(edge, "C", kNow - 2'000'000), kNow), Verdict::kOk);
  EXPECT_EQ(verdict(v, "C", signed_message(ahead, "C", kNow + 2'000'001), kNow), Verdict::kStale);
  EXPECT_EQ(verdict(v, "C", signed_message(late, "C", kNow + 2'000'000), kNow), Verdict::kOk);
  Signer older(k, 7);
  const auto m = signed_message(older, "C", kNow - 3'500'000);
  const auto r = v.verify("C", m.data(), m.size(), kNow);
  EXPECT_EQ(r.verdict, Verdict::kStale);
  EXPECT_NE(r.describe().find("3.500 s behind this host's clock"), std::string::npos) << r.describe();
  // A stale message never enters the replay state.
  EXPECT_EQ(v.streams(), 2u);
  EXPECT_EQ(v.count(Verdict::kStale), 3u);
  // The extremes do not overflow: counter 0 or UINT64_MAX against either end of the clock.
  Signer z(k, 5), m1(k, 6);
  const auto zero = signed_message(z, "C", 0);
  const auto max = signed_message(m1, "C", kMax);
  EXPECT_EQ(verdict(v, "C", zero, kMax), Verdict::kStale);
  EXPECT_EQ(verdict(v, "C", max, 0), Verdict::kStale);
  EXPECT_EQ(verdict(v, "C", max, kMax), Verdict::kOk);
}

TEST(BusAuth, TheCounterIsStrictlyIncreasingEvenWhenTheClockStallsOrGoesBack) {
  Signer s(key(1), 1);
  std::vector<std::uint64_t> counters;
  for (const std::uint64_t now : {kNow, kNow, kNow, kNow - 1'000'000, kNow + 5}) {
    const auto m = signed_message(s, "C", now);
    counters.push_back(pof::bus::auth::parse_trailer(m.data(), m.size())->counter);
  }
  EXPECT_EQ(counters, (std::vector<std::uint64_t>{kNow, kNow + 1, kNow + 2, kNow + 3, kNow + 5}));
  EXPECT_EQ(s.last_counter(), kNow + 5);
  // Negative realtime (a clock before 1970) counts from 0.
  EXPECT_EQ(pof::bus::auth::counter_time(-5), 0u);
  EXPECT_EQ(pof::bus::auth::counter_time(123), 123u);
}

TEST(BusAuth, ASaturatedCounterStopsSigningInsteadOfWrapping) {
  const auto k = key(1);
  Signer s(k, 1);
  const auto last = signed_message(s, "C", kMax - 1);
  const auto at_max = signed_message(s, "C", kMax - 1);  // forced to kMax
  EXPECT_EQ(pof::bus::auth::parse_trailer(at_max.data(), at_max.size())->counter, kMax);
  std::vector<unsigned char> buf(10 + kTrailerBytes, 0xAA);
  EXPECT_FALSE(s.sign("C", buf.data(), 10, kMax));
  EXPECT_FALSE(s.sign("C", buf.data(), 10, 5));
  EXPECT_EQ(buf, std::vector<unsigned char>(10 + kTrailerBytes, 0xAA));  // nothing written
  EXPECT_EQ(s.last_counter(), kMax);
  Verifier v(k);
  EXPECT_EQ(verdict(v, "C", last, kMax), Verdict::kOk);
  EXPECT_EQ(verdict(v, "C", at_max, kMax), Verdict::kOk);
  EXPECT_EQ(verdict(v, "C", at_max, kMax), Verdict::kReplayed);
}

TEST(BusAuth, TheReplayStateIsBoundedAndForgetsStaleStreamsFirst) {
  const auto k = key(1);
  Verifier v(k, VerifierSettings{1'000'000, 3});
  Signer s1(k, 1), s2(k, 2), s3(k, 3), s4(k, 4);
  const auto m1 = signed_message(s1, "C", kNow);
  EXPECT_EQ(verdict(v, "C", m1, kNow), Verdict::kOk);
  EXPECT_EQ(verdict(v, "C", signed_message(s2, "C", kNow + 1'500'000), kNow + 1'500'000), Verdict::kOk);
  EXPECT_EQ(verdict(v, "C", signed_message(s3, "C", kNow + 1'600'000), kNow + 1'600'000), Verdict::kOk);
  EXPECT_EQ(v.streams(), 3u);
  // A fourth stream: sender 1's last counter is beyond the window, so it goes (and its old message
  // is stale, not accepted again).
  EXPECT_EQ(verdict(v, "C", signed_message(s4, "C", kNow + 1'700'000), kNow + 1'700'000), Verdict::kOk);
  EXPECT_EQ(v.streams(), 3u);
  EXPECT_EQ(verdict(v, "C", m1, kNow + 1'700'000), Verdict::kStale);
  // Five more senders within the window: the least recent is evicted each time; never more than 3.
  for (std::uint64_t i = 10; i < 15; ++i) {
    Signer s(k, i);
    EXPECT_EQ(verdict(v, "C", signed_message(s, "C", kNow + 1'700'000 + i), kNow + 1'700'000), Verdict::kOk);
    EXPECT_LE(v.streams(), 3u);
  }
}

TEST(BusAuth, KeysAreThirtyTwoBytesAndTheirIdsDiffer) {
  const unsigned char short_key[31] = {};
  EXPECT_THROW(Key(short_key, sizeof short_key), std::invalid_argument);
  EXPECT_EQ(key(1)->id(), key(1)->id());
  EXPECT_EQ(pof::bus::auth::key_id_hex(0x1a2b3c4d), "1a2b3c4d");
  EXPECT_EQ(std::string(pof::bus::auth::verdict_name(Verdict::kBadMac)), "bad_mac");
  EXPECT_NE(pof::bus::auth::random_sender_id(), pof::bus::auth::random_sender_id());
}

// --- Key files (pof/bus/auth_key.hpp) ---------------------------------------------------------

namespace {

using pof::bus::auth::AclEntry;
using pof::bus::auth::key_access_problem;
using pof::bus::auth::load_key_file;

// A key file with `content` and `mode` in `dir`.
std::string key_file(const pof::test::TempDir& dir, const std::string& name, const std::string& content, mode_t mode) {
  const std::string p = dir.file(name, content);
  EXPECT_EQ(::chmod(p.c_str(), mode), 0);
  return p;
}

// The ConfigError (exit 78) load_key_file throws for `path`, or "(loaded)".
std::string refusal(const std::string& path) {
  try {
    (void)load_key_file(path);
  } catch (const pof::ConfigError& e) {
    EXPECT_EQ(e.code(), pof::kExitConfig);
    return e.what();
  }
  return "(loaded)";
}

const std::string kHex = "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f";

}  // namespace

TEST(BusAuthKey, HexOrRawKeysLoadAndGiveTheSameKey) {
  const pof::test::TempDir dir;
  std::string raw;
  for (int i = 0; i < 32; ++i) raw += static_cast<char>(i);
  const auto a = load_key_file(key_file(dir, "hex.key", kHex + "\n", 0600));
  const auto b = load_key_file(key_file(dir, "raw.key", raw, 0400));
  const auto c = load_key_file(key_file(dir, "crlf.key", kHex + "\r\n", 0600));
  const auto upper = load_key_file(key_file(dir, "upper.key", "000102030405060708090A0B0C0D0E0F101112131415161718191A1B1C1D1E1F", 0600));
  EXPECT_EQ(a->id(), b->id());
  EXPECT_EQ(a->id(), c->id());
  EXPECT_EQ(a->id(), upper->id());
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(a->bytes()), 32), raw);
}

TEST(BusAuthKey, AnAllZeroKeyIsRefused) {
  const pof::test::TempDir dir;
  for (const std::string& zero : {std::string(64, '0') + "\n", std::string(32, '\0')}) {
    const std::string p = key_file(dir, "zero.key", zero, 0600);
    const std::string why = refusal(p);
    EXPECT_NE(why.find("bus key file '" + p + "'"), std::string::npos) << why;
    EXPECT_NE(why.find("all zeros"), std::string::npos) << why;
    std::filesystem::remove(p);
  }
}

TEST(BusAuthKey, MalformedKeysAreRefusedNamingTheFile) {
  const pof::test::TempDir dir;
  for (const std::string& bad : {kHex.substr(0, 62) + "\n", kHex + "0\n", kHex.substr(0, 63) + "g\n", kHex + "\n\n",
                                 std::string(33, 'x'), std::string(), std::string(200, 'a')}) {
    const std::string p = key_file(dir, "bad.key", bad, 0600);
    const std::string why = refusal(p);
    EXPECT_NE(why.find("bus key file '" + p + "'"), std::string::npos) << why;
    EXPECT_NE(why.find("expected 32 bytes, or 64 hex digits"), std::string::npos) << why;
    std::filesystem::remove(p);
  }
  const std::string missing = refusal(dir.path("absent.key"));
  EXPECT_NE(missing.find("absent.key': cannot open"), std::string::npos) << missing;
  const std::string directory = refusal(dir.path().string());
  EXPECT_NE(directory.find("not a regular file"), std::string::npos) << directory;
}

TEST(BusAuthKey, AKeyOthersCanReadOrWriteIsRefusedWithItsMode) {
  const pof::test::TempDir dir;
  for (const mode_t mode : {0640u, 0604u, 0620u, 0602u, 0660u, 0644u, 0701u}) {
    const std::string p = key_file(dir, "open.key", kHex + "\n", mode);
    const std::string why = refusal(p);
    char m[8];
    std::snprintf(m, sizeof m, "%04o", static_cast<unsigned>(mode));
    EXPECT_NE(why.find("'" + p + "': mode " + m + " gives group or others access"), std::string::npos) << why;
    std::filesystem::remove(p);
  }
}

TEST(BusAuthKey, AKeyOwnedBySomeoneElseIsRefused) {
  if (::geteuid() != 0) GTEST_SKIP() << "chown to another user needs root";
  const pof::test::TempDir dir;
  const std::string p = key_file(dir, "theirs.key", kHex + "\n", 0600);
  ASSERT_EQ(::chown(p.c_str(), 12345, 12345), 0);
  const std::string why = refusal(p);
  EXPECT_NE(why.find("owned by uid 12345, neither root nor the user running this process"), std::string::npos) << why;
}

TEST(BusAuthKey, OwnerModeAndAclRules) {
  // Root or the running user; no group/other bits.
  EXPECT_EQ(key_access_problem(0, 0100600, nullptr, 998), "");
  EXPECT_EQ(key_access_problem(998, 0100400, nullptr, 998), "");
  EXPECT_NE(key_access_problem(1000, 0100600, nullptr, 998), "");
  EXPECT_NE(key_access_problem(0, 0100640, nullptr, 998), "");
  // systemd's LoadCredential= copy on a file system with ACLs: root's 0400 file, user 998 (the
  // service) may read it; stat shows the ACL mask in the group bits (0440).
  const std::vector<AclEntry> credential = {{0x01, 4, 0}, {0x02, 4, 998}, {0x04, 0, 0}, {0x10, 4, 0}, {0x20, 0, 0}};
  EXPECT_EQ(key_access_problem(0, 0100440, &credential, 998), "");
  // ... but not for a process running as another user, nor with a readable owning group or others.
  EXPECT_NE(key_access_problem(0, 0100440, &credential, 1000).find("gives user 998 access"), std::string::npos);
  auto group = credential;
  group[2].perm = 4;
  EXPECT_NE(key_access_problem(0, 0100440, &group, 998).find("gives the owning group access"), std::string::npos);
  auto other = credential;
  other[4].perm = 4;
  EXPECT_NE(key_access_problem(0, 0100444, &other, 998).find("gives others access"), std::string::npos);
  // A named group is harmless only while the mask takes its permissions away.
  std::vector<AclEntry> masked = {{0x01, 6, 0}, {0x04, 0, 0}, {0x08, 4, 50}, {0x10, 0, 0}, {0x20, 0, 0}};
  EXPECT_EQ(key_access_problem(0, 0100600, &masked, 998), "");
  masked[3].perm = 4;
  EXPECT_NE(key_access_problem(0, 0100640, &masked, 998).find("gives group 50 access"), std::string::npos);
}

TEST(BusAuthKey, PosixAclAttributesParse) {
  // system.posix_acl_access: u32 version 2, then {u16 tag, u16 perm, u32 id} entries, little-endian.
  const unsigned char attr[] = {2, 0, 0, 0, 0x01, 0, 6, 0, 0xff, 0xff, 0xff, 0xff, 0x02, 0, 4, 0, 0xe6, 3, 0, 0};
  const auto acl = pof::bus::auth::parse_posix_acl(attr, sizeof attr);
  ASSERT_TRUE(acl);
  ASSERT_EQ(acl->size(), 2u);
  EXPECT_EQ((*acl)[1].tag, 0x02);
  EXPECT_EQ((*acl)[1].perm, 4);
  EXPECT_EQ((*acl)[1].id, 998u);
  EXPECT_FALSE(pof::bus::auth::parse_posix_acl(attr, sizeof attr - 1));
  const unsigned char v1[] = {1, 0, 0, 0};
  EXPECT_FALSE(pof::bus::auth::parse_posix_acl(v1, sizeof v1));
}

TEST(BusAuthKey, NewKeysAreRandomHexThatLoads) {
  const std::string a = pof::bus::auth::new_key_text(), b = pof::bus::auth::new_key_text();
  ASSERT_EQ(a.size(), 65u);
  EXPECT_EQ(a.back(), '\n');
  EXPECT_NE(a, b);
  EXPECT_TRUE(pof::bus::auth::parse_key_bytes(reinterpret_cast<const unsigned char*>(a.data()), a.size()));
}

TEST(BusAuthKey, TheOptionWinsOverTheEnvironment) {
  const char* old = std::getenv(pof::bus::auth::kKeyFileEnv);
  const std::string saved = old != nullptr ? old : "";
  ::setenv(pof::bus::auth::kKeyFileEnv, "/env.key", 1);
  EXPECT_EQ(pof::bus::auth::resolve_key_file(""), "/env.key");
  EXPECT_EQ(pof::bus::auth::resolve_key_file("/opt.key"), "/opt.key");
  ::unsetenv(pof::bus::auth::kKeyFileEnv);
  EXPECT_EQ(pof::bus::auth::resolve_key_file(""), "");
  if (old != nullptr) ::setenv(pof::bus::auth::kKeyFileEnv, saved.c_str(), 1);
}
