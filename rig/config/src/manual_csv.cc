#include "odocal/config/manual_csv.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>

#include "file_result.h"

#include "odocal/base/text.h"

namespace odocal::config {
namespace {

std::optional<double> ParseNumber(const std::string& text) {
  if (text.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

// Which unit the user wrote, for a clear message on x_cm, theta_rad, ...
std::string WrongUnitHint(const std::string& column) {
  for (const char* axis : {"x", "y"})
    if (column.rfind(std::string(axis) + "_", 0) == 0 || column == axis)
      return "; odocal reads " + std::string(axis) + "_mm (millimetres)";
  if (column.rfind("theta", 0) == 0 || column.rfind("heading", 0) == 0)
    return "; odocal reads theta_deg (degrees)";
  return "";
}

}  // namespace

namespace {

// The parser; the public function wraps its error line in a Result.
std::optional<std::vector<ManualReading>> ReadManualCsvOrError(const std::string& path,
                                                        std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot open (no such file or not readable)";
    return std::nullopt;
  }
  auto fail = [&](int line, const std::string& what) {
    *error = path + ":" + std::to_string(line) + ": " + what;
    return std::nullopt;
  };
  std::map<std::string, int> column;  // name -> index
  int n_columns = 0;
  std::vector<ManualReading> readings;
  std::string text;
  int line = 0;
  bool have_header = false;
  while (std::getline(in, text)) {
    ++line;
    if (line == 1 && text.rfind("\xEF\xBB\xBF", 0) == 0) text = text.substr(3);  // BOM
    const std::string trimmed(Trim(text));
    if (trimmed.empty() || trimmed[0] == '#') continue;
    const std::vector<std::string> cells = SplitFields(trimmed);
    if (!have_header) {
      for (size_t i = 0; i < cells.size(); ++i) {
        const std::string& c = cells[i];
        if (c != "run" && c != "x_mm" && c != "y_mm" && c != "theta_deg")
          return fail(line, "header: unknown column '" + c + "'" + WrongUnitHint(c) +
                                " (expected run,x_mm,y_mm[,theta_deg])");
        if (column.count(c)) return fail(line, "header: column '" + c + "' twice");
        column[c] = static_cast<int>(i);
      }
      for (const char* required : {"run", "x_mm", "y_mm"})
        if (!column.count(required))
          return fail(line, std::string("header: missing column '") + required +
                                "' (expected run,x_mm,y_mm[,theta_deg]; the header is required)");
      n_columns = static_cast<int>(cells.size());
      have_header = true;
      continue;
    }
    if (static_cast<int>(cells.size()) != n_columns)
      return fail(line, std::to_string(cells.size()) + " cells, the header has " +
                            std::to_string(n_columns));
    ManualReading r;
    r.line = line;
    r.run = cells[column["run"]];
    if (r.run.empty()) return fail(line, "empty run name");
    for (const char* key : {"x_mm", "y_mm"}) {
      const std::string& cell = cells[column[key]];
      const std::optional<double> v = ParseNumber(cell);
      if (!v) return fail(line, std::string(key) + ": '" + cell + "' is not a finite number");
      (std::string(key) == "x_mm" ? r.x_mm : r.y_mm) = *v;
    }
    if (column.count("theta_deg")) {
      const std::string& cell = cells[column["theta_deg"]];
      if (!cell.empty()) {
        const std::optional<double> v = ParseNumber(cell);
        if (!v) return fail(line, "theta_deg: '" + cell + "' is not a finite number");
        r.theta_deg = *v;
      }
    }
    readings.push_back(r);
  }
  if (!have_header) {
    *error = path + ": empty (expected a header run,x_mm,y_mm[,theta_deg] and one line per reading)";
    return std::nullopt;
  }
  if (readings.empty()) {
    *error = path + ": a header but no readings";
    return std::nullopt;
  }
  return readings;
}

}  // namespace

Result<std::vector<ManualReading>> ReadManualCsv(const std::string& path) {
  return ReadFileAs<std::vector<ManualReading>>(path, [&](std::string* error) { return ReadManualCsvOrError(path, error); });
}

}  // namespace odocal::config
