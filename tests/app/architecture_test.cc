// The architecture as written down agrees with the build: the module graph CMake links
// (build/module_graph.txt, written at configure time) against
//   - what each module's sources really include (a module links what it includes, no more),
//   - README's layout table and docs/architecture.md's module table (so they cannot drift),
//   - the rules that make the layering: calibration is pure math, dependencies point upward.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

namespace fs = std::filesystem;
using Graph = std::map<std::string, std::set<std::string>>;

// Where each module's code lives.
const std::map<std::string, std::string>& ModuleDirs() {
  static const std::map<std::string, std::string> dirs = {
      {"base", "base"},           {"calibration", "calibration"}, {"robot_link", "robot_link"},
      {"sim", "sim"},             {"vision", "vision"},           {"records", "rig/records"},
      {"config", "rig/config"},
      {"media", "rig/media"},     {"measure", "rig/measure"},     {"report", "rig/report"},
      {"live", "rig/live"},       {"simulation", "rig/simulation"}, {"station", "rig/station"},
      {"app", "rig/app"}};
  return dirs;
}

Graph ReadGraph() {
  Graph g;
  std::istringstream in(test_util::Slurp(ODOCAL_MODULE_GRAPH));
  std::string line;
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::istringstream deps(line.substr(colon + 1));
    std::set<std::string>& d = g[line.substr(0, colon)];
    for (std::string m; deps >> m;) d.insert(m);
  }
  return g;
}

// The first group of every match of `pattern` in a folder's C and C++ sources.
std::set<std::string> MatchesInSources(const std::string& dir, const std::regex& pattern) {
  std::set<std::string> found;
  for (const auto& e : fs::recursive_directory_iterator(test_util::SourceDir() + "/" + dir)) {
    const std::string ext = e.path().extension();
    if (!e.is_regular_file() || (ext != ".h" && ext != ".cc" && ext != ".c")) continue;
    const std::string text = test_util::Slurp(e.path());
    for (auto it = std::sregex_iterator(text.begin(), text.end(), pattern); it != std::sregex_iterator(); ++it)
      found.insert((*it)[1]);
  }
  return found;
}

// The odocal modules a folder's sources include ("odocal/<module>/...").
std::set<std::string> IncludedModules(const std::string& dir, std::set<std::string>* third_party) {
  static const std::regex kOdocal(R"re(#include\s+"odocal/(\w+)/)re");
  static const std::regex kAngle(R"re(#include\s+<([\w\-]+)[/.>])re");
  if (third_party) third_party->merge(MatchesInSources(dir, kAngle));
  return MatchesInSources(dir, kOdocal);
}

// Rows of a markdown table whose first cell is a module in backticks: module -> the
// comma-separated names of the cell headed "uses".
std::map<std::string, std::set<std::string>> ModuleTable(const std::string& path) {
  std::map<std::string, std::set<std::string>> rows;
  std::istringstream in(test_util::Slurp(test_util::SourceDir() + "/" + path));
  std::string line;
  int uses_column = -1;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] != '|') {
      uses_column = line.empty() ? uses_column : -1;
      continue;
    }
    std::vector<std::string> cells;
    std::stringstream cs(line.substr(1));
    for (std::string c; std::getline(cs, c, '|');) {
      c.erase(0, c.find_first_not_of(' '));
      c.erase(c.find_last_not_of(' ') + 1);
      cells.push_back(c);
    }
    if (uses_column < 0) {
      for (size_t i = 0; i < cells.size(); ++i)
        if (cells[i] == "uses") uses_column = static_cast<int>(i);
      continue;
    }
    static const std::regex kName(R"(^`(\w+)`)");
    std::smatch m;
    if (static_cast<int>(cells.size()) <= uses_column || !std::regex_search(cells[0], m, kName)) continue;
    std::set<std::string>& deps = rows[m[1]];
    std::stringstream ds(cells[uses_column]);
    for (std::string d; std::getline(ds, d, ',');) {
      d.erase(0, d.find_first_not_of(" `"));
      d.erase(d.find_last_not_of(" `") + 1);
      if (!d.empty() && d != "—") deps.insert(d);
    }
  }
  return rows;
}

std::string Join(const std::set<std::string>& s) {
  std::string out;
  for (const std::string& x : s) out += (out.empty() ? "" : ", ") + x;
  return out.empty() ? "—" : out;
}

TEST(Architecture, EveryModuleLinksExactlyTheModulesItIncludes) {
  const Graph graph = ReadGraph();
  ASSERT_EQ(graph.size(), ModuleDirs().size()) << "module_graph.txt and ModuleDirs() disagree";
  for (const auto& [module, dir] : ModuleDirs()) {
    ASSERT_TRUE(graph.count(module)) << module << " is not in the build's module graph";
    std::set<std::string> included = IncludedModules(dir, nullptr);
    included.erase(module);
    included.erase("test_util");
    EXPECT_EQ(Join(included), Join(graph.at(module)))
        << module << " (" << dir << "): the modules its code includes (left) and links (right)";
  }
}

TEST(Architecture, DependenciesPointUpTheLayers) {
  // The order of CMakeLists.txt and docs/architecture.md: a module uses only those before it.
  const std::vector<std::string> order = {"base",   "calibration", "robot_link", "sim",
                                          "vision", "records",     "config",     "media",      "measure",
                                          "report", "live",        "simulation", "station",
                                          "app"};
  const Graph graph = ReadGraph();
  for (size_t i = 0; i < order.size(); ++i) {
    for (const std::string& dep : graph.at(order[i])) {
      const auto at = std::find(order.begin(), order.end(), dep) - order.begin();
      EXPECT_LT(static_cast<size_t>(at), i) << order[i] << " uses " << dep << ", which comes after it";
    }
  }
}

TEST(Architecture, CalibrationIsPureMath) {
  std::set<std::string> third_party;
  const std::set<std::string> used = IncludedModules("calibration", &third_party);
  EXPECT_THAT(used, ::testing::IsSubsetOf(std::set<std::string>{"base", "calibration"}));
  for (const char* io : {"opencv2", "fstream", "filesystem", "yaml-cpp", "nlohmann", "iostream"})
    EXPECT_FALSE(third_party.count(io)) << "calibration includes <" << io << ">";
  // And vision reads no files and starts no process.
  third_party.clear();
  IncludedModules("vision", &third_party);
  for (const char* io : {"fstream", "spawn", "yaml-cpp"})
    EXPECT_FALSE(third_party.count(io)) << "vision includes <" << io << ">";
}

// The system headers a module's sources include, whole ("opencv2/videoio.hpp").
std::set<std::string> IncludedHeaders(const std::string& dir) {
  static const std::regex kAngle(R"re(#include\s+<([^>]+)>)re");
  return MatchesInSources(dir, kAngle);
}

// docs/architecture.md, "I/O": who parses the files people write, who touches video and
// cameras, who opens a port, a database, a serial line or a process. Each kind of I/O is
// reached through headers only the modules named there include.
TEST(Architecture, EachKindOfIoLivesInTheModulesTheDocsName) {
  struct Rule {
    const char* what;
    std::vector<std::string> header_prefixes;
    std::set<std::string> modules;
  };
  const std::vector<Rule> rules = {
      {"YAML files people write (config parses them)", {"yaml-cpp/"}, {"config"}},
      {"video files, images and cameras (media, OpenCV's codecs as its plugin)",
       {"opencv2/videoio", "opencv2/imgcodecs"},
       {"media"}},
      {"an HTTP port (live)", {"httplib"}, {"live"}},
      {"a database (records)", {"sqlite3.h", "libpq-fe.h"}, {"records"}},
      {"a serial line (robot_link)", {"termios.h"}, {"robot_link"}},
      {"a child process (media's ffmpeg, station's external driver)", {"spawn.h"}, {"media", "station"}},
  };
  for (const auto& [module, dir] : ModuleDirs()) {
    const std::set<std::string> headers = IncludedHeaders(dir);
    for (const Rule& rule : rules) {
      if (rule.modules.count(module)) continue;
      for (const std::string& h : headers)
        for (const std::string& prefix : rule.header_prefixes)
          EXPECT_NE(h.rfind(prefix, 0), 0u)
              << module << " (" << dir << ") includes <" << h << ">: " << rule.what << " belongs to "
              << *rule.modules.begin() << (rule.modules.size() > 1 ? " and the others named" : "");
    }
  }
}

// docs/architecture.md, "Errors": a public fallible function returns Result/Status, or a
// struct of the same shape (StatusCode status, message, ok()); none returns its error through
// a std::string* (options' IsValid aside), and no struct keeps a bool ok of its own.
TEST(Architecture, PublicHeadersSpeakTheOneErrorVocabulary) {
  static const std::regex kBoolOk(R"re(\n([ \t]*bool ok\s*(=|;|\{)[^\n]*))re");
  static const std::regex kStringOut(
      R"re(\n([^\n]*std::string\s*\*\s*(why|error|err|error_message|message|reason)\b[^\n]*))re");
  for (const auto& [module, dir] : ModuleDirs()) {
    if (!fs::exists(test_util::SourceDir() + "/" + dir + "/include")) continue;
    for (const std::string& line : MatchesInSources(dir + "/include", kBoolOk))
      ADD_FAILURE() << module << ": a struct keeps a bool ok (use StatusCode status and ok()): " << line;
    for (const std::string& line : MatchesInSources(dir + "/include", kStringOut))
      EXPECT_NE(line.find("IsValid("), std::string::npos)
          << module << ": an error through a std::string* (return Result/Status): " << line;
  }
}

TEST(Architecture, ReadmeAndArchitectureDocTablesMatchTheBuild) {
  const Graph graph = ReadGraph();
  for (const char* doc : {"README.md", "docs/architecture.md"}) {
    const auto table = ModuleTable(doc);
    EXPECT_EQ(table.size(), graph.size()) << doc << ": one row per module";
    for (const auto& [module, deps] : graph) {
      ASSERT_TRUE(table.count(module)) << doc << " has no row for `" << module << "`";
      EXPECT_EQ(Join(table.at(module)), Join(deps))
          << doc << ", row `" << module << "`: the `uses` cell (left) and the build (right)";
    }
  }
}

}  // namespace
}  // namespace odocal
