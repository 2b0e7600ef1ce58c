#include "solvers/common/internal/sqlite_db.h"

#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <filesystem>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/output_file.h"

namespace machplan::store {

struct SqliteDb::Connection {
  sqlite3* h = nullptr;
  ~Connection() { sqlite3_close(h); }
};

struct Statement::Prepared {
  sqlite3_stmt* s = nullptr;
  ~Prepared() { sqlite3_finalize(s); }
};

namespace {

// The reason SQLite gives for a failure on `h`, with the system's when there is one (a full
// disk reads "database or disk is full (No space left on device)").
std::string sqlite_failure(sqlite3* h) {
  if (!h) return "out of memory";
  // A full disk may come back as SQLITE_FULL with no system error recorded (a short write).
  const int err = sqlite3_system_errno(h) != 0 ? sqlite3_system_errno(h) : sqlite3_errcode(h) == SQLITE_FULL ? ENOSPC : 0;
  return err != 0 ? fmt::format("{} ({})", sqlite3_errmsg(h), std::strerror(err)) : std::string(sqlite3_errmsg(h));
}

// A store that does not exist yet is built whole beside its path and renamed into place, so
// that a failure (a full disk) leaves no empty or half-made file under the store's name.
void create_store_file(const std::string& path, const char* schema) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path folder = fs::path(path).parent_path();
  if (!folder.empty() && !fs::is_directory(folder, ec))
    throw InputError::field("db_path", fmt::format("cannot open '{}': its folder does not exist", path));
  AtomicOutput out(path);
  sqlite3* h = nullptr;
  std::string why;
  if (sqlite3_open_v2(out.temp_path().c_str(), &h, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    why = sqlite_failure(h);
  } else {
    char* err = nullptr;
    for (const char* sql : {"PRAGMA foreign_keys = ON;", schema}) {
      if (sqlite3_exec(h, sql, nullptr, nullptr, &err) == SQLITE_OK) continue;
      why = sqlite_failure(h);
      sqlite3_free(err);
      break;
    }
  }
  sqlite3_close(h);
  if (!why.empty()) {
    ::unlink((out.temp_path() + "-journal").c_str());
    out.fail(why);
  }
  out.commit();  // throws OutputError with the reason, and removes the temporary
}

}  // namespace

SqliteDb::SqliteDb(const std::string& path, const char* schema)
    : connection_(std::make_unique<Connection>()), path_(path) {
  struct stat st {};
  const bool created = ::stat(path.c_str(), &st) != 0 && errno == ENOENT;
  if (created) create_store_file(path, schema);  // made whole with its schema
  sqlite3*& h = connection_->h;
  if (sqlite3_open_v2(path.c_str(), &h, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) != SQLITE_OK) {
    const std::string why = h ? sqlite3_errmsg(h) : "out of memory";
    sqlite3_close(h);
    h = nullptr;
    throw InputError::field("db_path", fmt::format("cannot open '{}': {} (its folder must exist)", path, why));
  }
  sqlite3_busy_timeout(h, 5000);
  try {
    exec("PRAGMA foreign_keys = ON;");
    if (!created) exec(schema);  // an existing store: the tables it lacks (schemas say IF NOT EXISTS)
  } catch (const InputError& e) {
    sqlite3_close(h);
    h = nullptr;
    throw InputError::field("db_path", fmt::format("'{}' is not a machplan store: {}", path, e.message()));
  }
}

SqliteDb::~SqliteDb() = default;

void SqliteDb::exec(const char* sql) const {
  char* err = nullptr;
  if (sqlite3_exec(connection_->h, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "unknown error";
    sqlite3_free(err);
    throw InputError::field("db_path", fmt::format("{}: {}", path_, msg));
  }
}

std::int64_t SqliteDb::last_insert_id() const { return sqlite3_last_insert_rowid(connection_->h); }

void SqliteDb::rollback() const noexcept { sqlite3_exec(connection_->h, "ROLLBACK;", nullptr, nullptr, nullptr); }

Statement::Statement(const SqliteDb& db, const char* sql) : db_(db), prepared_(std::make_unique<Prepared>()) {
  if (sqlite3_prepare_v2(db.connection_->h, sql, -1, &prepared_->s, nullptr) != SQLITE_OK)
    throw InputError::field("db_path",
                            fmt::format("'{}' is not a machplan store: {}", db.path(), sqlite3_errmsg(db.connection_->h)));
}

Statement::~Statement() = default;

void Statement::bind(int i, const std::string& v) { sqlite3_bind_text(prepared_->s, i, v.c_str(), -1, SQLITE_TRANSIENT); }
void Statement::bind(int i, std::int64_t v) { sqlite3_bind_int64(prepared_->s, i, v); }
void Statement::bind(int i, double v) { sqlite3_bind_double(prepared_->s, i, v); }

bool Statement::step() {
  const int rc = sqlite3_step(prepared_->s);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  throw InputError::field("db_path", fmt::format("{}: {}", db_.path(), sqlite3_errmsg(db_.connection_->h)));
}

std::string Statement::text(int column) const {
  const auto* p = sqlite3_column_text(prepared_->s, column);
  return p ? reinterpret_cast<const char*>(p) : "";
}

std::int64_t Statement::int64(int column) const { return sqlite3_column_int64(prepared_->s, column); }
double Statement::real(int column) const { return sqlite3_column_double(prepared_->s, column); }

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace machplan::store
