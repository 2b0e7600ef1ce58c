// Job statistics in machplan's store (solvers/common/store.h): one row per run of a job on a
// machine, and each machine's consumable changes, beside its calibrations and tunings in the
// same SQLite file (default $XDG_DATA_HOME/machplan/calibration.db).
//
// Tables: `jobs` (machine, program path and its FNV-1a hash, when the run started, how it
// ended: Summary's status and the first fault's kind, and its figures: pierces, arc-on time,
// cycle time, cut length (the cuts completed), rapid length, probes, skipped probes, probe time, faults) and
// `consumable_changes` (machine, who, when, the newest job id it follows). A consumable change
// erases nothing: the counters "since the last change" are the sums over the jobs recorded after
// the machine's newest change row; the lifetime totals are the sums over all its jobs.
//
// The figures come from the executor's result (engine/executor/executor.h), counted after the
// run: a pierce is a cut stretch the torch started, plus every re-pierce after a hold that put
// the torch out.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/executor/executor.h"
#include "solvers/common/store.h"

namespace machplan::stats {

// The figures one run adds to its machine's counters.
struct Figures {
  std::int64_t jobs = 0, pierces = 0, probes = 0, probes_skipped = 0, faults = 0;
  double arc_on_s = 0.0, cycle_s = 0.0, cut_mm = 0.0, rapid_mm = 0.0, probe_s = 0.0;
  Figures& operator+=(const Figures& o);
};

struct JobRecord {
  std::int64_t id = 0;
  std::string machine, program, program_hash, started_utc;
  std::string status;  // to_string(Status) of the run's summary: "done", "faulted", "cancelled", ...
  std::string fault;   // to_string(FaultKind) of the fault that stopped it; "" when none did
  Figures figures;     // jobs = 1
};

// A run's record: its figures counted from `result`; `program_bytes` are hashed (the path alone
// does not say which version ran). started_utc is now.
JobRecord job_record(const executor::ExecutionResult& result, const std::string& program_path,
                     const std::string& program_bytes);

struct MachineTotals {
  std::string machine;
  Figures lifetime, since_change;
  std::optional<std::string> last_change_utc, last_change_who;  // none: never changed
};

class StatsStore {
 public:
  // Opens (creating the file and the tables when needed). InputError::field("db_path", ...) when
  // the file cannot be opened or is not a machplan store.
  explicit StatsStore(const std::string& path);
  ~StatsStore();
  StatsStore(const StatsStore&) = delete;
  StatsStore& operator=(const StatsStore&) = delete;

  const std::string& path() const;
  // Stores the run; returns its id.
  std::int64_t record(const JobRecord& job);
  // Newest first, at most `limit`; all machines when `machine` is empty.
  std::vector<JobRecord> jobs(const std::string& machine = {}, std::int64_t limit = 20) const;
  MachineTotals totals(const std::string& machine) const;
  // The operator changed the consumables: the counters since the last change start again.
  void consumables_changed(const std::string& machine, const std::string& who);

 private:
  std::unique_ptr<store::Store> store_;
};

}  // namespace machplan::stats
