// The calibration store: calibration sessions and fits, and each machine's active calibration,
// in machplan's store (solvers/common/store.h, beside the tunings).
//
// Tables: `sessions` (the log's location, its FNV-1a 64-bit hash, machine, who and when it was
// added), `fits` (the fit as JSON, its status in Summary's spelling, the session it came from,
// who and when) and `active` (machine -> fit id). `apply()` stores the session, the fit and
// the activation in one transaction: a process killed in the middle leaves the database as it
// was before, with the previous calibration active (SQLite's rollback journal undoes the
// partial write at the next open). A fit whose status is not done cannot be applied.
//
// Default location: $XDG_DATA_HOME/machplan/calibration.db, or ~/.local/share/machplan/ when
// XDG_DATA_HOME is unset (the folder is created). One store object per thread.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "solvers/calibration/fit.h"
#include "solvers/common/store.h"

namespace machplan::calibration {

struct StoredFit {
  std::int64_t fit_id = 0, session_id = 0;
  std::string machine, who, created_utc;
  std::string status;    // to_string(Status): "done" (only done fits are applied)
  std::string log_path;
  std::string log_hash;  // FNV-1a 64, hex
  std::string fit_json;  // CalibrationFit::json()
  bool active = false;
  // From fit_json, for the user of the calibration.
  double feed_factor[2] = {0, 0}, dead_band_mm_per_s[2] = {0, 0}, mm_per_count[2] = {0, 0}, backlash_mm[2] = {0, 0};
};

// $XDG_DATA_HOME/machplan/calibration.db (or ~/.local/share/...); creates its folder on first use.
using store::default_store_path;
// FNV-1a 64 of `bytes`, as 16 hex digits.
std::string log_hash(const std::string& bytes);

class CalibrationStore {
 public:
  // Opens (creating file and schema when needed, never its folder: solvers/common/internal/sqlite_db.h).
  // Throws InputError::field("db_path", ...) when the file cannot be opened or is not a calibration store.
  explicit CalibrationStore(const std::string& path);
  ~CalibrationStore();
  CalibrationStore(const CalibrationStore&) = delete;
  CalibrationStore& operator=(const CalibrationStore&) = delete;

  // Stores the session and `fit` and makes the fit the machine's active calibration, in one
  // transaction. Returns the fit id. Throws Infeasible when the fit's status is not done.
  // `before_commit` (tests only) runs inside the transaction, just before COMMIT.
  std::int64_t apply(const CalibrationFit& fit, const std::string& log_path, const std::string& log_bytes,
                     const std::string& who, void (*before_commit)() = nullptr);

  std::optional<StoredFit> active(const std::string& machine) const;
  // Newest first; all machines when `machine` is empty.
  std::vector<StoredFit> history(const std::string& machine = {}) const;

 private:
  std::unique_ptr<store::Store> store_;
};

// The paper modes' open-loop factor (commanded / programmed speed) for a feed, from a stored
// calibration: the speed command that makes the axis run at `feed_mm_per_s` is
// (feed + dead band) / feed factor, so the factor is (F + d) / (k F), averaged over the axes.
// One session gives it for every feed; the paper measured it anew for each.
double open_loop_factor(const StoredFit& calibration, double feed_mm_per_s);

// What `machplan calibrate history` prints: one line per stored fit in the order given (newest
// first from history()), the active one marked; "no calibrations stored" when there is none.
std::string history_report(const std::vector<StoredFit>& fits);
// What `machplan calibrate show` prints: the active calibration's factors per axis, and with
// a feed the paper modes' open-loop factor for it (open_loop_factor()).
std::string calibration_report(const StoredFit& calibration, std::optional<double> feed_mm_per_s = std::nullopt);

}  // namespace machplan::calibration
