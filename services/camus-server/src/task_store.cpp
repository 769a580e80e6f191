#include "task_store.hpp"

#include <spdlog/spdlog.h>

namespace urs::camus_server::tasks {

TaskStore::TaskStore(const std::string& db_path, size_t keep_finished)
    : keep_finished_(keep_finished), db_(db_path, Durability::Full) {
  db_.exec(
      "CREATE TABLE IF NOT EXISTS task_defs (name TEXT PRIMARY KEY, yaml TEXT NOT NULL);"
      "CREATE TABLE IF NOT EXISTS task_runs (number INTEGER PRIMARY KEY, task TEXT NOT NULL, yaml TEXT NOT NULL, "
      "state TEXT NOT NULL, run BLOB NOT NULL, iteration INTEGER NOT NULL, watch_seq INTEGER NOT NULL);");
  // Stores written before tasks had owners get the column, empty for what they hold.
  for (const char* table : {"task_defs", "task_runs"}) {
    bool has_owner = false;
    const std::string query = std::string("PRAGMA table_info(") + table + ")";
    Statement columns(db_, query.c_str());
    while (columns.step()) has_owner = has_owner || columns.column_text(1) == "owner";
    if (!has_owner) db_.exec(std::string("ALTER TABLE ") + table + " ADD COLUMN owner TEXT NOT NULL DEFAULT ''");
  }
}

std::vector<TaskStore::StoredDefinition> TaskStore::definitions() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<StoredDefinition> out;
  Statement defs(db_, "SELECT name, yaml, owner FROM task_defs ORDER BY name");
  while (defs.step()) out.push_back({defs.column_text(0), defs.column_text(1), defs.column_text(2)});
  return out;
}

void TaskStore::put_definition(const std::string& name, const std::string& yaml, const std::string& owner) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement put(db_, "INSERT OR REPLACE INTO task_defs (name, yaml, owner) VALUES (?, ?, ?)");
  put.bind(1, name).bind(2, yaml).bind(3, owner).step();
}

std::vector<TaskStore::StoredRun> TaskStore::runs() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<StoredRun> out;
  Statement runs(db_, "SELECT number, yaml, run, iteration, watch_seq, owner FROM task_runs ORDER BY number");
  while (runs.step()) {
    StoredRun run;
    run.number = static_cast<uint64_t>(runs.column_int(0));
    run.yaml = runs.column_text(1);
    run.state.ParseFromString(runs.column_blob(2));
    run.iteration = static_cast<uint32_t>(runs.column_int(3));
    run.watch_seq = static_cast<uint64_t>(runs.column_int(4));
    run.owner = runs.column_text(5);
    out.push_back(std::move(run));
  }
  return out;
}

void TaskStore::insert_run(const Run& run) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement put(db_,
                "INSERT INTO task_runs (number, task, yaml, state, run, iteration, watch_seq, owner) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?)");
  put.bind(1, static_cast<int64_t>(run.number))
      .bind(2, run.spec.name)
      .bind(3, run.yaml)
      .bind(4, run.state.state())
      .bind_blob(5, run.state.SerializeAsString())
      .bind(6, static_cast<int64_t>(run.iteration))
      .bind(7, static_cast<int64_t>(run.watch_seq))
      .bind(8, run.owner)
      .step();
}

void TaskStore::save(const Run& run) {
  try {
    std::lock_guard<std::mutex> lock(mutex_);
    Statement put(db_, "UPDATE task_runs SET state = ?, run = ?, iteration = ?, watch_seq = ? WHERE number = ?");
    put.bind(1, run.state.state())
        .bind_blob(2, run.state.SerializeAsString())
        .bind(3, static_cast<int64_t>(run.iteration))
        .bind(4, static_cast<int64_t>(run.watch_seq))
        .bind(5, static_cast<int64_t>(run.number))
        .step();
    if (run.state.state() != kRunning) {
      Statement prune(db_,
                      "DELETE FROM task_runs WHERE state != 'running' AND number NOT IN "
                      "(SELECT number FROM task_runs WHERE state != 'running' ORDER BY number DESC LIMIT ?)");
      prune.bind(1, static_cast<int64_t>(keep_finished_)).step();
    }
  } catch (const SqliteError& e) {
    spdlog::error("task run {} ({}): state '{}' not stored: {}", run.run_id, run.state.task(), run.state.state(),
                  e.what());
  }
}

}  // namespace urs::camus_server::tasks
