#pragma once
// Thin RAII wrapper over SQLite: one connection, prepared statements, transactions.
// Every failure throws SqliteError naming the database file and SQLite's message; components
// catch it at their boundary and answer INTERNAL on the per-message path.
//
// Threading: a Database is used by one component, which serialises access with its own mutex.

#include <cstdint>
#include <stdexcept>
#include <string>

struct sqlite3;
struct sqlite3_stmt;

namespace urs::camus_server {

class SqliteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// How hard a commit waits for the disk (PRAGMA synchronous in WAL mode).
//  - Full: a committed transaction survives a power loss.
//  - Normal: it survives a crash of the process (kill -9); a power loss may roll back the last
//    transactions.
enum class Durability { Full, Normal };

class Database {
 public:
  // `path` empty or ":memory:" opens a private in-memory database (nothing survives a restart).
  // Otherwise opens or creates the file in WAL mode. Throws SqliteError.
  Database(const std::string& path, Durability durability);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  void exec(const std::string& sql);  // throws SqliteError
  sqlite3* handle() { return db_; }
  const std::string& path() const { return path_; }
  bool in_memory() const { return in_memory_; }
  [[noreturn]] void fail(const std::string& what) const;  // throws SqliteError with the sqlite message

 private:
  sqlite3* db_ = nullptr;
  std::string path_;
  bool in_memory_ = false;
};

class Statement {
 public:
  Statement(Database& db, const char* sql);  // throws SqliteError
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Parameters are 1-based, as in SQLite.
  Statement& bind(int index, int64_t value);
  Statement& bind(int index, const std::string& text);
  Statement& bind_blob(int index, const std::string& bytes);
  // True while a row is available; false when done. Throws SqliteError.
  bool step();
  void reset();  // clears bindings too

  int64_t column_int(int column) const;  // 0-based, as in SQLite
  std::string column_text(int column) const;
  std::string column_blob(int column) const;

 private:
  Database& db_;
  sqlite3_stmt* stmt_ = nullptr;
};

// BEGIN IMMEDIATE on construction; ROLLBACK on destruction unless commit() was called.
class Transaction {
 public:
  explicit Transaction(Database& db);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit();

 private:
  Database& db_;
  bool done_ = false;
};

}  // namespace urs::camus_server
