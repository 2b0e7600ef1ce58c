#include "solvers/session/job_stats.h"

#include <fmt/format.h>

#include "solvers/calibration/store.h"
#include "solvers/common/internal/sqlite_db.h"

namespace machplan::stats {
namespace {

constexpr const char* kSums =
    "COUNT(*), COALESCE(SUM(pierces),0), COALESCE(SUM(probes),0), COALESCE(SUM(probes_skipped),0), "
    "COALESCE(SUM(faults),0), COALESCE(SUM(arc_on_s),0), COALESCE(SUM(cycle_s),0), COALESCE(SUM(rapid_mm),0), "
    "COALESCE(SUM(probe_s),0), COALESCE(SUM(cut_mm),0)";

// Reads kSums' ten columns starting at `first`.
Figures figures_at(const store::Statement& s, int first) {
  Figures f;
  f.jobs = s.int64(first);
  f.pierces = s.int64(first + 1);
  f.probes = s.int64(first + 2);
  f.probes_skipped = s.int64(first + 3);
  f.faults = s.int64(first + 4);
  f.arc_on_s = s.real(first + 5);
  f.cycle_s = s.real(first + 6);
  f.rapid_mm = s.real(first + 7);
  f.probe_s = s.real(first + 8);
  f.cut_mm = s.real(first + 9);
  return f;
}

Figures sums(const store::SqliteDb& db, const std::string& machine, std::int64_t after_id) {
  const std::string sql = fmt::format("SELECT {} FROM jobs WHERE machine = ?1 AND id > ?2", kSums);
  store::Statement s(db, sql.c_str());
  s.bind(1, machine);
  s.bind(2, after_id);
  return s.step() ? figures_at(s, 0) : Figures{};
}

}  // namespace

Figures& Figures::operator+=(const Figures& o) {
  jobs += o.jobs;
  pierces += o.pierces;
  probes += o.probes;
  probes_skipped += o.probes_skipped;
  faults += o.faults;
  arc_on_s += o.arc_on_s;
  cycle_s += o.cycle_s;
  rapid_mm += o.rapid_mm;
  cut_mm += o.cut_mm;
  probe_s += o.probe_s;
  return *this;
}

JobRecord job_record(const executor::ExecutionResult& result, const std::string& program_path,
                     const std::string& program_bytes) {
  JobRecord r;
  r.machine = result.machine;
  r.program = program_path;
  r.program_hash = calibration::log_hash(program_bytes);
  r.started_utc = store::now_utc();
  r.status = to_string(result.summary.status);
  if (!result.faults.empty()) r.fault = executor::to_string(result.faults.front().kind);
  Figures& f = r.figures;
  f.jobs = 1;
  f.pierces = static_cast<std::int64_t>(result.cuts.size());
  for (const executor::HoldReport& h : result.holds)
    if (h.torch_off) ++f.pierces;
  f.probes = static_cast<std::int64_t>(result.probes.size() + result.probes_dropped);
  for (const executor::ProbeReport& p : result.probes) {
    if (p.skipped) ++f.probes_skipped;
    f.probe_s += p.duration_s;
  }
  f.faults = static_cast<std::int64_t>(result.faults.size());
  f.arc_on_s = result.torch_on_s;
  f.cycle_s = result.cycle_time_s;
  f.rapid_mm = result.rapid_distance_mm;
  f.cut_mm = result.cut_distance_mm;
  return r;
}

StatsStore::StatsStore(const std::string& path) : store_(std::make_unique<store::Store>(path)) {}

StatsStore::~StatsStore() = default;

const std::string& StatsStore::path() const { return store_->path(); }

std::int64_t StatsStore::record(const JobRecord& job) {
  const store::SqliteDb& db = store_->db();
  return db.transaction([&] {
    store::Statement s(db,
                       "INSERT INTO jobs(machine, program, program_hash, started_utc, status, fault, pierces, arc_on_s, "
                       "cycle_s, rapid_mm, probes, probes_skipped, probe_s, faults, cut_mm) VALUES(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    const Figures& f = job.figures;
    s.bind(1, job.machine);
    s.bind(2, job.program);
    s.bind(3, job.program_hash);
    s.bind(4, job.started_utc);
    s.bind(5, job.status);
    s.bind(6, job.fault);
    s.bind(7, f.pierces);
    s.bind(8, f.arc_on_s);
    s.bind(9, f.cycle_s);
    s.bind(10, f.rapid_mm);
    s.bind(11, f.probes);
    s.bind(12, f.probes_skipped);
    s.bind(13, f.probe_s);
    s.bind(14, f.faults);
    s.bind(15, f.cut_mm);
    s.run();
    return db.last_insert_id();
  });
}

std::vector<JobRecord> StatsStore::jobs(const std::string& machine, std::int64_t limit) const {
  store::Statement s(store_->db(),
                     "SELECT id, machine, program, program_hash, started_utc, status, fault, 1, pierces, probes, "
                     "probes_skipped, faults, arc_on_s, cycle_s, rapid_mm, probe_s, cut_mm FROM jobs "
                     "WHERE (?1 = '' OR machine = ?1) ORDER BY id DESC LIMIT ?2");
  s.bind(1, machine);
  s.bind(2, limit);
  std::vector<JobRecord> out;
  while (s.step()) {
    JobRecord r;
    r.id = s.int64(0);
    r.machine = s.text(1);
    r.program = s.text(2);
    r.program_hash = s.text(3);
    r.started_utc = s.text(4);
    r.status = s.text(5);
    r.fault = s.text(6);
    r.figures = figures_at(s, 7);
    out.push_back(std::move(r));
  }
  return out;
}

MachineTotals StatsStore::totals(const std::string& machine) const {
  MachineTotals t;
  t.machine = machine;
  const store::SqliteDb& db = store_->db();
  t.lifetime = sums(db, machine, 0);
  store::Statement c(db,
                     "SELECT changed_utc, who, after_job_id FROM consumable_changes WHERE machine = ?1 "
                     "ORDER BY id DESC LIMIT 1");
  c.bind(1, machine);
  if (!c.step()) {
    t.since_change = t.lifetime;
    return t;
  }
  t.last_change_utc = c.text(0);
  t.last_change_who = c.text(1);
  t.since_change = sums(db, machine, c.int64(2));
  return t;
}

void StatsStore::consumables_changed(const std::string& machine, const std::string& who) {
  // The change row remembers the newest job it follows: the counters since the change sum the
  // jobs after it (ids, not timestamps: two runs may start within one second).
  const store::SqliteDb& db = store_->db();
  db.transaction([&] {
    store::Statement s(db,
                       "INSERT INTO consumable_changes(machine, who, changed_utc, after_job_id) "
                       "VALUES(?1, ?2, ?3, (SELECT COALESCE(MAX(id), 0) FROM jobs WHERE machine = ?1))");
    s.bind(1, machine);
    s.bind(2, who);
    s.bind(3, store::now_utc());
    s.run();
    return 0;
  });
}

}  // namespace machplan::stats
