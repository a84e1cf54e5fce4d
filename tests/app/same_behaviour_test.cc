// Same behaviour: every case of tests/app/golden/commands.txt is run with the real binary and
// what it writes is compared with the snapshot recorded before a change (record.sh). Text is
// compared token by token: words exactly, numbers within 1e-12 relative (threads may reorder
// sums). Files too big to keep are compared by the SHA-256 of their normalised text.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

namespace fs = std::filesystem;
using test_util::RunCommand;
using test_util::Slurp;

// Fixed at build time: the case names are read when the tests are listed, before any
// environment is set.
std::string GoldenDir() { return ODOCAL_GOLDEN_DIR; }

// NAME -> the odocal argument lines of that case, in order.
std::map<std::string, std::vector<std::string>> ReadCases() {
  std::map<std::string, std::vector<std::string>> cases;
  std::istringstream in(Slurp(GoldenDir() + "/commands.txt"));
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const auto tab = line.find('\t');
    if (tab == std::string::npos) continue;
    cases[line.substr(0, tab)].push_back(line.substr(tab + 1));
  }
  return cases;
}

std::string ReplaceAll(std::string s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) {
    s.replace(at, from.size(), to);
  }
  return s;
}

// Text split into numbers and the words between them.
struct Tokens {
  std::vector<std::string> words;  // words[i] precedes numbers[i]; one more word than numbers
  std::vector<double> numbers;
};

Tokens Tokenize(const std::string& text) {
  static const std::regex kNumber(R"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)");
  Tokens t;
  auto begin = std::sregex_iterator(text.begin(), text.end(), kNumber);
  size_t last = 0;
  for (auto it = begin; it != std::sregex_iterator(); ++it) {
    t.words.push_back(text.substr(last, it->position() - last));
    t.numbers.push_back(std::strtod(it->str().c_str(), nullptr));
    last = it->position() + it->length();
  }
  t.words.push_back(text.substr(last));
  return t;
}

// "" when the texts agree, else where they first differ.
std::string CompareText(const std::string& expected, const std::string& actual) {
  const Tokens e = Tokenize(expected), a = Tokenize(actual);
  const size_t n = std::min(e.numbers.size(), a.numbers.size());
  for (size_t i = 0; i <= n; ++i) {
    if (e.words[i] != a.words[i]) {
      return "text differs after number " + std::to_string(i) + ": expected \"" +
             e.words[i].substr(0, 80) + "\", got \"" + a.words[i].substr(0, 80) + "\"";
    }
    if (i == n) break;
    const double tol = 1e-12 * std::max(std::abs(e.numbers[i]), std::abs(a.numbers[i])) + 1e-12;
    if (!(std::abs(e.numbers[i] - a.numbers[i]) <= tol)) {
      std::ostringstream msg;
      msg.precision(17);
      msg << "number " << i << " after \"" << e.words[i].substr(0, 60) << "\": expected "
          << e.numbers[i] << ", got " << a.numbers[i];
      return msg.str();
    }
  }
  if (e.numbers.size() != a.numbers.size()) {
    return "expected " + std::to_string(e.numbers.size()) + " numbers, got " +
           std::to_string(a.numbers.size());
  }
  return "";
}

std::string Sha256(const std::string& text, const std::string& scratch) {
  {
    std::ofstream(scratch, std::ios::binary) << text;
  }
  const auto r = RunCommand("sha256sum " + scratch);
  return r.out.substr(0, 64);
}

class SameBehaviour : public ::testing::TestWithParam<std::string> {};

TEST_P(SameBehaviour, OutputsMatchTheRecordedSnapshot) {
  const std::string name = GetParam();
  const auto cases = ReadCases();
  ASSERT_TRUE(cases.count(name)) << name;
  const std::string out = test_util::MakeTempDir("odocal_same_" + name + "_");
  const std::string src = test_util::SourceDir();

  // Run each step; stdout of step k is kept as stdout.k.txt, as record.sh does.
  int step = 0;
  for (const std::string& args : cases.at(name)) {
    const std::string line = ReplaceAll(ReplaceAll(args, "@OUT", out), "@SRC", src);
    const auto r = RunCommand("cd " + out + " && " + test_util::Odocal(line));
    ASSERT_EQ(r.exit_code, 0) << line << "\n" << r.err;
    std::ofstream(out + "/stdout." + std::to_string(step++) + ".txt") << r.out;
  }
  auto normalise = [&](const std::string& text) {
    return ReplaceAll(ReplaceAll(text, out, "@OUT"), src, "@SRC");
  };

  // Every file kept whole in the snapshot.
  const fs::path golden = GoldenDir() + "/" + name;
  int compared = 0;
  for (const auto& entry : fs::recursive_directory_iterator(golden)) {
    if (!entry.is_regular_file() || entry.path().filename() == "digests.txt") continue;
    const fs::path rel = fs::relative(entry.path(), golden);
    const fs::path produced = fs::path(out) / rel;
    ASSERT_TRUE(fs::exists(produced)) << name << ": " << rel << " was not written";
    EXPECT_EQ(CompareText(Slurp(entry.path()), normalise(Slurp(produced))), "")
        << name << ": " << rel;
    ++compared;
  }
  // Files kept by digest.
  std::istringstream digests(Slurp(golden / "digests.txt"));
  std::string hash, rel;
  while (digests >> hash >> rel) {
    const fs::path produced = fs::path(out) / rel;
    ASSERT_TRUE(fs::exists(produced)) << name << ": " << rel << " was not written";
    EXPECT_EQ(Sha256(normalise(Slurp(produced)), out + "/.digest_scratch"), hash)
        << name << ": " << rel << " differs from the snapshot";
    ++compared;
  }
  EXPECT_GT(compared, 0) << name << ": the snapshot is empty";

  // Nothing new appeared that the snapshot does not know of (a renamed output is a change).
  for (const auto& entry : fs::recursive_directory_iterator(out)) {
    const std::string ext = entry.path().extension();
    // record.json says when and where the run was (docs/formats.md, "Records"); its numbers
    // are report.json's, compared above.
    if (!entry.is_regular_file() || entry.path().filename() == "record.json" ||
        (ext != ".json" && ext != ".yaml" && ext != ".csv" && ext != ".txt" && ext != ".html")) {
      continue;
    }
    const fs::path r = fs::relative(entry.path(), out);
    const std::string listed = Slurp(golden / "digests.txt");
    EXPECT_TRUE(fs::exists(golden / r) || listed.find("  " + r.string() + "\n") != std::string::npos)
        << name << ": " << r << " is new";
  }
}

std::vector<std::string> CaseNames() {
  std::vector<std::string> names;
  for (const auto& [name, steps] : ReadCases()) names.push_back(name);
  return names;
}

INSTANTIATE_TEST_SUITE_P(Snapshot, SameBehaviour, ::testing::ValuesIn(CaseNames()),
                         [](const auto& info) { return info.param; });

TEST(SameBehaviourCompare, NumbersWithinToleranceWordsExactly) {
  EXPECT_EQ(CompareText("a 1.0 b", "a 1.0000000000000002 b"), "");
  EXPECT_THAT(CompareText("a 1.0 b", "a 1.000001 b"), ::testing::HasSubstr("number 0"));
  EXPECT_THAT(CompareText("a 1 b", "a 1 c"), ::testing::HasSubstr("text differs"));
  EXPECT_THAT(CompareText("a 1 b 2", "a 1 b"), ::testing::HasSubstr("text differs"));
  EXPECT_EQ(CompareText("x=-3e-5,", "x=-3.0e-5,"), "");
}

}  // namespace
}  // namespace odocal
