// Tuned gains in the calibration store: each machine's tunings and its active one, beside its
// calibrations in the same SQLite file (solvers/calibration/store.h; default
// $XDG_DATA_HOME/machplan/calibration.db).
//
// Tables: `tunings` (machine, controller kind, gains as JSON, the tuning's report as JSON,
// who, when) and `active_tuning` (machine -> tuning id). save() inserts and activates in one
// transaction. Only a tuning with status "ok" can be saved. `machplan run --controller tuned`
// builds the active tuning's controller with its gains.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/control/controller_factory.h"

namespace machplan::store {
class SqliteDb;
}

namespace machplan::tuning {

struct StoredTuning {
  std::int64_t id = 0;
  std::string machine, controller, who, created_utc, result_json;
  control::Gains gains;
  bool active = false;
};

class TuningStore {
 public:
  // Opens (creating the file and the tables when needed). InputError::field("db_path", ...) when the
  // file cannot be opened or is not a machplan store.
  explicit TuningStore(const std::string& path);
  ~TuningStore();
  TuningStore(const TuningStore&) = delete;
  TuningStore& operator=(const TuningStore&) = delete;

  // Stores the tuning and makes it the machine's active one; returns its id. Infeasible when
  // status is not "ok".
  std::int64_t save(const std::string& machine, const std::string& controller, const control::Gains& gains,
                    const std::string& status, const std::string& result_json, const std::string& who);
  std::optional<StoredTuning> active(const std::string& machine) const;
  // Newest first; all machines when `machine` is empty.
  std::vector<StoredTuning> history(const std::string& machine = {}) const;

 private:
  std::unique_ptr<store::SqliteDb> db_;
};

}  // namespace machplan::tuning
