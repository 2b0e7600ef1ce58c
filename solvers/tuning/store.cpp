#include "solvers/tuning/store.h"

#include <sqlite3.h>

#include <ctime>
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/common/error.h"

namespace machplan::tuning {
namespace {

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS tunings (
  id INTEGER PRIMARY KEY,
  machine TEXT NOT NULL,
  controller TEXT NOT NULL,
  gains_json TEXT NOT NULL,
  result_json TEXT NOT NULL,
  who TEXT NOT NULL,
  created_utc TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS active_tuning (
  machine TEXT PRIMARY KEY,
  tuning_id INTEGER NOT NULL REFERENCES tunings(id)
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

struct Stmt {
  sqlite3_stmt* s = nullptr;
  Stmt(sqlite3* db, const char* sql, const std::string& where) {
    if (sqlite3_prepare_v2(db, sql, -1, &s, nullptr) != SQLITE_OK)
      throw InputError(where, 0, fmt::format("not a machplan store: {}", sqlite3_errmsg(db)));
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
    throw InputError(where, 0, fmt::format("tuning store: {}", msg));
  }
}

}  // namespace

struct TuningStore::Db {
  sqlite3* h = nullptr;
  ~Db() {
    if (h) sqlite3_close(h);
  }
};

TuningStore::TuningStore(const std::string& path) : db_(std::make_unique<Db>()), path_(path) {
  const auto parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  if (sqlite3_open_v2(path.c_str(), &db_->h, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) != SQLITE_OK)
    throw InputError("--db", 0, fmt::format("cannot open '{}': {}", path, db_->h ? sqlite3_errmsg(db_->h) : "?"));
  sqlite3_busy_timeout(db_->h, 5000);
  try {
    exec(db_->h, "PRAGMA foreign_keys = ON;", path);
    exec(db_->h, kSchema, path);
  } catch (const InputError& e) {
    throw InputError("--db", 0, fmt::format("'{}' is not a machplan store: {}", path, e.message()));
  }
}

TuningStore::~TuningStore() = default;

std::int64_t TuningStore::save(const std::string& machine, const std::string& controller, const control::Gains& gains,
                               const std::string& status, const std::string& result_json, const std::string& who) {
  if (status != "ok")
    throw Infeasible(fmt::format("a tuning with status '{}' cannot become the active tuning of '{}'", status, machine));
  nlohmann::json g = nlohmann::json::object();
  for (const auto& [k, v] : gains) g[k] = v;
  sqlite3* db = db_->h;
  exec(db, "BEGIN IMMEDIATE;", path_);
  try {
    Stmt s(db, "INSERT INTO tunings(machine, controller, gains_json, result_json, who, created_utc) VALUES(?,?,?,?,?,?)",
           path_);
    s.bind(1, machine);
    s.bind(2, controller);
    s.bind(3, g.dump());
    s.bind(4, result_json);
    s.bind(5, who);
    s.bind(6, now_utc());
    if (sqlite3_step(s.s) != SQLITE_DONE) throw InputError(path_, 0, sqlite3_errmsg(db));
    const std::int64_t id = sqlite3_last_insert_rowid(db);
    Stmt a(db,
           "INSERT INTO active_tuning(machine, tuning_id) VALUES(?,?) ON CONFLICT(machine) DO UPDATE SET tuning_id = "
           "excluded.tuning_id",
           path_);
    a.bind(1, machine);
    a.bind(2, id);
    if (sqlite3_step(a.s) != SQLITE_DONE) throw InputError(path_, 0, sqlite3_errmsg(db));
    exec(db, "COMMIT;", path_);
    return id;
  } catch (...) {
    sqlite3_exec(db, "ROLLBACK;", nullptr, nullptr, nullptr);
    throw;
  }
}

std::vector<StoredTuning> TuningStore::history(const std::string& machine) const {
  Stmt s(db_->h,
         "SELECT t.id, t.machine, t.controller, t.gains_json, t.result_json, t.who, t.created_utc, "
         "(SELECT COUNT(*) FROM active_tuning a WHERE a.tuning_id = t.id) FROM tunings t "
         "WHERE (?1 = '' OR t.machine = ?1) ORDER BY t.id DESC",
         path_);
  s.bind(1, machine);
  std::vector<StoredTuning> out;
  while (sqlite3_step(s.s) == SQLITE_ROW) {
    StoredTuning t;
    t.id = sqlite3_column_int64(s.s, 0);
    t.machine = s.text(1);
    t.controller = s.text(2);
    const auto g = nlohmann::json::parse(s.text(3), nullptr, false);
    if (g.is_object())
      for (const auto& [k, v] : g.items())
        if (v.is_number()) t.gains[k] = v.get<double>();
    t.result_json = s.text(4);
    t.who = s.text(5);
    t.created_utc = s.text(6);
    t.active = sqlite3_column_int64(s.s, 7) > 0;
    out.push_back(std::move(t));
  }
  return out;
}

std::optional<StoredTuning> TuningStore::active(const std::string& machine) const {
  for (auto& t : history(machine))
    if (t.active) return t;
  return std::nullopt;
}

}  // namespace machplan::tuning
