// Tuned gains in machplan's store (solvers/common/store.h): each machine's tunings and its
// active one, beside its calibrations in the same SQLite file (default
// $XDG_DATA_HOME/machplan/calibration.db).
//
// Tables: `tunings` (machine, controller kind, gains as JSON, the tuning's report as JSON,
// its status in Summary's spelling, who, when) and `active_tuning` (machine -> tuning id).
// save() inserts and activates in one transaction. Only a tuning with a usable answer can be
// saved: done, or ended by its deadline or budget with gains that meet every constraint
// (engine/common/summary.h). `machplan run --controller tuned` builds the active tuning's
// controller with its gains.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/common/summary.h"
#include "engine/control/controller_factory.h"
#include "solvers/common/store.h"

namespace machplan::tuning {

struct StoredTuning {
  std::int64_t id = 0;
  std::string machine, controller, who, created_utc, result_json;
  std::string status;  // to_string(Status) of the tuning's summary: "done", "deadline", "budget"
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
  // `summary` holds no usable answer.
  std::int64_t save(const std::string& machine, const std::string& controller, const control::Gains& gains,
                    const Summary& summary, const std::string& result_json, const std::string& who);
  std::optional<StoredTuning> active(const std::string& machine) const;
  // Newest first; all machines when `machine` is empty.
  std::vector<StoredTuning> history(const std::string& machine = {}) const;

 private:
  std::unique_ptr<store::Store> store_;
};

}  // namespace machplan::tuning
