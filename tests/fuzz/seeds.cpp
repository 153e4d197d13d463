// fuzz_seeds: writes the seed corpora of the bus and DAQ fuzz targets (udpm_datagram, auth,
// ni_usb600x, mcc_usb1208ls) from the code's own encoders: lcm-gen's for the messages, the Signer
// for the trailers, make_frame/make_reply/configure_frames/start_frames/encode_sample for the NI
// devices, encode_scan_report for the MCC one; the datagrams by the wire format of
// common/bus/include/pof/bus/udpm_receiver.hpp (tests/support/udpm_wire.hpp). Each corpus holds valid
// inputs and a few near-valid ones (one field wrong). Crash inputs kept as regression tests
// (regress_*) are not written here.
//
//   fuzz_seeds DIR          writes DIR/<target>/<file>
//   fuzz_seeds --check DIR  exit 1 unless every file is in DIR with these bytes (ctest fuzz.seeds)
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_auth_input.hpp"
#include "pof/angle_t.hpp"
#include "pof/bus/auth.hpp"
#include "pof/bus/udpm_receiver.hpp"
#include "pof/daq/protocol/mcc_usb1208ls.hpp"
#include "pof/daq/protocol/ni_usb600x.hpp"
#include "pof/raw_block_t.hpp"
#include "udpm_wire.hpp"

namespace {

using Bytes = std::vector<unsigned char>;
namespace ai = pof::fuzz::auth_input;
namespace ni = pof::daq::ni;
namespace mcc = pof::daq::mcc;

template <class T>
Bytes encode(const T& m) {
  Bytes b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

pof::angle_t angle() {
  pof::angle_t a{};
  a.utime = static_cast<std::int64_t>(ai::kNow);
  a.publish_utime = a.utime + 180;
  a.seq = 7;
  a.scan_index = 700;
  a.angle_deg = 42.5f;
  a.angle_uncomp_deg = 44.0f;
  a.angle_ref_deg = 42.0f;
  a.velocity_rad_s = 1.25f;
  a.phase = pof::angle_t::PHASE_FLEXION;
  return a;
}

pof::raw_block_t raw_block(int scans) {
  pof::raw_block_t b{};
  b.utime = static_cast<std::int64_t>(ai::kNow);
  b.publish_utime = b.utime + 250;
  b.seq = 3;
  b.first_scan = 3 * scans;
  b.scan_rate_hz = 2000.0;
  b.sensor_id = "LEFT_KNEE";
  b.n_channels = 3;
  b.channel_names = {"sensor", "reference", "pot"};
  b.channel_units = {"V", "V", "V"};
  b.n_scans = scans;
  for (int i = 0; i < scans; ++i)
    b.volts.push_back({2.5f + 0.01f * static_cast<float>(i % 50), 3.0f, 0.02f * static_cast<float>(i)});
  return b;
}

// A message signed with `key` on `channel` at `counter` by the first sender of the script format.
Bytes signed_bytes(const std::shared_ptr<const pof::bus::auth::Key>& key, std::string_view channel, const Bytes& msg,
                   std::uint64_t counter) {
  Bytes b = msg;
  b.resize(msg.size() + pof::bus::auth::kTrailerBytes);
  pof::bus::auth::Signer s(key, ai::kSenders[0]);
  s.sign(channel, b.data(), msg.size(), counter);
  return b;
}

// The "as received" input of fuzz_auth: mode byte 0, channel length, channel, message.
Bytes received(std::string_view channel, const Bytes& message) {
  Bytes b{0, static_cast<unsigned char>(channel.size())};
  b.insert(b.end(), channel.begin(), channel.end());
  b.insert(b.end(), message.begin(), message.end());
  return b;
}

// One signing step of the script format.
Bytes sign_step(unsigned sender, unsigned channel, std::uint8_t flags, std::uint8_t advance_ms, std::uint8_t skew,
                const Bytes& msg, Bytes alter = {}) {
  if (msg.size() > 255) throw std::length_error("a script message holds at most 255 bytes");
  Bytes b{static_cast<unsigned char>(ai::kSign | sender << 2 | channel << 4 | flags), advance_ms, skew,
          static_cast<unsigned char>(msg.size())};
  b.insert(b.end(), msg.begin(), msg.end());
  b.insert(b.end(), alter.begin(), alter.end());
  return b;
}

using Corpus = std::map<std::string, Bytes>;  // "<target>/<file>" -> bytes

void udpm(Corpus& c) {
  using pof::test::udpm_fragment;
  using pof::test::udpm_short;
  const Bytes a = encode(angle());
  c["udpm_datagram/short_angle.bin"] = udpm_short(0, "POF_ANGLE_LEFT_KNEE", a);
  c["udpm_datagram/short_raw_block.bin"] = udpm_short(1, "POF_RAW_LEFT_KNEE", encode(raw_block(20)));
  c["udpm_datagram/short_empty_message.bin"] = udpm_short(2, "POF_X", {});
  const std::string probe = "lcm self test";  // what liblcm sends when a process first subscribes
  c["udpm_datagram/short_lcm_self_test.bin"] = udpm_short(3, "LCM_SELF_TEST", Bytes(probe.begin(), probe.end()));
  const Bytes big = encode(raw_block(60));  // ~900 bytes in 256-byte fragments
  const auto frags = pof::test::udpm_fragments(4, "POF_RAW_LEFT_KNEE", big, 256);
  for (std::size_t i = 0; i < frags.size(); ++i)
    c["udpm_datagram/fragment_" + std::to_string(i) + "_of_" + std::to_string(frags.size()) + ".bin"] = frags[i];
  // Near-valid: one field wrong.
  const Bytes ten(10, 0xAB);
  c["udpm_datagram/bad_offset_ffffffff.bin"] = udpm_fragment(5, 100000, 0xFFFFFFFFu, 1, 2, "", ten);  // crashes liblcm 1.3.1
  c["udpm_datagram/bad_one_byte_past_end.bin"] = udpm_fragment(5, 100, 91, 1, 2, "", ten);
  c["udpm_datagram/bad_number_is_count.bin"] = udpm_fragment(5, 100, 0, 2, 2, "", ten);
  c["udpm_datagram/bad_size_above_limit.bin"] = udpm_fragment(5, (16u << 20) + 1, 0, 1, 300, "", ten);
  c["udpm_datagram/bad_fragment0_without_channel.bin"] = udpm_fragment(5, 100, 0, 0, 2, "", ten);
  c["udpm_datagram/bad_channel_64_bytes.bin"] = udpm_short(6, std::string(64, 'C'), a);
  Bytes no_nul = udpm_short(6, "POF_ANGLE", {});
  no_nul.pop_back();
  c["udpm_datagram/bad_no_channel_end.bin"] = no_nul;
}

void auth(Corpus& c) {
  const auto key = ai::key();
  const Bytes a = encode(angle());
  const Bytes r = encode(raw_block(10));
  c["auth/received_signed_angle.bin"] = received("POF_ANGLE_LEFT_KNEE", signed_bytes(key, "POF_ANGLE_LEFT_KNEE", a, ai::kNow));
  c["auth/received_signed_raw_block.bin"] =
      received("POF_RAW_LEFT_KNEE", signed_bytes(key, "POF_RAW_LEFT_KNEE", r, ai::kNow - 1500));
  c["auth/received_signed_empty.bin"] = received("POF_X", signed_bytes(key, "POF_X", {}, ai::kNow));
  c["auth/received_unsigned.bin"] = received("POF_ANGLE_LEFT_KNEE", a);
  // Near-valid.
  c["auth/received_other_key.bin"] = received("POF_ANGLE_LEFT_KNEE", signed_bytes(ai::key(1), "POF_ANGLE_LEFT_KNEE", a, ai::kNow));
  c["auth/received_stale.bin"] =
      received("POF_ANGLE_LEFT_KNEE", signed_bytes(key, "POF_ANGLE_LEFT_KNEE", a, ai::kNow - 3 * ai::kWindowUs));
  Bytes altered = signed_bytes(key, "POF_ANGLE_LEFT_KNEE", a, ai::kNow);
  altered[a.size() + 40] ^= 0x01;  // a MAC byte
  c["auth/received_altered_mac.bin"] = received("POF_ANGLE_LEFT_KNEE", altered);
  c["auth/received_other_channel.bin"] = received("POF_ANGLE_RIGHT_KNEE", signed_bytes(key, "POF_ANGLE_LEFT_KNEE", a, ai::kNow));
  // Scripts: sign, deliver twice, replay, move to another channel, alter, go stale; and more
  // streams than the verifier keeps.
  const Bytes small(a.begin(), a.begin() + 24);
  c["auth/script_sign_replay_alter.bin"] =
      cat({{1}, sign_step(0, 0, ai::kTwice, 1, 128, a), sign_step(1, 1, 0, 1, 120, r),
           {ai::kReplayOld, 0}, {ai::kOtherChannel, 1}, sign_step(0, 0, ai::kAlter, 1, 128, small, {3, 0x80}),
           sign_step(2, 2, 0, 1, 0, small)});
  Bytes streams{1};
  for (unsigned i = 0; i < 6; ++i) {
    const Bytes s = sign_step(i % 4, i % 3, 0, 50, 128, small);
    streams.insert(streams.end(), s.begin(), s.end());
  }
  for (unsigned char i = 0; i < 6; ++i) streams.insert(streams.end(), {ai::kReplayOld, i});
  c["auth/script_eviction.bin"] = streams;
}

void ni600x(Corpus& c) {
  // The commands of one session as pof-daqd sends them (3 channels, RSE, +-10 V, 2 kHz), and the
  // replies the device gives [4], with either header byte [3].
  ni::ScanProgram prog;
  prog.channels = {0, 1, 4};
  prog.clock_divisor = ni::clock_divisor(2000.0);
  std::vector<ni::Frame> frames{ni::make_frame(ni::Cmd::kHello)};
  for (const auto& list : {ni::session_frames(), ni::configure_frames(prog), ni::start_frames(1000, 3), ni::stop_frames()})
    frames.insert(frames.end(), list.begin(), list.end());
  std::map<std::string, int> seen;
  for (const ni::Frame& f : frames) {
    const auto p = ni::parse_frame(f.view());
    std::string name(ni::find_opcode(p->op, p->group)->name);
    for (char& ch : name) ch = ch == ' ' || ch == '/' ? '_' : ch;
    const int k = seen[name]++;
    if (k > 0) continue;  // one frame of each command
    c["ni_usb600x/command_" + name + ".bin"] = Bytes(f.bytes.begin(), f.bytes.begin() + static_cast<std::ptrdiff_t>(f.size));
  }
  const auto reply = [](ni::Cmd cmd, std::uint8_t hh) {
    const ni::Frame f = ni::make_reply(cmd, hh);
    return Bytes(f.bytes.begin(), f.bytes.begin() + static_cast<std::ptrdiff_t>(f.size));
  };
  c["ni_usb600x/reply_hello_00.bin"] = reply(ni::Cmd::kHello, 0);
  c["ni_usb600x/reply_hello_01.bin"] = reply(ni::Cmd::kHello, 1);
  c["ni_usb600x/reply_ack_00.bin"] = reply(ni::Cmd::kArm, 0);
  c["ni_usb600x/reply_channel_setup_01.bin"] = reply(ni::Cmd::kChannelSetup, 1);
  Bytes short_ack = reply(ni::Cmd::kArm, 0);
  short_ack.pop_back();
  c["ni_usb600x/bad_reply_short.bin"] = short_ack;
  Bytes hh2 = reply(ni::Cmd::kArm, 0);
  hh2[1] = 2;
  c["ni_usb600x/bad_reply_header_02.bin"] = hh2;
  Bytes len = reply(ni::Cmd::kArm, 0);
  len[3] = 0x10;  // the length field disagrees with the bytes
  c["ni_usb600x/bad_frame_length.bin"] = len;
  // Samples on 0x82 [9]: 300 scans of 3 channels, a slow triangle with +-1 LSB of noise (the byte
  // order detector needs noise or motion), in each coding; the 6008 once with padding bits set.
  std::minstd_rand noise(1);
  const auto stream = [&](ni::SampleCoding coding, bool pad) {
    Bytes b(2 * 3 * 300);
    const int mid = 1 << (coding.bits - 1);
    for (int s = 0; s < 300; ++s) {
      for (int ch = 0; ch < 3; ++ch) {
        const int tri = (s % 100 < 50 ? s % 100 : 100 - s % 100) * (ch + 1);
        const auto code = static_cast<std::uint16_t>(mid + tri + static_cast<int>(noise() % 3) - 1);
        unsigned char* w = &b[static_cast<std::size_t>(2 * (3 * s + ch))];
        ni::encode_sample(code, coding, w);
        if (pad) w[coding.order == ni::ByteOrder::kBig ? 1 : 0] |= static_cast<unsigned char>((s + ch) % 16);
      }
    }
    return b;
  };
  c["ni_usb600x/samples_6008_big_3ch.bin"] = stream(ni::usb6008_coding(ni::ByteOrder::kBig), false);
  c["ni_usb600x/samples_6008_little_3ch.bin"] = stream(ni::usb6008_coding(ni::ByteOrder::kLittle), false);
  c["ni_usb600x/samples_6008_little_padding_set.bin"] = stream(ni::usb6008_coding(ni::ByteOrder::kLittle), true);
  c["ni_usb600x/samples_6009_3ch.bin"] = stream(ni::usb6009_coding(), false);
}

void mcc1208(Corpus& c) {
  // Scan feature reports [7] as the device sends them in one scan: index 1, 2, 3, in each layout;
  // a repeat of the last report (the device's "not ready yet"); and AIn replies [5].
  const auto reports = [](mcc::ReportLayout l, std::initializer_list<std::uint16_t> indices) {
    Bytes out;
    for (const std::uint16_t i : indices) {
      std::array<std::int16_t, mcc::kSamplesPerScanReport> s{};
      for (std::size_t k = 0; k < s.size(); ++k) {
        const auto n = static_cast<int>((i - 1U) * 64U + k);
        s[k] = static_cast<std::int16_t>(k % 4 == 3 ? 0 : (n % 400) * 10 - 2000);  // 3 channels + padding
      }
      std::array<std::uint8_t, mcc::kScanReportBytes> r{};
      mcc::encode_scan_report(s, i, static_cast<std::uint8_t>(i), r, l);
      out.insert(out.end(), r.begin(), r.end());
    }
    return out;
  };
  c["mcc_usb1208ls/reports_record_first_1_2_3.bin"] = reports(mcc::ReportLayout::kRecordFirst, {1, 2, 3});
  c["mcc_usb1208ls/reports_data_first_1_2_3.bin"] = reports(mcc::ReportLayout::kDataFirst, {1, 2, 3});
  c["mcc_usb1208ls/reports_record_first_repeat.bin"] = reports(mcc::ReportLayout::kRecordFirst, {1, 1, 2});
  c["mcc_usb1208ls/bad_reports_first_index_2.bin"] = reports(mcc::ReportLayout::kRecordFirst, {2, 3});
  Bytes ain;
  for (const int counts : {0, 1023, -1024, 512}) {  // single-ended: {lo nibble, hi}, 6 bytes padding
    const auto raw = static_cast<unsigned>(counts + 0x400);
    const Bytes reply{static_cast<unsigned char>(raw & 0x0F), static_cast<unsigned char>(raw >> 4), 0, 0, 0, 0, 0, 0};
    ain.insert(ain.end(), reply.begin(), reply.end());
  }
  c["mcc_usb1208ls/ain_single_ended_replies.bin"] = ain;
  // A channel list for the queue [3]: count, gain, channels.
  c["mcc_usb1208ls/queue_3_channels_se.bin"] = {3, mcc::kSe10V, 0, 1, 2};
  c["mcc_usb1208ls/queue_8_channels_bp5.bin"] = {8, mcc::kBp5V, 0, 1, 2, 3, 4, 5, 6, 7};
}

}  // namespace

int main(int argc, char** argv) {
  const bool check = argc == 3 && std::string_view(argv[1]) == "--check";
  if (argc != (check ? 3 : 2)) {
    std::fprintf(stderr, "usage: %s [--check] CORPUS_DIR\n", argv[0]);
    return 2;
  }
  const std::filesystem::path dir = argv[argc - 1];
  Corpus c;
  udpm(c);
  auth(c);
  ni600x(c);
  mcc1208(c);
  int bad = 0;
  for (const auto& [name, bytes] : c) {
    const std::filesystem::path p = dir / name;
    if (check) {
      std::ifstream in(p, std::ios::binary);
      const Bytes have((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      if (!in.is_open() || have != bytes) {
        std::fprintf(stderr, "%s: %s (run %s %s)\n", p.c_str(), in.is_open() ? "differs from what the encoders write" : "missing",
                     argv[0], dir.c_str());
        ++bad;
      }
      continue;
    }
    std::filesystem::create_directories(p.parent_path());
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!out) {
      std::fprintf(stderr, "%s: cannot write\n", p.c_str());
      return 1;
    }
  }
  std::printf("%s %zu seed files in %s\n", check ? (bad == 0 ? "checked" : "FAILED:") : "wrote", c.size(), dir.c_str());
  return bad == 0 ? 0 : 1;
}
