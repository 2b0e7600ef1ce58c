#include "solvers/common/store.h"

#include <cstdlib>
#include <filesystem>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "solvers/common/internal/sqlite_db.h"

namespace machplan::store {
namespace {

// Every kind's tables. Calibrations: the sessions recorded, the fits made of them, the active
// fit per machine. Tunings: the tuned gains, the active tuning per machine. Job statistics
// (solvers/session/job_stats.h): one row per run, and the consumable changes. New tables need
// no version step: CREATE TABLE IF NOT EXISTS adds them to an older file when it is opened.
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
CREATE TABLE IF NOT EXISTS tunings (
  id INTEGER PRIMARY KEY,
  machine TEXT NOT NULL,
  controller TEXT NOT NULL,
  gains_json TEXT NOT NULL,
  result_json TEXT NOT NULL,
  who TEXT NOT NULL,
  created_utc TEXT NOT NULL,
  status TEXT NOT NULL DEFAULT 'done'
);
CREATE TABLE IF NOT EXISTS active_tuning (
  machine TEXT PRIMARY KEY,
  tuning_id INTEGER NOT NULL REFERENCES tunings(id)
);
CREATE TABLE IF NOT EXISTS jobs (
  id INTEGER PRIMARY KEY,
  machine TEXT NOT NULL,
  program TEXT NOT NULL,
  program_hash TEXT NOT NULL,
  started_utc TEXT NOT NULL,
  status TEXT NOT NULL,
  fault TEXT NOT NULL,
  pierces INTEGER NOT NULL,
  arc_on_s REAL NOT NULL,
  cycle_s REAL NOT NULL,
  cut_mm REAL NOT NULL,
  rapid_mm REAL NOT NULL,
  probes INTEGER NOT NULL,
  probes_skipped INTEGER NOT NULL,
  probe_s REAL NOT NULL,
  faults INTEGER NOT NULL
);
CREATE INDEX IF NOT EXISTS jobs_machine ON jobs(machine, id);
CREATE TABLE IF NOT EXISTS consumable_changes (
  id INTEGER PRIMARY KEY,
  machine TEXT NOT NULL,
  who TEXT NOT NULL,
  changed_utc TEXT NOT NULL,
  after_job_id INTEGER NOT NULL
);
)sql";

// The file's layout version (PRAGMA user_version): 0 before statuses were kept in Summary's
// spelling, 1 since, 2 since the jobs' cut length is kept.
constexpr int kVersion = 2;

std::int64_t one_number(const SqliteDb& db, const char* sql) {
  Statement s(db, sql);
  return s.step() ? s.int64(0) : 0;
}

// Version 0 -> 1: the fits' "ok" and "not identifiable" become done and infeasible, in their
// column and in their JSON; tunings gain a status column (every tuning stored then was done)
// and their JSON's "ok" becomes done.
void to_summary_spelling(const SqliteDb& db) {
  if (one_number(db, "SELECT COUNT(*) FROM pragma_table_info('tunings') WHERE name = 'status'") == 0)
    db.exec("ALTER TABLE tunings ADD COLUMN status TEXT NOT NULL DEFAULT 'done';");
  db.exec(R"sql(
UPDATE fits SET status = CASE status WHEN 'ok' THEN 'done' ELSE 'infeasible' END
  WHERE status IN ('ok', 'not identifiable');
UPDATE fits SET fit_json = json_set(fit_json, '$.status',
    CASE json_extract(fit_json, '$.status') WHEN 'ok' THEN 'done' ELSE 'infeasible' END)
  WHERE json_valid(fit_json) AND json_extract(fit_json, '$.status') IN ('ok', 'not identifiable');
UPDATE tunings SET result_json = json_set(result_json, '$.status', 'done')
  WHERE json_valid(result_json) AND json_extract(result_json, '$.status') = 'ok';
)sql");
}

// Version 1 -> 2: the jobs gain their cut length (the jobs recorded before: 0, not known).
void add_cut_length(const SqliteDb& db) {
  if (one_number(db, "SELECT COUNT(*) FROM pragma_table_info('jobs') WHERE name = 'cut_mm'") == 0)
    db.exec("ALTER TABLE jobs ADD COLUMN cut_mm REAL NOT NULL DEFAULT 0;");
}

}  // namespace

std::string default_store_path() {
  const char* xdg = std::getenv("XDG_DATA_HOME");
  std::filesystem::path base;
  if (xdg && *xdg) {
    base = xdg;
  } else {
    const char* home = std::getenv("HOME");
    if (!home || !*home) throw InputError::field("db_path", "neither XDG_DATA_HOME nor HOME is set: give the store's path");
    base = std::filesystem::path(home) / ".local" / "share";
  }
  // The default location is the one folder machplan creates for a store (sqlite_db.h).
  const std::filesystem::path dir = base / "machplan";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec)
    throw InputError::field("db_path", fmt::format("cannot create '{}': {} (give the store's path)", dir.string(), ec.message()));
  return (dir / "calibration.db").string();
}

Store::Store(const std::string& path) : db_(std::make_unique<SqliteDb>(path, kSchema)) {
  const std::int64_t version = one_number(*db_, "PRAGMA user_version");
  if (version >= kVersion) return;
  db_->transaction([&] {
    if (version < 1) to_summary_spelling(*db_);
    add_cut_length(*db_);
    db_->exec(fmt::format("PRAGMA user_version = {};", kVersion).c_str());
    return 0;
  });
}

Store::~Store() = default;

const std::string& Store::path() const { return db_->path(); }

const SqliteDb& Store::db() const { return *db_; }

void Store::activate(const Kind& kind, const std::string& machine, std::int64_t id) const {
  const std::string sql = fmt::format("INSERT INTO {0}(machine, {1}) VALUES(?,?) ON CONFLICT(machine) DO UPDATE SET {1} = excluded.{1}",
                                      kind.active_table, kind.active_column);
  Statement a(*db_, sql.c_str());
  a.bind(1, machine);
  a.bind(2, id);
  a.run();
}

std::string Store::active_flag(const Kind& kind, const char* alias) {
  return fmt::format("(SELECT COUNT(*) FROM {} a WHERE a.{} = {}.id)", kind.active_table, kind.active_column, alias);
}

}  // namespace machplan::store
