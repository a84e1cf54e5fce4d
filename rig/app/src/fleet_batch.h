// batch over many robots' sessions: one calibration per session, each in its own folder and
// record, the sessions split over machines by --shard I/N with no coordinator (each shard
// writes its own summary; the shared record store is where they meet). docs/fleet.md.
#ifndef ODOCAL_APP_FLEET_BATCH_H_
#define ODOCAL_APP_FLEET_BATCH_H_

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace odocal::app {

struct FleetSession {
  int index = 0;       // in the whole list (before sharding)
  std::string path;    // the session file
  std::string robot;   // robot=ID from the list file; empty: the session's robot.id
  std::string folder;  // OUT/<folder>: the session's directory name (or file stem), unique in the list
};

struct FleetBatch {
  std::vector<FleetSession> sessions;  // this shard's
  int total = 0;                       // in the whole list
  int shard = 0, shards = 1;
};

// nullopt when `positional` are session files to pool (no --each, --list or --shard, no
// directory). Otherwise the sessions: positional files and directories (every session.yaml
// under them, sorted) then the list file's lines; this shard's share. Bad input fails `command`
// with exit 2 naming the file, the line or the option.
std::optional<FleetBatch> FleetBatchOrFail(const std::string& command, const std::vector<std::string>& positional,
                                           const std::string& list, const std::string& shard, bool each);

// Runs `one` for each session into OUT/<folder>, going on past a session that fails; writes
// OUT/shard-I-of-N.json (each session's folder, robot and exit code) and prints one line per
// session. Returns 0, 1 when any session failed, or 6 when none failed and some were outside limits.
int RunFleetBatch(const std::string& command, const FleetBatch& fleet, const std::string& out,
                  const std::function<int(const FleetSession&, const std::string& out)>& one);

}  // namespace odocal::app

#endif  // ODOCAL_APP_FLEET_BATCH_H_
