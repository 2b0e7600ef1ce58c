#include "solvers/session/tuning_store.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/common/error.h"
#include "solvers/common/internal/sqlite_db.h"

namespace machplan::tuning {

TuningStore::TuningStore(const std::string& path) : store_(std::make_unique<store::Store>(path)) {}

TuningStore::~TuningStore() = default;

std::int64_t TuningStore::save(const std::string& machine, const std::string& controller, const control::Gains& gains,
                               const Summary& summary, const std::string& result_json, const std::string& who) {
  if (!summary.usable_answer())
    throw Infeasible(fmt::format("a tuning with status '{}' cannot become the active tuning of '{}'", to_string(summary.status),
                                 machine));
  nlohmann::json g = nlohmann::json::object();
  for (const auto& [k, v] : gains) g[k] = v;
  const store::SqliteDb& db = store_->db();
  return db.transaction([&] {
    store::Statement s(db,
                       "INSERT INTO tunings(machine, controller, gains_json, result_json, who, created_utc, status) "
                       "VALUES(?,?,?,?,?,?,?)");
    s.bind(1, machine);
    s.bind(2, controller);
    s.bind(3, g.dump());
    s.bind(4, result_json);
    s.bind(5, who);
    s.bind(6, store::now_utc());
    s.bind(7, std::string(to_string(summary.status)));
    s.run();
    const std::int64_t id = db.last_insert_id();
    store_->activate(store::kTunings, machine, id);
    return id;
  });
}

std::vector<StoredTuning> TuningStore::history(const std::string& machine) const {
  const std::string sql = "SELECT t.id, t.machine, t.controller, t.gains_json, t.result_json, t.who, t.created_utc, t.status, " +
                          store::Store::active_flag(store::kTunings, "t") +
                          " FROM tunings t WHERE (?1 = '' OR t.machine = ?1) ORDER BY t.id DESC";
  store::Statement s(store_->db(), sql.c_str());
  s.bind(1, machine);
  std::vector<StoredTuning> out;
  while (s.step()) {
    StoredTuning t;
    t.id = s.int64(0);
    t.machine = s.text(1);
    t.controller = s.text(2);
    const auto g = nlohmann::json::parse(s.text(3), nullptr, false);
    if (g.is_object())
      for (const auto& [k, v] : g.items())
        if (v.is_number()) t.gains[k] = v.get<double>();
    t.result_json = s.text(4);
    t.who = s.text(5);
    t.created_utc = s.text(6);
    t.status = s.text(7);
    t.active = s.int64(8) > 0;
    out.push_back(std::move(t));
  }
  return out;
}

std::optional<StoredTuning> TuningStore::active(const std::string& machine) const {
  return store::active_of(history(machine));
}

}  // namespace machplan::tuning
