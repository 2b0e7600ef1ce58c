// machplan's store: one SQLite file (default $XDG_DATA_HOME/machplan/calibration.db) that keeps,
// per machine, records of each kind (calibration fits: solvers/calibration/store.h; tuned gains:
// solvers/session/tuning_store.h) and which record of each kind is the machine's active one, and
// its job statistics (solvers/session/job_stats.h: no active record, so no Kind).
//
// Store is the one type that opens the file. It creates every kind's tables, brings a file
// written by an older machplan up to date, and does what every kind does the same way: make a
// record the machine's active one (inside the kind's own insert transaction) and mark the
// active record when a kind lists its history. A kind keeps its own tables and columns; a new
// kind (statistics, say) adds its tables to the schema in store.cpp and a Kind below.
//
// Statuses are kept in Summary's spelling (to_string(Status), engine/common/summary.h). Files
// written before that held "ok" and "not identifiable" for fits, and no status at all for
// tunings (only done ones could be stored): opening such a file rewrites them as done and
// infeasible, in the status columns and in the stored JSON, once (SQLite's user_version says
// which files are up to date).
//
// Opening never creates folders (solvers/common/internal/sqlite_db.h), except default_store_path()'s.
// One Store object per thread.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace machplan::store {

class SqliteDb;

// $XDG_DATA_HOME/machplan/calibration.db (or ~/.local/share/...); creates its folder on first use.
std::string default_store_path();

// A kind of record: its table (with an integer `id` and a `machine` column) and the table that
// names each machine's active record of that kind.
struct Kind {
  const char* table;
  const char* active_table;   // (machine PRIMARY KEY, <active_column> REFERENCES table(id))
  const char* active_column;
};
inline constexpr Kind kFits{"fits", "active", "fit_id"};
inline constexpr Kind kTunings{"tunings", "active_tuning", "tuning_id"};

class Store {
 public:
  // Opens `path` (creating the file and every kind's tables when needed) and updates an older
  // file's statuses (see above). InputError::field("db_path", ...) when the file cannot be
  // opened or is not a machplan store.
  explicit Store(const std::string& path);
  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  const std::string& path() const;
  const SqliteDb& db() const;

  // Makes record `id` of `kind` the active one of `machine`. Call it inside the transaction
  // that inserted the record, so that both happen or neither.
  void activate(const Kind& kind, const std::string& machine, std::int64_t id) const;
  // A SELECT column that is 1 when the row `alias`.id of `kind` is its machine's active one,
  // else 0: "(SELECT COUNT(*) FROM active a WHERE a.fit_id = f.id)".
  static std::string active_flag(const Kind& kind, const char* alias);

 private:
  std::unique_ptr<SqliteDb> db_;
};

// The active row among a kind's history (rows with a bool `active`), if any.
template <class Row>
std::optional<Row> active_of(std::vector<Row> rows) {
  for (Row& r : rows)
    if (r.active) return std::move(r);
  return std::nullopt;
}

}  // namespace machplan::store
