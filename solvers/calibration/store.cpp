#include "solvers/calibration/store.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/common/error.h"
#include "solvers/common/internal/sqlite_db.h"
#include "solvers/common/store.h"

namespace machplan::calibration {
namespace {

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

std::string log_hash(const std::string& bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

CalibrationStore::CalibrationStore(const std::string& path) : store_(std::make_unique<store::Store>(path)) {}

CalibrationStore::~CalibrationStore() = default;

std::int64_t CalibrationStore::apply(const CalibrationFit& fit, const std::string& log_path,
                                     const std::string& log_bytes, const std::string& who,
                                     void (*before_commit)()) {
  if (!fit.summary.done())
    throw Infeasible(fmt::format("a fit with status '{}' cannot become the active calibration: {}",
                                 to_string(fit.summary.status), fit.summary.message));
  const store::SqliteDb& db = store_->db();
  return db.transaction([&] {
    const std::string when = store::now_utc();
    store::Statement s(db, "INSERT INTO sessions(machine, log_path, log_hash, who, added_utc) VALUES(?,?,?,?,?)");
    s.bind(1, fit.machine);
    s.bind(2, log_path);
    s.bind(3, log_hash(log_bytes));
    s.bind(4, who);
    s.bind(5, when);
    s.run();
    const std::int64_t session = db.last_insert_id();
    store::Statement f(db, "INSERT INTO fits(session_id, machine, status, fit_json, who, created_utc) VALUES(?,?,?,?,?,?)");
    f.bind(1, session);
    f.bind(2, fit.machine);
    f.bind(3, std::string(to_string(fit.summary.status)));
    f.bind(4, fit.json());
    f.bind(5, who);
    f.bind(6, when);
    f.run();
    const std::int64_t id = db.last_insert_id();
    store_->activate(store::kFits, fit.machine, id);
    if (before_commit) before_commit();
    return id;
  });
}

std::vector<StoredFit> CalibrationStore::history(const std::string& machine) const {
  const std::string sql =
      "SELECT f.id, f.session_id, f.machine, f.status, f.who, f.created_utc, s.log_path, s.log_hash, f.fit_json, " +
      store::Store::active_flag(store::kFits, "f") +
      " FROM fits f JOIN sessions s ON s.id = f.session_id WHERE (?1 = '' OR f.machine = ?1) ORDER BY f.id DESC";
  store::Statement s(store_->db(), sql.c_str());
  s.bind(1, machine);
  std::vector<StoredFit> out;
  while (s.step()) {
    StoredFit f;
    f.fit_id = s.int64(0);
    f.session_id = s.int64(1);
    f.machine = s.text(2);
    f.status = s.text(3);
    f.who = s.text(4);
    f.created_utc = s.text(5);
    f.log_path = s.text(6);
    f.log_hash = s.text(7);
    f.fit_json = s.text(8);
    f.active = s.int64(9) > 0;
    fill_from_json(f);
    out.push_back(std::move(f));
  }
  return out;
}

std::optional<StoredFit> CalibrationStore::active(const std::string& machine) const {
  return store::active_of(history(machine));
}

double open_loop_factor(const StoredFit& c, double feed_mm_per_s) {
  if (!(feed_mm_per_s > 0)) throw InputError::field("feed_mm_per_s", fmt::format("{} must be > 0 mm/s", feed_mm_per_s));
  double sum = 0;
  for (int a = 0; a < 2; ++a) {
    if (!(c.feed_factor[a] > 0)) throw InputError::field("calibration", fmt::format("stored fit {} has no feed factor", c.fit_id));
    sum += (feed_mm_per_s + c.dead_band_mm_per_s[a]) / (c.feed_factor[a] * feed_mm_per_s);
  }
  return sum / 2;
}

std::string history_report(const std::vector<StoredFit>& fits) {
  if (fits.empty()) return "no calibrations stored\n";
  std::string s;
  for (const auto& f : fits)
    s += fmt::format("fit {}{}  {}  {} by {}  feed x {:.5f} y {:.5f}  backlash x {:.4f} y {:.4f} mm  log {} ({})\n",
                     f.fit_id, f.active ? " (active)" : "", f.machine, f.created_utc, f.who, f.feed_factor[0],
                     f.feed_factor[1], f.backlash_mm[0], f.backlash_mm[1], f.log_path, f.log_hash);
  return s;
}

std::string calibration_report(const StoredFit& c, std::optional<double> feed_mm_per_s) {
  std::string s = fmt::format("active calibration for {}: fit {} of {} by {}\n", c.machine, c.fit_id, c.created_utc, c.who);
  for (int i = 0; i < 2; ++i)
    s += fmt::format("  {}: feed factor {:.5f}, dead band {:.4f} mm/s, {:.7f} mm/count, backlash {:.4f} mm\n",
                     i ? "y" : "x", c.feed_factor[i], c.dead_band_mm_per_s[i], c.mm_per_count[i], c.backlash_mm[i]);
  if (feed_mm_per_s)
    s += fmt::format("open-loop factor at {:g} mm/s: {:.5f}\n", *feed_mm_per_s, open_loop_factor(c, *feed_mm_per_s));
  return s;
}

}  // namespace machplan::calibration
