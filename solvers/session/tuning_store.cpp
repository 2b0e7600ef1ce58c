#include "solvers/session/tuning_store.h"


#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/common/error.h"
#include "solvers/common/internal/sqlite_db.h"

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

}  // namespace

TuningStore::TuningStore(const std::string& path) : db_(std::make_unique<store::SqliteDb>(path, kSchema)) {}

TuningStore::~TuningStore() = default;

std::int64_t TuningStore::save(const std::string& machine, const std::string& controller, const control::Gains& gains,
                               const std::string& status, const std::string& result_json, const std::string& who) {
  if (status != "ok")
    throw Infeasible(fmt::format("a tuning with status '{}' cannot become the active tuning of '{}'", status, machine));
  nlohmann::json g = nlohmann::json::object();
  for (const auto& [k, v] : gains) g[k] = v;
  return db_->transaction([&] {
    store::Statement s(*db_,
                       "INSERT INTO tunings(machine, controller, gains_json, result_json, who, created_utc) VALUES(?,?,?,?,?,?)");
    s.bind(1, machine);
    s.bind(2, controller);
    s.bind(3, g.dump());
    s.bind(4, result_json);
    s.bind(5, who);
    s.bind(6, store::now_utc());
    s.run();
    const std::int64_t id = db_->last_insert_id();
    store::Statement a(*db_,
                       "INSERT INTO active_tuning(machine, tuning_id) VALUES(?,?) ON CONFLICT(machine) DO UPDATE SET "
                       "tuning_id = excluded.tuning_id");
    a.bind(1, machine);
    a.bind(2, id);
    a.run();
    return id;
  });
}

std::vector<StoredTuning> TuningStore::history(const std::string& machine) const {
  store::Statement s(*db_,
         "SELECT t.id, t.machine, t.controller, t.gains_json, t.result_json, t.who, t.created_utc, "
         "(SELECT COUNT(*) FROM active_tuning a WHERE a.tuning_id = t.id) FROM tunings t "
         "WHERE (?1 = '' OR t.machine = ?1) ORDER BY t.id DESC");
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
    t.active = s.int64(7) > 0;
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
