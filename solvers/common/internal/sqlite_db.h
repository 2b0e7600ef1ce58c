// The SQLite connection behind machplan's store (solvers/common/store.h: calibrations, tuned
// gains): one file, each kind of record owning its own tables.
//
// Opening never creates folders: a store's path in a folder that does not exist is an error, so a
// typing mistake cannot scatter databases over the disk. Only the default location
// (default_store_path() in solvers/common/store.h) has its folder created, on first use.
// A store that does not exist yet is made whole in a temporary beside its path and renamed
// into place (engine/common/output_file.h): a failure there (a full disk) is an OutputError
// and leaves no file. Every other failure is an InputError::field("db_path", ...) naming the
// file.
//
// SQLite itself stays in sqlite_db.cpp: the connection and the prepared statement are held
// behind pointers to types defined there, so this header needs no SQLite header.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

namespace machplan::store {

class SqliteDb {
 public:
  // Opens `path` (creating the file, not its folder), waits up to 5 s for other writers, turns
  // foreign keys on and runs `schema` (CREATE TABLE IF NOT EXISTS ...).
  SqliteDb(const std::string& path, const char* schema);
  ~SqliteDb();
  SqliteDb(const SqliteDb&) = delete;
  SqliteDb& operator=(const SqliteDb&) = delete;

  const std::string& path() const { return path_; }
  void exec(const char* sql) const;
  std::int64_t last_insert_id() const;

  // Runs `body` between BEGIN IMMEDIATE and COMMIT; any exception rolls back and propagates.
  template <class Body>
  auto transaction(Body&& body) const {
    exec("BEGIN IMMEDIATE;");
    try {
      auto result = body();
      exec("COMMIT;");
      return result;
    } catch (...) {
      rollback();
      throw;
    }
  }

 private:
  friend class Statement;
  struct Connection;  // the open SQLite handle
  void rollback() const noexcept;
  std::unique_ptr<Connection> connection_;
  std::string path_;
};

class Statement {
 public:
  Statement(const SqliteDb& db, const char* sql);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  void bind(int i, const std::string& v);
  void bind(int i, std::int64_t v);
  void bind(int i, double v);
  // Steps once: true when a row is ready, false when done.
  bool step();
  // Steps a statement that returns no rows.
  void run() {
    while (step()) {
    }
  }
  std::string text(int column) const;
  std::int64_t int64(int column) const;
  double real(int column) const;

 private:
  struct Prepared;  // the prepared SQLite statement
  const SqliteDb& db_;
  std::unique_ptr<Prepared> prepared_;
};

// Now as an ISO 8601 UTC timestamp ("2026-11-23T15:00:00Z").
std::string now_utc();

}  // namespace machplan::store
