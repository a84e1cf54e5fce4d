// odocal import optiodom DIR --out SESSION_DIR: the OptiOdom data set as
// pose-log sessions (the conversion: config/optiodom.h).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <vector>

#include "cli_util.h"
#include "commands.h"
#include "odocal/config/optiodom.h"

namespace odocal::app {

namespace fs = std::filesystem;

struct ImportArgs {
  std::string dir;
  std::string out;
};

void RunImport(const ImportArgs& args) {
  const std::string name = "import optiodom";
  fs::path dir = fs::path(args.dir).lexically_normal();
  if (dir.filename().empty()) dir = dir.parent_path();  // a trailing slash
  if (!fs::is_directory(dir)) Fail(name, kExitBadInput, args.dir + ": no such directory");
  std::vector<fs::path> sets;
  if (config::IsOptiodomSet(dir)) {
    sets.push_back(dir);
  } else {
    for (const auto& entry : fs::recursive_directory_iterator(dir))
      if (entry.is_directory() && config::IsOptiodomSet(entry.path())) sets.push_back(entry.path());
    std::sort(sets.begin(), sets.end());
  }
  if (sets.empty())
    Fail(name, kExitBadInput,
         args.dir + ": no OptiOdom set found (a folder <set> holding <set>_metadata.csv)");
  const bool one = sets.size() == 1 && sets.front() == dir;
  // A folder of sets may hold the data set's other robots (omni3, omni4,
  // tricycle): named and skipped. A set that cannot be read is named with
  // why, the others are still imported, and the exit code says so.
  std::map<std::string, int> skipped;  // robot type -> sets
  std::vector<std::string> failed;
  int total = 0, imported = 0;
  for (const fs::path& set : sets) {
    const std::string category = set.parent_path().filename().string();
    const std::string type = config::OptiodomRobotType(set);
    if (!one && type != "diff") {
      ++skipped[type];
      continue;
    }
    const fs::path out = one ? fs::path(args.out) : fs::path(args.out) / category / set.filename();
    const Result<int> runs = config::ImportOptiodomSet(set, category, out);
    if (!runs) {
      if (one) Fail(name, runs.status == StatusCode::kIoError ? kExitFailure : kExitBadInput, runs.message);
      std::fprintf(stderr, "odocal import optiodom: %s/%s not imported: %s\n", category.c_str(), set.filename().c_str(),
                   runs.message.c_str());
      failed.push_back(category + "/" + set.filename().string());
      continue;
    }
    total += *runs;
    ++imported;
    std::printf("%s/%s: %d runs -> %s\n", category.c_str(), set.filename().c_str(), *runs,
                (out / "session.yaml").c_str());
  }
  for (const auto& [type, count] : skipped)
    std::printf("skipped %d set%s of type %s: not a differential-drive robot\n", count,
                count == 1 ? "" : "s", type.c_str());
  std::printf("imported %d set%s, %d runs\n", imported, imported == 1 ? "" : "s", total);
  if (!failed.empty()) {
    std::string names;
    for (const auto& f : failed) names += (names.empty() ? "" : ", ") + f;
    Fail(name, kExitBadInput,
         std::to_string(failed.size()) + " set" + (failed.size() == 1 ? "" : "s") +
             " not imported (why above): " + names);
  }
  if (imported == 0)
    Fail(name, kExitBadInput, args.dir + ": no differential-drive set among the OptiOdom sets found");
}

void RegisterImportCommand(CLI::App& app) {
  auto args = std::make_shared<ImportArgs>();
  CLI::App* cmd = app.add_subcommand("import", "Convert recorded data sets into sessions");
  cmd->require_subcommand(1);
  CLI::App* optiodom = cmd->add_subcommand(
      "optiodom", "OptiOdom sets (diff/<category>/<set>/) -> pose-log session.yaml files");
  optiodom->add_option("dir", args->dir, "One set, or any folder above sets")->required();
  optiodom->add_option("--out", args->out, "Output directory (created)")->required();
  optiodom->callback([args]() { RunImport(*args); });
}

}  // namespace odocal::app
