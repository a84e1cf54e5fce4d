#include "odocal/records/record.h"

#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace odocal::records {
namespace {

using nlohmann::json;

std::optional<double> Number(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return std::nullopt;
  return j[key].get<double>();
}

json WheelSetJson(const std::optional<WheelSet>& w) {
  if (!w) return nullptr;
  return {{"left_wheel_diameter_mm", ToJson(w->left_wheel_diameter_mm)},
          {"right_wheel_diameter_mm", ToJson(w->right_wheel_diameter_mm)},
          {"track_mm", ToJson(w->track_mm)},
          {"ticks_per_rev", w->ticks_per_rev}};
}

// A parameter set as the reports write it ({left_wheel_diameter_mm: 72.0, ...}); nullopt
// unless all four are numbers.
std::optional<WheelSet> PlainWheelSet(const json& j) {
  const auto l = Number(j, "left_wheel_diameter_mm"), r = Number(j, "right_wheel_diameter_mm"),
             t = Number(j, "track_mm"), n = Number(j, "ticks_per_rev");
  if (!l || !r || !t || !n) return std::nullopt;
  WheelSet w;
  w.left_wheel_diameter_mm.value = *l;
  w.right_wheel_diameter_mm.value = *r;
  w.track_mm.value = *t;
  w.ticks_per_rev = *n;
  return w;
}

// The calibrated set's sigmas from the estimator's: D_L ∝ 2/(Ed + 1) s, D_R ∝ 2 Ed/(Ed + 1) s,
// so near Ed = 1 each diameter moves by half of Ed's relative error (and by all of the travel
// scale's); the track by Eb's relative error.
void AddSigmas(WheelSet* w, const std::optional<Estimate>& ed, const std::optional<Estimate>& eb,
               std::optional<double> relative_scale_sigma) {
  if (ed && ed->sigma) {
    const double rel = std::hypot(*ed->sigma / (ed->value + 1.0), relative_scale_sigma.value_or(0.0));
    w->left_wheel_diameter_mm.sigma = w->left_wheel_diameter_mm.value * rel;
    w->right_wheel_diameter_mm.sigma = w->right_wheel_diameter_mm.value * rel;
  }
  if (eb && eb->sigma && eb->value > 0) w->track_mm.sigma = w->track_mm.value * *eb->sigma / eb->value;
}

// The relative sigma of the distance scale UMBMark's correction used: CVRA's from straights
// (`cvra.scale.sigma_total` of the report or the station's round), when one was stated.
std::optional<double> UmbmarkScaleSigma(const json& holder) {
  const json scale = holder.is_object() && holder.contains("cvra") && holder["cvra"].is_object()
                         ? holder["cvra"].value("scale", json())
                         : json();
  const std::optional<double> total = Number(scale, "sigma_total");
  if (total && *total > 0.0) return total;
  return std::nullopt;
}

void ClearDiameterSigmas(WheelSet* w) {
  w->left_wheel_diameter_mm.sigma.reset();
  w->right_wheel_diameter_mm.sigma.reset();
}

std::optional<Estimate> EstimateFrom(const json& j, const char* value_key, const char* sigma_key) {
  const auto v = Number(j, value_key);
  if (!v) return std::nullopt;
  return Estimate{*v, Number(j, sigma_key)};
}

// A trajectory fit's parameter ({"value", "sigma", "sigma_between_runs"}: trajectory_fit's, explain's
// final.parameters'): the larger of the model's sigma and the runs' disagreement. On a real robot
// the runs disagree several times more than the model says, and the report says to trust that.
std::optional<Estimate> FitParameter(const json& params, const char* name) {
  if (!params.is_object() || !params.contains(name)) return std::nullopt;
  std::optional<Estimate> e = EstimateFrom(params[name], "value", "sigma");
  if (const auto between = Number(params[name], "sigma_between_runs"); e && between && *between > e->sigma.value_or(0.0))
    e->sigma = *between;
  return e;
}

std::vector<std::string> Strings(const json& j) {
  std::vector<std::string> out;
  if (!j.is_array()) return out;
  for (const json& s : j) {
    if (s.is_string()) out.push_back(s.get<std::string>());
    else if (s.is_object() && s.contains("effect") && s["effect"].is_string()) out.push_back(s["effect"].get<std::string>());
    else out.push_back(s.dump());
  }
  return out;
}

std::string HostName() {
  std::array<char, 256> name{};
  if (gethostname(name.data(), name.size() - 1) != 0) return "unknown";
  return name.data();
}

void FromStation(const json& report, Record* r) {
  r->status = report.value("status", "");
  r->before = PlainWheelSet(report.value("robot_params_initial", json()));
  r->after = PlainWheelSet(report.value("robot_params_final", json()));
  r->findings = Strings(report.value("findings", json::array()));
  const json iterations = report.value("iterations", json::array());
  if (iterations.empty()) return;
  const json& first = iterations.front();
  r->emax_syst_before_mm = EstimateFrom(first, "emax_syst_mm", "emax_syst_sigma_mm");
  if (first.contains("estimate") && first["estimate"].is_object()) {
    r->ed = EstimateFrom(first["estimate"], "Ed", "sigma_Ed");
    r->eb = EstimateFrom(first["estimate"], "Eb", "sigma_Eb");
  }
  // After: the last round, when it was driven with the set the robot kept.
  const json& last = iterations.back();
  if (iterations.size() > 1 && r->after && PlainWheelSet(last.value("params_used", json())))
    r->emax_syst_after_mm = EstimateFrom(last, "emax_syst_mm", "emax_syst_sigma_mm");
  // The station estimates as batch's UMBMark does: the diameters only as well as CVRA's scale
  // from straights, when the plan drove them (the first round's cvra.scale).
  const std::optional<double> scale_sigma = UmbmarkScaleSigma(first);
  if (r->after) {
    AddSigmas(&*r->after, r->ed, r->eb, scale_sigma);
    if (!scale_sigma) ClearDiameterSigmas(&*r->after);
  }
}

void FromBatch(const json& report, Record* r) {
  r->before = PlainWheelSet(report.value("nominal", json()));
  r->after = PlainWheelSet(report.value("corrected", json()));
  const std::string from = report.value("corrected_from", "");
  const json umbmark = report.value("umbmark", json());
  if (umbmark.is_object()) r->emax_syst_before_mm = EstimateFrom(umbmark, "emax_syst_mm", "sigma_emax_syst_mm");
  std::optional<double> scale_sigma;
  bool umbmark_scale_unknown = false;
  if (from == "trajectory" && report.contains("trajectory_fit")) {
    const json& fit = report["trajectory_fit"];
    r->ed = FitParameter(fit, "Ed");
    r->eb = FitParameter(fit, "Eb");
    if (const auto es = FitParameter(fit, "Es"); es && es->sigma && es->value > 0) scale_sigma = *es->sigma / es->value;
  } else if (umbmark.is_object() && umbmark.contains("estimate")) {
    r->ed = EstimateFrom(umbmark["estimate"], "Ed", "sigma_Ed");
    r->eb = EstimateFrom(umbmark["estimate"], "Eb", "sigma_Eb");
    // UMBMark keeps the believed distance scale, or takes CVRA's from straights: the diameters
    // are known only as well as that scale. No stated sigma for it (one straight, none): none
    // for the diameters either, rather than Ed's alone, which would claim the scale exact.
    scale_sigma = UmbmarkScaleSigma(report);
    umbmark_scale_unknown = !scale_sigma;
  }
  if (r->after) AddSigmas(&*r->after, r->ed, r->eb, scale_sigma);
  if (r->after && umbmark_scale_unknown) ClearDiameterSigmas(&*r->after);
  r->status = r->after ? "calibrated (" + (from.empty() ? std::string("umbmark") : from) + ")" : "measured, nothing exported";
  r->findings = Strings(report.value("findings", json::array()));
}

void FromCheck(const json& report, Record* r) {
  r->before = PlainWheelSet(report.value("nominal", json()));
  // The first set after the session's own: the calibration being checked.
  const json sets = report.value("sets", json::array());
  for (const json& s : sets)
    if (s.value("name", "") != "nominal") {
      r->after = PlainWheelSet(s.value("params", json()));
      r->status = "checked: " + s.value("name", "");
      break;
    }
  for (const json& s : report.value("summary", json::array())) {
    const auto mean = Number(s.value("final_position_error_mm", json()), "mean");
    if (!mean) continue;
    r->findings.push_back(s.value("set", "") + ": held-out final position error " +
                          (std::ostringstream() << *mean).str() + " mm (mean over the replayed runs)");
  }
}

void FromExplain(const json& report, Record* r) {
  r->before = PlainWheelSet(report.value("believed", json()));
  r->after = PlainWheelSet(report.value("corrected", json()));
  const json params = report.contains("final") ? report["final"].value("parameters", json()) : json();
  r->ed = FitParameter(params, "Ed");
  r->eb = FitParameter(params, "Eb");
  std::optional<double> scale_sigma;
  if (const auto es = FitParameter(params, "Es"); es && es->sigma && es->value > 0) scale_sigma = *es->sigma / es->value;
  if (r->after) AddSigmas(&*r->after, r->ed, r->eb, scale_sigma);
  r->findings = Strings(report.value("effects_added", json::array()));
  r->status = "explained";
}

Result<Estimate> ReadEstimate(const json& j, const std::string& key) {
  if (!j.is_object() || !j.contains("value") || !j["value"].is_number())
    return Result<Estimate>::Error(StatusCode::kBadFile, key + ": expected {value, sigma}");
  Estimate e{j["value"].get<double>(), std::nullopt};
  if (j.contains("sigma") && j["sigma"].is_number()) e.sigma = j["sigma"].get<double>();
  return Result<Estimate>::Ok(e);
}

}  // namespace

std::string_view ToString(RunKind kind) {
  switch (kind) {
    case RunKind::kStation: return "station";
    case RunKind::kBatch: return "batch";
    case RunKind::kCheck: return "check";
    case RunKind::kExplain: return "explain";
  }
  return "batch";
}

std::optional<RunKind> RunKindFromString(std::string_view text) {
  for (RunKind k : {RunKind::kStation, RunKind::kBatch, RunKind::kCheck, RunKind::kExplain})
    if (ToString(k) == text) return k;
  return std::nullopt;
}

std::string_view ToString(Verdict verdict) {
  switch (verdict) {
    case Verdict::kNone: return "none";
    case Verdict::kPass: return "pass";
    case Verdict::kFail: return "fail";
  }
  return "none";
}

Estimate WheelSet::MeanWheelDiameterMm() const {
  Estimate e{0.5 * (left_wheel_diameter_mm.value + right_wheel_diameter_mm.value), std::nullopt};
  if (left_wheel_diameter_mm.sigma && right_wheel_diameter_mm.sigma)
    e.sigma = 0.5 * std::hypot(*left_wheel_diameter_mm.sigma, *right_wheel_diameter_mm.sigma);
  return e;
}

json ToJson(const std::optional<Estimate>& e) {
  if (!e) return nullptr;
  return {{"value", e->value}, {"sigma", e->sigma ? json(*e->sigma) : json(nullptr)}};
}

json ToJson(const Record& r) {
  return {{"robot", r.robot},
          {"kind", ToString(r.kind)},
          {"time_utc", r.time_utc},
          {"host", r.host},
          {"odocal_version", r.odocal_version},
          {"digest", r.digest},
          {"folder", r.folder},
          {"params_before", WheelSetJson(r.before)},
          {"params_after", WheelSetJson(r.after)},
          {"Ed", ToJson(r.ed)},
          {"Eb", ToJson(r.eb)},
          {"emax_syst_before_mm", ToJson(r.emax_syst_before_mm)},
          {"emax_syst_after_mm", ToJson(r.emax_syst_after_mm)},
          {"distance_km", r.distance_km ? json(*r.distance_km) : json(nullptr)},
          {"findings", r.findings},
          {"verdict", ToString(r.verdict)},
          {"failed_limits", r.failed_limits},
          {"status", r.status}};
}

Result<Record> RecordFromJson(const json& j) {
  using R = Result<Record>;
  if (!j.is_object()) return R::Error(StatusCode::kBadFile, "a record is a JSON object");
  Record r;
  for (const char* key : {"robot", "kind", "time_utc", "digest"})
    if (!j.contains(key) || !j[key].is_string() || j[key].get<std::string>().empty())
      return R::Error(StatusCode::kBadFile, std::string("record: `") + key + "` missing or not a text");
  r.robot = j["robot"];
  const auto kind = RunKindFromString(j["kind"].get<std::string>());
  if (!kind) return R::Error(StatusCode::kBadFile, "record: kind `" + j["kind"].get<std::string>() +
                                                       "` is none of station, batch, check, explain");
  r.kind = *kind;
  r.time_utc = j["time_utc"];
  if (!ParseUtc(r.time_utc)) return R::Error(StatusCode::kBadFile, "record: time_utc `" + r.time_utc + "` is not ISO 8601");
  r.digest = j["digest"];
  r.host = j.value("host", "");
  r.odocal_version = j.value("odocal_version", "");
  r.folder = j.value("folder", "");
  for (auto [key, target] : {std::pair{"params_before", &r.before}, std::pair{"params_after", &r.after}}) {
    if (!j.contains(key) || j[key].is_null()) continue;
    const json& w = j[key];
    WheelSet set;
    for (auto [name, e] : {std::pair{"left_wheel_diameter_mm", &set.left_wheel_diameter_mm},
                           std::pair{"right_wheel_diameter_mm", &set.right_wheel_diameter_mm},
                           std::pair{"track_mm", &set.track_mm}}) {
      const auto v = ReadEstimate(w.value(name, json()), std::string("record: ") + key + "." + name);
      if (!v) return R::From(v);
      *e = *v;
    }
    const auto n = Number(w, "ticks_per_rev");
    if (!n) return R::Error(StatusCode::kBadFile, std::string("record: ") + key + ".ticks_per_rev missing");
    set.ticks_per_rev = *n;
    *target = set;
  }
  for (auto [key, target] : {std::pair{"Ed", &r.ed}, std::pair{"Eb", &r.eb},
                             std::pair{"emax_syst_before_mm", &r.emax_syst_before_mm},
                             std::pair{"emax_syst_after_mm", &r.emax_syst_after_mm}}) {
    if (!j.contains(key) || j[key].is_null()) continue;
    const auto v = ReadEstimate(j[key], std::string("record: ") + key);
    if (!v) return R::From(v);
    *target = *v;
  }
  if (const auto d = Number(j, "distance_km")) r.distance_km = d;
  if (j.contains("findings")) r.findings = Strings(j["findings"]);
  const std::string verdict = j.value("verdict", "none");
  if (verdict == "pass") r.verdict = Verdict::kPass;
  else if (verdict == "fail") r.verdict = Verdict::kFail;
  else if (verdict != "none") return R::Error(StatusCode::kBadFile, "record: verdict `" + verdict + "` is none of pass, fail, none");
  if (j.contains("failed_limits")) r.failed_limits = Strings(j["failed_limits"]);
  r.status = j.value("status", "");
  return R::Ok(std::move(r));
}

Result<Record> RecordFromReport(RunKind kind, const json& report, const RecordContext& context) {
  using R = Result<Record>;
  Record r;
  r.kind = kind;
  r.robot = context.robot;
  if (r.robot.empty()) r.robot = report.value("robot_id", "");
  if (r.robot.empty()) r.robot = report.value("robot_name", "");
  r.time_utc = context.time_utc.empty() ? NowUtc() : context.time_utc;
  if (!ParseUtc(r.time_utc)) return R::Error(StatusCode::kInvalidArgument, "time `" + r.time_utc + "` is not ISO 8601");
  r.host = context.host.empty() ? HostName() : context.host;
  r.odocal_version = std::string(OdocalVersion());
  r.digest = context.digest;
  r.folder = context.folder.empty() ? std::string() : std::filesystem::absolute(context.folder).lexically_normal().string();
  switch (kind) {
    case RunKind::kStation: FromStation(report, &r); break;
    case RunKind::kBatch: FromBatch(report, &r); break;
    case RunKind::kCheck: FromCheck(report, &r); break;
    case RunKind::kExplain: FromExplain(report, &r); break;
  }
  if (const auto d = Number(report, "distance_km")) r.distance_km = d;
  return R::Ok(std::move(r));
}

Status WriteRecordFile(const Record& record, const std::string& folder) {
  namespace fs = std::filesystem;
  const fs::path path = fs::path(folder) / "record.json";
  const fs::path tmp = fs::path(folder) / ".record.json.tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << ToJson(record).dump(2) << "\n";
    if (!out) return Status::Error(StatusCode::kIoError, tmp.string() + ": cannot be written");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) return Status::Error(StatusCode::kIoError, path.string() + ": " + ec.message());
  return Status::Ok();
}

Result<Record> ReadRecordFile(const std::string& folder_or_file) {
  namespace fs = std::filesystem;
  fs::path path = folder_or_file;
  if (fs::is_directory(path)) path /= "record.json";
  std::ifstream in(path);
  if (!in)
    return Result<Record>::Error(StatusCode::kNotFound,
                                 path.string() + ": no record.json (only runs made with odocal 0.2 or later leave one)");
  json j = json::parse(in, nullptr, false);
  if (j.is_discarded()) return Result<Record>::Error(StatusCode::kBadFile, path.string() + ": not JSON");
  Result<Record> r = RecordFromJson(j);
  if (!r) r.message = path.string() + ": " + r.message;
  return r;
}

std::string_view OdocalVersion() { return ODOCAL_VERSION; }

}  // namespace odocal::records
