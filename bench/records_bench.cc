// The record store's speed (issue 27): what keeping a record adds to a run (open the store, put
// one record, close: what KeepRecord does), and how long `fleet` takes over N records (read
// every record, analyse every robot, the control charts). SQLite by default; --db URL for
// PostgreSQL.
//   ./build/bench/records_bench [--records 10000] [--robots 100] [--db postgresql://...]
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>

#include <unistd.h>

#include "odocal/records/digest.h"
#include "odocal/records/history.h"
#include "odocal/records/store.h"

namespace {

using odocal::records::Record;
using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

// Robot r's calibration k: wheels wearing by 0.03 mm a week, calibrated weekly.
Record MakeRecord(int r, int k, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, 0.01);
  Record rec;
  char name[32];
  std::snprintf(name, sizeof(name), "R-%05d", r);
  rec.robot = name;
  rec.kind = odocal::records::RunKind::kBatch;
  rec.time_utc = odocal::FormatUtc(1767225600.0 + k * 7 * 86400.0 + r * 60.0);
  rec.host = "bench";
  rec.odocal_version = "bench";
  rec.digest = odocal::records::DigestText(std::string(name) + "/" + std::to_string(k));
  rec.folder = "/runs/" + std::string(name) + "/" + std::to_string(k);
  odocal::records::WheelSet before{{72.0, {}}, {72.0, {}}, {300.0, {}}, 2048};
  const double d = 72.0 - 0.03 * k;
  odocal::records::WheelSet after{{d + noise(rng), 0.01}, {d + 0.02 + noise(rng), 0.01}, {300.5 + noise(rng), 0.05}, 2048};
  rec.before = before;
  rec.after = after;
  rec.ed = odocal::records::Estimate{1.0003 + noise(rng) * 1e-3, 1e-4};
  rec.eb = odocal::records::Estimate{1.0017 + noise(rng) * 1e-3, 2e-4};
  rec.emax_syst_before_mm = odocal::records::Estimate{5.0 + 10.0 * std::abs(noise(rng)) * 100, 0.5};
  rec.verdict = odocal::records::Verdict::kPass;
  return rec;
}

}  // namespace

int main(int argc, char** argv) {
  int records = 10000, robots = 100;
  std::string db;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--records")) records = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--robots")) robots = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--db")) db = argv[i + 1];
  }
  std::filesystem::path tmp;
  if (db.empty()) {
    tmp = std::filesystem::temp_directory_path() / ("odocal_records_bench_" + std::to_string(::getpid()));
    std::filesystem::remove_all(tmp);
    db = (tmp / "records.sqlite").string();
  }
  std::mt19937 rng(7);
  {
    auto store = odocal::records::OpenStore(db);
    if (!store) {
      std::fprintf(stderr, "%s\n", store.message.c_str());
      return 1;
    }
    const auto t0 = Clock::now();
    for (int i = 0; i < records; ++i) {
      const auto put = (*store)->Put(MakeRecord(i % robots, i / robots, rng));
      if (!put) {
        std::fprintf(stderr, "%s\n", put.message.c_str());
        return 1;
      }
    }
    std::printf("filled: %d records of %d robots in %.0f ms (%.2f ms a record, one transaction each)\n", records,
                robots, Ms(t0, Clock::now()), Ms(t0, Clock::now()) / records);
  }
  // What a run pays: open, put one, close (KeepRecord), over a store of `records`.
  double worst = 0, sum = 0;
  const int trials = 20;
  for (int t = 0; t < trials; ++t) {
    const auto a = Clock::now();
    auto store = odocal::records::OpenStore(db);
    const auto put = (*store)->Put(MakeRecord(robots + t, 0, rng));
    store.value->reset();
    const double ms = Ms(a, Clock::now());
    if (!put) return 1;
    worst = std::max(worst, ms);
    sum += ms;
  }
  std::printf("keep one record (open, put, close): mean %.1f ms, worst %.1f ms over %d runs\n", sum / trials, worst,
              trials);
  // fleet: read all, analyse.
  const auto a = Clock::now();
  auto store = odocal::records::OpenStore(db);
  const auto all = (*store)->All();
  const auto b = Clock::now();
  odocal::records::HistoryOptions options;
  options.now_s = 1767225600.0 + 120 * 7 * 86400.0;
  options.limits.emax_syst_after_mm = 2.0;
  options.limits.recalibrate_days = 30;
  const odocal::records::FleetSummary fleet = odocal::records::SummariseFleet(*all, options);
  const std::string json = odocal::records::FleetJson(fleet).dump();
  const std::string html = odocal::records::FleetHtml(fleet);
  const auto c = Clock::now();
  std::printf("fleet over %zu records, %zu robots: %.0f ms (read %.0f ms, analyse + JSON + HTML %.0f ms)\n",
              all->size(), fleet.robots.size(), Ms(a, c), Ms(a, b), Ms(b, c));
  if (!tmp.empty()) std::filesystem::remove_all(tmp);
  return 0;
}
