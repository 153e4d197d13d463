#pragma once
// Whether a `pof record` manifest that says "recording" is still being recorded. A recorder that is
// killed (SIGKILL, OOM, power loss) never writes its final manifest, which then goes on saying
// "recording" for a session that is over. The manifest names its recorder (host, boot id, pid and
// the process's start time, which a reused pid does not share), so a reader on the same host can
// tell: the session is "interrupted" once that process is gone or the host rebooted. A manifest
// from before that field falls back to the log files' lock (a recorder holds an advisory lock on
// the file it writes, pof/recorder/lcmlog_durable.hpp).
//
// Readers: `pof record --check` names the state of a log's manifest; a `pof record` into a
// directory marks the interrupted manifests it finds there (mark_interrupted) before it starts, so
// the state on disk is recovered at the next start of the service.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace pof::recorder {

/// The manifest status a reader should take, and why when it is not the written one.
struct ManifestState {
  std::string status;  // the manifest's own, or "interrupted"
  std::string why;     // for "interrupted" (and a "recording" that cannot be checked from here)
};

/// This process, as the manifest's "recorder" object names it: host, boot_id, pid, start_ticks.
nlohmann::json this_recorder();

/// The state of a parsed manifest found in `dir` (its files are named relative to it).
ManifestState manifest_state(const nlohmann::json& manifest, const std::filesystem::path& dir);

/// The manifest of a log file: NAME.manifest.json for NAME.lcmlog and NAME.NNNN.lcmlog (rotation);
/// an empty path when there is none.
std::filesystem::path manifest_of_log(const std::filesystem::path& log);

/// Reads `manifest_path` (at most 64 MiB) and judges it; nullopt-like empty status when it cannot
/// be read or parsed.
ManifestState read_manifest_state(const std::filesystem::path& manifest_path);

/// Rewrites every *.manifest.json in `dir` that says "recording" but whose recorder is gone with
/// status "interrupted" (and "interrupted": {"found_utc", "why"}), atomically. Returns the manifests
/// it marked. Never throws: a manifest it cannot read or write is left as it is.
std::vector<std::filesystem::path> mark_interrupted(const std::filesystem::path& dir) noexcept;

}  // namespace pof::recorder
