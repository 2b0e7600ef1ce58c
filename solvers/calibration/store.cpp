#include "solvers/calibration/store.h"

#include <sqlite3.h>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/common/error.h"

namespace machplan::calibration {
namespace {

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS sessions (
  id INTEGER PRIMARY KEY,
  machine TEXT NOT NULL,
  log_path TEXT NOT NULL,
  log_hash TEXT NOT NULL,
  who TEXT NOT NULL,
  added_utc TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS fits (
  id INTEGER PRIMARY KEY,
  session_id INTEGER NOT NULL REFERENCES sessions(id),
  machine TEXT NOT NULL,
  status TEXT NOT NULL,
  fit_json TEXT NOT NULL,
  who TEXT NOT NULL,
  created_utc TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS active (
  machine TEXT PRIMARY KEY,
  fit_id INTEGER NOT NULL REFERENCES fits(id)
);
)sql";

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

struct CalibrationStore::Db {
  sqlite3* h = nullptr;
  ~Db() {
    if (h) sqlite3_close(h);
  }
};

namespace {

struct Stmt {
  sqlite3_stmt* s = nullptr;
  Stmt(sqlite3* db, const char* sql, const std::string& where) {
    if (sqlite3_prepare_v2(db, sql, -1, &s, nullptr) != SQLITE_OK)
      throw InputError(where, 0, fmt::format("not a calibration store: {}", sqlite3_errmsg(db)));
  }
  ~Stmt() { sqlite3_finalize(s); }
  void bind(int i, const std::string& v) { sqlite3_bind_text(s, i, v.c_str(), -1, SQLITE_TRANSIENT); }
  void bind(int i, std::int64_t v) { sqlite3_bind_int64(s, i, v); }
  std::string text(int i) const {
    const auto* p = sqlite3_column_text(s, i);
    return p ? reinterpret_cast<const char*>(p) : "";
  }
};

void exec(sqlite3* db, const char* sql, const std::string& where) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "unknown error";
    sqlite3_free(err);
    throw InputError(where, 0, fmt::format("calibration store: {}", msg));
  }
}

void fill_from_json(StoredFit& f) {
  const auto j = nlohmann::json::parse(f.fit_json, nullptr, false);
  if (j.is_discarded() || !j.contains("axes")) return;
  for (int a = 0; a < 2; ++a) {
    const char* name = a == 0 ? "x" : "y";
    if (!j["axes"].contains(name)) continue;
    const auto& x = j["axes"][name];
    auto num = [&](const char* k) { return x.contains(k) && x[k].is_number() ? x[k].get<double>() : 0.0; };
    f.feed_factor[a] = num("feed_factor");
    f.dead_band_mm_per_s[a] = num("dead_band_mm_per_s");
    f.mm_per_count[a] = num("mm_per_count");
    f.backlash_mm[a] = num("backlash_mm");
  }
}

}  // namespace

std::string default_store_path() {
  const char* xdg = std::getenv("XDG_DATA_HOME");
  std::filesystem::path base;
  if (xdg && *xdg) {
    base = xdg;
  } else {
    const char* home = std::getenv("HOME");
    if (!home || !*home) throw InputError("--db", 0, "neither XDG_DATA_HOME nor HOME is set: give --db FILE");
    base = std::filesystem::path(home) / ".local" / "share";
  }
  return (base / "machplan" / "calibration.db").string();
}

std::string log_hash(const std::string& bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

CalibrationStore::CalibrationStore(const std::string& path) : db_(std::make_unique<Db>()), path_(path) {
  const auto parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  if (sqlite3_open_v2(path.c_str(), &db_->h, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) != SQLITE_OK)
    throw InputError("--db", 0, fmt::format("cannot open '{}': {}", path, db_->h ? sqlite3_errmsg(db_->h) : "?"));
  sqlite3_busy_timeout(db_->h, 5000);
  exec(db_->h, "PRAGMA foreign_keys = ON;", path);
  exec(db_->h, kSchema, path);
}

CalibrationStore::~CalibrationStore() = default;

std::int64_t CalibrationStore::apply(const CalibrationFit& fit, const std::string& log_path,
                                     const std::string& log_bytes, const std::string& who,
                                     void (*before_commit)()) {
  if (fit.status != CalibrationFit::Status::ok)
    throw Infeasible(fmt::format("a fit with status '{}' cannot become the active calibration: {}",
                                 to_string(fit.status), fit.message));
  sqlite3* db = db_->h;
  exec(db, "BEGIN IMMEDIATE;", path_);
  try {
    const std::string when = now_utc();
    Stmt s(db, "INSERT INTO sessions(machine, log_path, log_hash, who, added_utc) VALUES(?,?,?,?,?)", path_);
    s.bind(1, fit.machine);
    s.bind(2, log_path);
    s.bind(3, log_hash(log_bytes));
    s.bind(4, who);
    s.bind(5, when);
    if (sqlite3_step(s.s) != SQLITE_DONE) throw InputError(path_, 0, sqlite3_errmsg(db));
    const std::int64_t session = sqlite3_last_insert_rowid(db);
    Stmt f(db, "INSERT INTO fits(session_id, machine, status, fit_json, who, created_utc) VALUES(?,?,?,?,?,?)", path_);
    f.bind(1, session);
    f.bind(2, fit.machine);
    f.bind(3, std::string(to_string(fit.status)));
    f.bind(4, fit.json());
    f.bind(5, who);
    f.bind(6, when);
    if (sqlite3_step(f.s) != SQLITE_DONE) throw InputError(path_, 0, sqlite3_errmsg(db));
    const std::int64_t id = sqlite3_last_insert_rowid(db);
    Stmt a(db, "INSERT INTO active(machine, fit_id) VALUES(?,?) ON CONFLICT(machine) DO UPDATE SET fit_id = excluded.fit_id",
           path_);
    a.bind(1, fit.machine);
    a.bind(2, id);
    if (sqlite3_step(a.s) != SQLITE_DONE) throw InputError(path_, 0, sqlite3_errmsg(db));
    if (before_commit) before_commit();
    exec(db, "COMMIT;", path_);
    return id;
  } catch (...) {
    sqlite3_exec(db, "ROLLBACK;", nullptr, nullptr, nullptr);
    throw;
  }
}

std::vector<StoredFit> CalibrationStore::history(const std::string& machine) const {
  Stmt s(db_->h,
         "SELECT f.id, f.session_id, f.machine, f.status, f.who, f.created_utc, s.log_path, s.log_hash, f.fit_json, "
         "(SELECT COUNT(*) FROM active a WHERE a.fit_id = f.id) FROM fits f JOIN sessions s ON s.id = f.session_id "
         "WHERE (?1 = '' OR f.machine = ?1) ORDER BY f.id DESC",
         path_);
  s.bind(1, machine);
  std::vector<StoredFit> out;
  while (sqlite3_step(s.s) == SQLITE_ROW) {
    StoredFit f;
    f.fit_id = sqlite3_column_int64(s.s, 0);
    f.session_id = sqlite3_column_int64(s.s, 1);
    f.machine = s.text(2);
    f.status = s.text(3);
    f.who = s.text(4);
    f.created_utc = s.text(5);
    f.log_path = s.text(6);
    f.log_hash = s.text(7);
    f.fit_json = s.text(8);
    f.active = sqlite3_column_int64(s.s, 9) > 0;
    fill_from_json(f);
    out.push_back(std::move(f));
  }
  return out;
}

std::optional<StoredFit> CalibrationStore::active(const std::string& machine) const {
  for (auto& f : history(machine))
    if (f.active) return f;
  return std::nullopt;
}

double open_loop_factor(const StoredFit& c, double feed_mm_per_s) {
  if (!(feed_mm_per_s > 0)) throw InputError("--feed", 0, fmt::format("{} must be > 0 mm/s", feed_mm_per_s));
  double sum = 0;
  for (int a = 0; a < 2; ++a) {
    if (!(c.feed_factor[a] > 0)) throw InputError("--db", 0, fmt::format("stored fit {} has no feed factor", c.fit_id));
    sum += (feed_mm_per_s + c.dead_band_mm_per_s[a]) / (c.feed_factor[a] * feed_mm_per_s);
  }
  return sum / 2;
}

}  // namespace machplan::calibration
