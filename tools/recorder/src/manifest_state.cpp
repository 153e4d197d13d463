// Interrupted recording sessions: see pof/recorder/manifest_state.hpp.
#include "pof/recorder/manifest_state.hpp"

#include <unistd.h>

#include <fstream>
#include <iterator>
#include <sstream>

#include "pof/io/atomic_file.hpp"
#include "pof/lcm/utime.hpp"
#include "pof/recorder/lcmlog_durable.hpp"

namespace pof::recorder {
namespace fs = std::filesystem;
namespace {

constexpr std::uintmax_t kMaxManifestBytes = 64u << 20;

std::string read_small(const fs::path& p) {
  std::ifstream f(p);
  std::string s;
  std::getline(f, s);
  return s;
}

std::string host_name() {
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  return host;
}

std::string boot_id() { return read_small("/proc/sys/kernel/random/boot_id"); }

// Field 22 of /proc/PID/stat (proc(5)): the start time in clock ticks after boot; 0 when the
// process does not exist. The fields are counted after the ')' that ends the command name.
std::uint64_t start_ticks(long pid) {
  const std::string stat = read_small("/proc/" + std::to_string(pid) + "/stat");
  const auto close = stat.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream in(stat.substr(close + 1));
  std::string field;
  for (int i = 3; i <= 22; ++i) {
    if (!(in >> field)) return 0;
    if (i == 3 && (field == "Z" || field == "X")) return 0;  // exited, not yet reaped
  }
  try {
    return std::stoull(field);
  } catch (...) {
    return 0;
  }
}

}  // namespace

nlohmann::json this_recorder() {
  const long pid = static_cast<long>(::getpid());
  return {{"host", host_name()}, {"boot_id", boot_id()}, {"pid", pid}, {"start_ticks", start_ticks(pid)}};
}

ManifestState manifest_state(const nlohmann::json& m, const fs::path& dir) {
  ManifestState st;
  st.status = m.is_object() && m.contains("status") && m["status"].is_string() ? m["status"].get<std::string>() : "";
  if (st.status != "recording") return st;
  const auto interrupted = [&](std::string why) {
    st.status = "interrupted";
    st.why = std::move(why);
    return st;
  };
  if (const auto r = m.find("recorder"); r != m.end() && r->is_object()) {
    const std::string host = r->value("host", "");
    const long pid = r->value("pid", 0L);
    if (host != host_name()) {
      st.why = "recorded on host '" + host + "': its recorder cannot be checked from here";
      return st;
    }
    if (r->value("boot_id", "") != boot_id()) return interrupted("this host restarted since (another boot id)");
    const std::uint64_t ticks = r->value("start_ticks", std::uint64_t{0});
    if (pid <= 0 || ticks == 0 || start_ticks(pid) != ticks)
      return interrupted("its recorder (pid " + std::to_string(pid) + ") is gone: killed or crashed");
    return st;
  }
  // A manifest without "recorder": alive while a recorder holds one of its files.
  if (const auto f = m.find("files"); f != m.end() && f->is_array()) {
    for (const auto& e : *f) {
      if (e.is_object() && e.contains("name") && e["name"].is_string() &&
          log_is_being_written(dir / e["name"].get<std::string>()))
        return st;
    }
  }
  return interrupted("no recorder holds its log files");
}

fs::path manifest_of_log(const fs::path& log) {
  std::string stem = log.filename().string();
  if (stem.size() > 7 && stem.ends_with(".lcmlog")) stem.resize(stem.size() - 7);
  // NAME.NNNN (a rotated file): the session's name is NAME.
  if (const auto dot = stem.rfind('.'); dot != std::string::npos && stem.size() - dot == 5 &&
                                        stem.find_first_not_of("0123456789", dot + 1) == std::string::npos) {
    const fs::path rotated = log.parent_path() / (stem.substr(0, dot) + ".manifest.json");
    if (fs::exists(rotated)) return rotated;
  }
  const fs::path plain = log.parent_path() / (stem + ".manifest.json");
  return fs::exists(plain) ? plain : fs::path{};
}

ManifestState read_manifest_state(const fs::path& manifest_path) {
  std::error_code ec;
  const auto size = fs::file_size(manifest_path, ec);
  if (ec || size > kMaxManifestBytes) return {};
  std::ifstream f(manifest_path);
  const nlohmann::json m = nlohmann::json::parse(f, nullptr, /*allow_exceptions=*/false);
  if (m.is_discarded()) return {};
  return manifest_state(m, manifest_path.parent_path());
}

std::vector<fs::path> mark_interrupted(const fs::path& dir) noexcept {
  std::vector<fs::path> marked;
  try {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      const fs::path& p = e.path();
      const std::string name = p.filename().string();
      if (!name.ends_with(".manifest.json") || !e.is_regular_file(ec)) continue;
      if (e.file_size(ec) > kMaxManifestBytes || ec) continue;
      std::ifstream f(p);
      nlohmann::json m = nlohmann::json::parse(f, nullptr, /*allow_exceptions=*/false);
      if (m.is_discarded()) continue;
      if (!m.is_object() || m.value("status", "") != "recording") continue;  // final, or marked before
      const ManifestState st = manifest_state(m, dir);
      if (st.status != "interrupted") continue;
      m["status"] = "interrupted";
      m["interrupted"] = {{"found_utc", lcmutil::iso_utc(lcmutil::now_utime())}, {"why", st.why}};
      try {
        io::write_file_atomic(p, m.dump(2) + "\n");
        marked.push_back(p);
      } catch (...) {
      }
    }
  } catch (...) {
  }
  return marked;
}

}  // namespace pof::recorder
