#include "odocal/records/limits.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "odocal/base/format.h"
#include "odocal/base/text.h"

namespace odocal::records {
namespace {

using nlohmann::json;

// The keys of the text form and of the JSON form: one list, so the two cannot drift apart.
struct Key {
  const char* name;
  std::optional<double> Limits::*field;
  bool fraction;  // ed, eb: a fraction, or a percentage with %
};
constexpr Key kKeys[] = {
    {"emax_syst_after_mm", &Limits::emax_syst_after_mm, false},
    {"emax_syst_before_mm", &Limits::emax_syst_before_mm, false},
    {"ed", &Limits::ed_tolerance, true},
    {"eb", &Limits::eb_tolerance, true},
    {"recalibrate_days", &Limits::recalibrate_days, false},
};

std::string KeyList() {
  std::string out;
  for (const Key& k : kKeys) out += (out.empty() ? "" : ", ") + std::string(k.name);
  return out;
}

const Key* FindKey(std::string_view name) {
  for (const Key& k : kKeys)
    if (name == k.name) return &k;
  return nullptr;
}

// The whole of `text` as a number, or nullopt ("2mm", "", "nan" are not).
std::optional<double> WholeNumber(std::string_view text) {
  const std::string s(text);
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

// A number for people: three significant digits, more when needed to tell it from `other`
// (2.0004 mm against a 2 mm limit must not read "2 mm > 2 mm").
std::string Short(double value, std::optional<double> other = std::nullopt) {
  std::string s;
  for (int digits = 3; digits <= 9; ++digits) {
    s = Format("%.*g", digits, value);
    if (!other || s != Format("%.*g", digits, *other)) break;
  }
  return s;
}

}  // namespace

Result<Limits> ParseLimits(const std::string& text) {
  using R = Result<Limits>;
  Limits limits;
  std::string_view rest = text;
  while (!rest.empty()) {
    const size_t comma = rest.find(',');
    const std::string_view item = Trim(rest.substr(0, comma));
    rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
    if (item.empty()) continue;  // "a=1,,b=2" or a trailing comma: nothing meant
    const size_t eq = item.find('=');
    if (eq == std::string_view::npos)
      return R::Error(StatusCode::kInvalidArgument,
                      "limits: `" + std::string(item) + "` is not KEY=VALUE (keys: " + KeyList() + ")");
    const std::string name(Trim(item.substr(0, eq)));
    std::string_view value_text = Trim(item.substr(eq + 1));
    const Key* key = FindKey(name);
    if (!key)
      return R::Error(StatusCode::kInvalidArgument, "limits: unknown key `" + name + "` (keys: " + KeyList() + ")");
    if (limits.*(key->field))
      return R::Error(StatusCode::kInvalidArgument, "limits: " + name + " is given twice");
    double scale = 1.0;
    if (key->fraction && !value_text.empty() && value_text.back() == '%') {
      value_text = Trim(value_text.substr(0, value_text.size() - 1));
      scale = 0.01;
    }
    const auto v = WholeNumber(value_text);
    if (!v || *v <= 0.0)
      return R::Error(StatusCode::kInvalidArgument,
                      "limits: " + name + "=`" + std::string(Trim(item.substr(eq + 1))) + "` is not a positive number" +
                          (key->fraction ? " (a fraction such as 0.005, or a percentage such as 0.5%)" : ""));
    limits.*(key->field) = *v * scale;
  }
  return R::Ok(limits);
}

json LimitsJson(const Limits& limits) {
  json j = json::object();
  for (const Key& k : kKeys)
    if (limits.*(k.field)) j[k.name] = *(limits.*(k.field));
  return j;
}

Result<Limits> LimitsFromJson(const json& j) {
  using R = Result<Limits>;
  Limits limits;
  if (j.is_null()) return R::Ok(limits);
  if (!j.is_object()) return R::Error(StatusCode::kBadFile, "limits: expected an object {" + KeyList() + "}");
  for (const auto& [name, value] : j.items()) {
    const Key* key = FindKey(name);
    if (!key) return R::Error(StatusCode::kBadFile, "limits: unknown key `" + name + "` (keys: " + KeyList() + ")");
    if (value.is_null()) continue;
    if (!value.is_number() || !std::isfinite(value.get<double>()) || value.get<double>() <= 0.0)
      return R::Error(StatusCode::kBadFile, "limits: " + name + " = " + value.dump() + " is not a positive number");
    limits.*(key->field) = value.get<double>();
  }
  return R::Ok(limits);
}

std::string Describe(const Limits& limits) {
  std::vector<std::string> parts;
  if (limits.emax_syst_after_mm) parts.push_back("E_max,syst after <= " + Short(*limits.emax_syst_after_mm) + " mm");
  if (limits.emax_syst_before_mm) parts.push_back("E_max,syst before <= " + Short(*limits.emax_syst_before_mm) + " mm");
  if (limits.ed_tolerance) parts.push_back("|Ed - 1| <= " + Short(*limits.ed_tolerance * 100.0) + " %");
  if (limits.eb_tolerance) parts.push_back("|Eb - 1| <= " + Short(*limits.eb_tolerance * 100.0) + " %");
  if (limits.recalibrate_days) parts.push_back("recalibrate every " + Short(*limits.recalibrate_days) + " days");
  if (parts.empty()) return "no limits";
  std::string out;
  for (const std::string& p : parts) out += (out.empty() ? "" : ", ") + p;
  return out;
}

void Judge(const Limits& limits, Record* record) {
  record->failed_limits.clear();
  // recalibrate_days says when to look again, not whether the robot is good: no verdict from it.
  if (!limits.emax_syst_after_mm && !limits.emax_syst_before_mm && !limits.ed_tolerance && !limits.eb_tolerance) {
    record->verdict = Verdict::kNone;
    return;
  }
  auto check_mm = [&](const char* name, const std::optional<double>& limit, const std::optional<Estimate>& found) {
    if (!limit) return;
    if (!found) {
      record->failed_limits.push_back(std::string(name) + " not measured (limit " + Short(*limit) + " mm)");
    } else if (found->value > *limit) {
      record->failed_limits.push_back(std::string(name) + " " + Short(found->value, *limit) + " mm > " + Short(*limit) + " mm");
    }
  };
  auto check_ratio = [&](const char* name, const std::optional<double>& tolerance, const std::optional<Estimate>& found) {
    if (!tolerance) return;
    if (!found) {
      record->failed_limits.push_back(std::string(name) + " not measured (limit " + Short(*tolerance * 100.0) + " %)");
      return;
    }
    const double off = std::fabs(found->value - 1.0);
    if (off > *tolerance)
      record->failed_limits.push_back(std::string(name) + " " + Short(off * 100.0, *tolerance * 100.0) + " % > " +
                                      Short(*tolerance * 100.0) + " %");
  };
  check_mm("E_max,syst after", limits.emax_syst_after_mm, record->emax_syst_after_mm);
  check_mm("E_max,syst before", limits.emax_syst_before_mm, record->emax_syst_before_mm);
  check_ratio("|Ed - 1|", limits.ed_tolerance, record->ed);
  check_ratio("|Eb - 1|", limits.eb_tolerance, record->eb);
  record->verdict = record->failed_limits.empty() ? Verdict::kPass : Verdict::kFail;
}

}  // namespace odocal::records
