#pragma once
// Where the task manager keeps definitions and runs across restarts (SQLite). A run's row is
// written before each change of it is published, so what subscribers saw is never lost.
//
// Threading: thread-safe; its lock is a leaf (taken under a run's mutex).

#include <cstdint>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "camus.pb.h"
#include "task_run.hpp"
#include "urs/camus_server/sqlite.hpp"

namespace urs::camus_server::tasks {

class TaskStore {
 public:
  // Opens or creates `db_path` ("" = in memory); keeps at most `keep_finished` finished runs.
  // Throws SqliteError.
  TaskStore(const std::string& db_path, size_t keep_finished);

  struct StoredDefinition {
    std::string name;
    std::string yaml;
    std::string owner;  // empty in stores written before owners were kept
  };
  // Every stored definition, by name.
  std::vector<StoredDefinition> definitions();
  // Throws SqliteError.
  void put_definition(const std::string& name, const std::string& yaml, const std::string& owner);

  struct StoredRun {
    uint64_t number = 0;
    std::string yaml;
    std::string owner;
    camus::TaskRun state;
    uint32_t iteration = 0;
    uint64_t watch_seq = 0;
  };
  // Every stored run, oldest first.
  std::vector<StoredRun> runs();
  // The first row of a new run (its mutex held). Throws SqliteError.
  void insert_run(const Run& run);
  // The run's current state (its mutex held); prunes finished runs beyond keep_finished. A
  // failure is logged, not thrown: the run goes on.
  void save(const Run& run);

 private:
  const size_t keep_finished_;
  std::mutex mutex_;
  Database db_;
};

}  // namespace urs::camus_server::tasks
