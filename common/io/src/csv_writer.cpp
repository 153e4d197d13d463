#include "pof/io/csv_writer.hpp"

#include <charconv>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "pof/base/errors.hpp"

namespace pof::io {

CsvWriter::CsvWriter(const std::filesystem::path& path, CsvColumns columns) : file_(path), cols_(columns) {
  if (!cols_.angle_ref_deg && !cols_.pot_v)
    throw std::invalid_argument("CsvWriter: a recording needs angle_ref_deg or pot_v");
  f_ = std::fopen(file_.temp_path().c_str(), "wb");
  if (f_ == nullptr) throw IoError(path.string() + ": cannot open for writing: " + std::strerror(errno));
  std::setvbuf(f_, nullptr, _IOFBF, 1 << 20);
  std::string header = "t_s,sensor_v,reference_v";
  if (cols_.angle_ref_deg) header += ",angle_ref_deg";
  if (cols_.pot_v) header += ",pot_v";
  if (cols_.angle_true_deg) header += ",angle_true_deg";
  header += '\n';
  std::fputs(header.c_str(), f_);
}

CsvWriter::~CsvWriter() {
  if (f_ != nullptr) std::fclose(f_);
}

void CsvWriter::put(double v, bool last) {
  // Shortest representation that parses back to the same double (round-trip exact).
  char buf[40];
  auto [end, ec] = std::to_chars(buf, buf + sizeof buf - 1, v);
  if (ec != std::errc{}) end = buf;  // cannot happen with 40 bytes; an empty field then
  *end++ = last ? '\n' : ',';
  std::fwrite(buf, 1, static_cast<std::size_t>(end - buf), f_);
}

void CsvWriter::write(const RecordingRow& r) {
  put(r.t_s, false);
  put(r.sensor_v, false);
  put(r.reference_v, !cols_.angle_ref_deg && !cols_.pot_v && !cols_.angle_true_deg);
  if (cols_.angle_ref_deg) put(r.angle_ref_deg, !cols_.pot_v && !cols_.angle_true_deg);
  if (cols_.pot_v) put(r.pot_v, !cols_.angle_true_deg);
  if (cols_.angle_true_deg) put(r.angle_true_deg, true);
  ++rows_;
  if (std::ferror(f_)) throw IoError(file_.dest_path().string() + ": write error: " + std::strerror(errno));
}

void CsvWriter::commit() {
  const bool bad = std::fflush(f_) != 0 || std::ferror(f_);
  const int e = errno;
  const bool close_bad = std::fclose(f_) != 0;
  f_ = nullptr;
  if (bad || close_bad) throw IoError(file_.dest_path().string() + ": write error: " + std::strerror(e));
  file_.commit();
}

void write_csv(const std::filesystem::path& path, const Recording& rec) {
  const Eigen::Index n = rec.size();
  CsvColumns cols;
  cols.angle_ref_deg = rec.angle_ref_deg.size() == n && n > 0;
  cols.pot_v = rec.pot_v.size() == n && n > 0;
  cols.angle_true_deg = rec.angle_true_deg.size() == n && n > 0;
  if (!cols.angle_ref_deg && !cols.pot_v) cols.angle_ref_deg = true;  // empty recording: header only
  CsvWriter w(path, cols);
  for (Eigen::Index i = 0; i < n; ++i) w.write(row_of(rec, i));
  w.commit();
}

}  // namespace pof::io
