#include "odocal/records/store.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "backends.h"

namespace odocal::records {

Result<std::unique_ptr<RecordStore>> OpenStore(const std::string& db, bool create) {
  if (db.empty())
    return Result<std::unique_ptr<RecordStore>>::Error(StatusCode::kInvalidArgument, "--db: empty (a file path or a postgresql:// URL)");
  if (db.rfind("postgresql://", 0) == 0 || db.rfind("postgres://", 0) == 0) return internal::OpenPostgresStore(db);
  if (db.find("://") != std::string::npos)
    return Result<std::unique_ptr<RecordStore>>::Error(
        StatusCode::kInvalidArgument, "--db " + db + ": unknown scheme (a file path for SQLite, or postgresql://...)");
  if (!create && !std::filesystem::exists(db))
    return Result<std::unique_ptr<RecordStore>>::Error(
        StatusCode::kNotFound, db + ": no record store there (station, batch, check and explain create it; --db or "
                                    "$ODOCAL_DB names another)");
  return internal::OpenSqliteStore(db);
}

std::vector<std::string> PasswordsIn(const std::string& db) {
  std::vector<std::string> secrets;
  const size_t scheme = db.find("://");
  if (scheme == std::string::npos) return secrets;
  const std::string rest = db.substr(scheme + 3);
  const std::string authority = rest.substr(0, rest.find_first_of("/?"));
  if (const size_t at = authority.rfind('@'); at != std::string::npos)
    if (const size_t colon = authority.find(':'); colon < at && at > colon + 1)
      secrets.push_back(authority.substr(colon + 1, at - colon - 1));
  if (const size_t q = db.find('?'); q != std::string::npos)
    for (size_t p = db.find("password=", q); p != std::string::npos; p = db.find("password=", p + 9)) {
      const size_t begin = p + 9, end = db.find('&', begin);
      if (end != begin) secrets.push_back(db.substr(begin, end == std::string::npos ? std::string::npos : end - begin));
    }
  return secrets;
}

std::string WithoutPassword(const std::string& db) {
  std::string out = db;
  for (const std::string& secret : PasswordsIn(db))
    for (size_t at = out.find(secret); at != std::string::npos; at = out.find(secret, at + 3)) out.replace(at, secret.size(), "***");
  return out;
}

std::string DefaultDatabase() {
  if (const char* env = std::getenv("ODOCAL_DB"); env && *env) return env;
  if (const char* xdg = std::getenv("XDG_DATA_HOME"); xdg && *xdg) return std::string(xdg) + "/odocal/records.sqlite";
  const char* home = std::getenv("HOME");
  return std::string(home && *home ? home : ".") + "/.local/share/odocal/records.sqlite";
}

std::vector<std::string> CloseNames(const std::string& name, const std::vector<std::string>& known, int count) {
  auto distance = [](const std::string& a, const std::string& b) {
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
      size_t diagonal = row[0];
      row[0] = i;
      for (size_t j = 1; j <= b.size(); ++j) {
        const size_t up = row[j];
        const bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) == std::tolower(static_cast<unsigned char>(b[j - 1]));
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (same ? 0 : 1)});
        diagonal = up;
      }
    }
    return row[b.size()];
  };
  std::vector<std::pair<size_t, std::string>> scored;
  for (const std::string& k : known) scored.push_back({distance(name, k), k});
  std::stable_sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::string> out;
  // Close: at most half the name's length edits away (a typo, a missing prefix digit).
  const size_t limit = std::max<size_t>(2, name.size() / 2);
  for (const auto& [d, k] : scored)
    if (d <= limit && static_cast<int>(out.size()) < count) out.push_back(k);
  return out;
}

}  // namespace odocal::records
