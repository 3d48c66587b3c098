#pragma once
// The job manager's job_store, shared by its strand (the writes) and readers on any thread, and closed
// at shutdown (or dropped when the manager is abandoned, like a crash). A caller takes the store for one
// call: a call in progress keeps it open until it returns. The lock is held only to copy the pointer,
// never during SQLite work, so a reader never waits here for a write.
//
//   auto store = handle.get();
//   if (!store) return make_error(operation_error_kind::storage_unavailable, "the job store is closed");
//   auto found = store->find(id);

#include <memory>
#include <mutex>
#include <utility>

#include "gateway/jobs/store/job_store.hpp"

namespace gw::jobs {

class job_store_handle {
  public:
    explicit job_store_handle(std::unique_ptr<job_store> store) : store_(std::move(store)) {}

    // Null once closed.
    std::shared_ptr<job_store> get() const {
        std::lock_guard lock(mutex_);
        return store_;
    }
    // Takes the store out: later get() calls return null. The store itself closes when the last call
    // that holds it returns.
    std::shared_ptr<job_store> close() {
        std::lock_guard lock(mutex_);
        return std::exchange(store_, nullptr);
    }

  private:
    mutable std::mutex mutex_;
    std::shared_ptr<job_store> store_;
};

}  // namespace gw::jobs
