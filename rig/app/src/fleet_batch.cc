#include "fleet_batch.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "odocal/config/files.h"
#include "record_util.h"

namespace odocal::app {
namespace {

namespace fs = std::filesystem;

std::string FolderName(const std::string& session) {
  const fs::path p(session);
  if (p.filename() == "session.yaml" && p.has_parent_path()) {
    const std::string dir = fs::absolute(p).parent_path().filename().string();
    if (!dir.empty()) return dir;
  }
  return p.stem().string();
}

}  // namespace

std::optional<FleetBatch> FleetBatchOrFail(const std::string& command, const std::vector<std::string>& positional,
                                           const std::string& list, const std::string& shard, bool each) {
  bool any_directory = false;
  for (const std::string& p : positional) any_directory = any_directory || fs::is_directory(p);
  if (!each && list.empty() && shard.empty() && !any_directory) return std::nullopt;

  FleetBatch fleet;
  if (!shard.empty()) {
    int i = -1, n = 0;
    char tail = 0;
    if (std::sscanf(shard.c_str(), "%d/%d%c", &i, &n, &tail) != 2 || n < 1 || i < 0 || i >= n)
      Fail(command, kExitBadInput, "--shard " + shard + ": expected I/N with 0 <= I < N (e.g. 0/4)");
    fleet.shard = i;
    fleet.shards = n;
  }
  std::vector<FleetSession> all;
  for (const std::string& p : positional) {
    if (!fs::is_directory(p)) {
      if (!fs::exists(p)) Fail(command, kExitBadInput, p + ": no such file or directory");
      all.push_back({0, p, "", ""});
      continue;
    }
    std::vector<std::string> found;
    for (const fs::directory_entry& e : fs::recursive_directory_iterator(p))
      if (e.is_regular_file() && e.path().filename() == "session.yaml") found.push_back(e.path().string());
    if (found.empty()) Fail(command, kExitBadInput, p + ": no session.yaml in it or below it");
    std::sort(found.begin(), found.end());
    for (const std::string& f : found) all.push_back({0, f, "", ""});
  }
  if (!list.empty()) {
    std::ifstream in(list);
    if (!in) Fail(command, kExitBadInput, "--list " + list + ": cannot be read");
    const fs::path base = fs::path(list).parent_path();
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
      if (const size_t hash = line.find('#'); hash != std::string::npos) line.erase(hash);
      std::istringstream words(line);
      std::string path, word;
      if (!(words >> path)) continue;
      FleetSession s{0, (fs::path(path).is_absolute() ? fs::path(path) : base / path).string(), "", ""};
      while (words >> word) {
        if (word.rfind("robot=", 0) != 0 || word.size() == 6)
          Fail(command, kExitBadInput, list + ":" + std::to_string(number) + ": `" + word + "`: expected robot=ID after the session");
        s.robot = word.substr(6);
      }
      if (!fs::is_regular_file(s.path))
        Fail(command, kExitBadInput, list + ":" + std::to_string(number) + ": " + s.path + ": no such session file");
      all.push_back(s);
    }
  }
  if (all.empty()) Fail(command, kExitBadInput, "no sessions given (files, a directory of sessions or --list FILE)");
  std::map<std::string, int> used;
  for (size_t k = 0; k < all.size(); ++k) {
    all[k].index = static_cast<int>(k);
    std::string name = FolderName(all[k].path);
    if (const int n = used[name]++; n > 0) name += "-" + std::to_string(n + 1);
    all[k].folder = name;
  }
  fleet.total = static_cast<int>(all.size());
  for (const FleetSession& s : all)
    if (s.index % fleet.shards == fleet.shard) fleet.sessions.push_back(s);
  return fleet;
}

int RunFleetBatch(const std::string& command, const FleetBatch& fleet, const std::string& out,
                  const std::function<int(const FleetSession&, const std::string& out)>& one) {
  if (const Status e = config::EnsureDirectory(out); !e) Fail(command, kExitFailure, e.message);
  nlohmann::json summary = {{"shard", fleet.shard}, {"shards", fleet.shards}, {"sessions_in_list", fleet.total},
                            {"sessions", nlohmann::json::array()}};
  int failed = 0, outside = 0;
  for (const FleetSession& s : fleet.sessions) {
    const std::string folder = out + "/" + s.folder;
    std::printf("== %s (%d of %d, shard %d/%d) -> %s\n", s.path.c_str(), s.index + 1, fleet.total, fleet.shard,
                fleet.shards, folder.c_str());
    std::fflush(stdout);
    const auto start = std::chrono::steady_clock::now();
    int code = 0;
    try {
      code = one(s, folder);
    } catch (const CLI::RuntimeError& e) {
      code = e.get_exit_code();  // the session's own line is on stderr already
    }
    failed += code != 0 && code != kExitOutsideLimits;
    outside += code == kExitOutsideLimits;
    summary["sessions"].push_back(
        {{"session", s.path}, {"robot", s.robot.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.robot)},
         {"out", folder}, {"exit_code", code},
         {"wall_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}});
  }
  const std::string file =
      out + "/shard-" + std::to_string(fleet.shard) + "-of-" + std::to_string(fleet.shards) + ".json";
  if (const Status e = config::WriteFileAtomically(file, summary.dump(2) + "\n"); !e)
    Fail(command, kExitFailure, e.message);
  std::printf("%s: %zu session(s), %d failed, %d outside the limits; %s\n", command.c_str(), fleet.sessions.size(),
              failed, outside, file.c_str());
  return failed > 0 ? kExitFailure : outside > 0 ? kExitOutsideLimits : 0;
}

}  // namespace odocal::app
