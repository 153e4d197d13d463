#include "pof/io/lcmlog_writer.hpp"

#include <cmath>
#include <stdexcept>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <pof/raw_block_t.hpp>

#include "pof/base/errors.hpp"

namespace pof::io {

struct LcmLogWriter::Impl {
  std::unique_ptr<lcm::LogFile> log;
  pof::raw_block_t msg;
  std::vector<std::uint8_t> buf;
  std::int32_t flags = 0;
  std::int64_t first_utime = 0;
  std::int64_t last_utime = 0;
};

LcmLogWriter::LcmLogWriter(const std::filesystem::path& path, LcmLogOptions options)
    : file_(path), opt_(std::move(options)), impl_(std::make_unique<Impl>()) {
  if (opt_.block_scans < 1) throw std::invalid_argument("LcmLogWriter: block_scans must be >= 1");
  impl_->log = std::make_unique<lcm::LogFile>(file_.temp_path().string(), "w");
  if (!impl_->log->good()) throw IoError(path.string() + ": cannot open the LCM log for writing");
  pof::raw_block_t& m = impl_->msg;
  m.scan_rate_hz = opt_.scan_rate_hz;
  m.sensor_id = opt_.sensor_id;
  m.channel_names = {"sensor", "reference"};
  m.channel_units = {"V", "V"};
  if (opt_.pot) {
    m.channel_names.emplace_back("pot");
    m.channel_units.emplace_back("V");
  }
  if (opt_.angle_ref) {
    m.channel_names.emplace_back("angle_ref");
    m.channel_units.emplace_back("deg");
  }
  if (opt_.angle_true) {
    m.channel_names.emplace_back("angle_true");
    m.channel_units.emplace_back("deg");
  }
  m.n_channels = static_cast<std::int16_t>(m.channel_names.size());
  m.volts.reserve(static_cast<std::size_t>(opt_.block_scans));
  m.n_scans = 0;
}

LcmLogWriter::~LcmLogWriter() = default;

void LcmLogWriter::write(const RecordingRow& r) {
  pof::raw_block_t& m = impl_->msg;
  const std::int64_t utime = opt_.epoch_utime + std::llround(r.t_s * 1e6);
  if (m.n_scans == 0) {
    impl_->first_utime = utime;
    m.first_scan = scans_;
    impl_->flags = opt_.simulated ? std::int32_t{pof::raw_block_t::FLAG_SIMULATED} : 0;
  }
  impl_->last_utime = utime;
  std::vector<float> row;
  row.reserve(static_cast<std::size_t>(m.n_channels));
  row.push_back(static_cast<float>(r.sensor_v));
  row.push_back(static_cast<float>(r.reference_v));
  if (opt_.pot) row.push_back(static_cast<float>(r.pot_v));
  if (opt_.angle_ref) row.push_back(static_cast<float>(r.angle_ref_deg));
  if (opt_.angle_true) row.push_back(static_cast<float>(r.angle_true_deg));
  m.volts.push_back(std::move(row));
  if (r.over_range) impl_->flags |= std::int32_t{pof::raw_block_t::FLAG_OVER_RANGE};
  ++m.n_scans;
  ++scans_;
  if (m.n_scans >= opt_.block_scans) flush_block();
}

void LcmLogWriter::flush_block() {
  pof::raw_block_t& m = impl_->msg;
  if (m.n_scans == 0) return;
  m.utime = impl_->first_utime;
  m.publish_utime = impl_->last_utime;  // the earliest a live publisher could have sent it
  m.seq = seq_;
  m.flags = impl_->flags;
  const int size = m.getEncodedSize();
  impl_->buf.resize(static_cast<std::size_t>(size));
  if (m.encode(impl_->buf.data(), 0, size) != size) throw IoError(file_.dest_path().string() + ": cannot encode raw_block_t");
  lcm::LogEvent ev{};
  ev.eventnum = seq_;
  ev.timestamp = m.publish_utime;
  ev.channel = opt_.channel;
  ev.datalen = size;
  ev.data = impl_->buf.data();
  if (impl_->log->writeEvent(&ev) != 0) throw IoError(file_.dest_path().string() + ": write error in the LCM log");
  ++seq_;
  m.volts.clear();
  m.n_scans = 0;
}

void LcmLogWriter::commit() {
  flush_block();
  if (std::fflush(impl_->log->getFilePtr()) != 0) throw IoError(file_.dest_path().string() + ": write error in the LCM log");
  impl_->log.reset();  // closes the file
  file_.commit();
}

void write_lcmlog(const std::filesystem::path& path, const Recording& rec, LcmLogOptions options) {
  const Eigen::Index n = rec.size();
  options.pot = rec.pot_v.size() == n && n > 0;
  options.angle_ref = rec.angle_ref_deg.size() == n && n > 0;
  options.angle_true = rec.angle_true_deg.size() == n && n > 0;
  LcmLogWriter w(path, options);
  for (Eigen::Index i = 0; i < n; ++i) w.write(row_of(rec, i));
  w.commit();
}

}  // namespace pof::io
