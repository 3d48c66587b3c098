#pragma once
// One gateway per storage directory: two gateways on one job store would both recover its jobs and
// both drive their controllers. main() takes this lock before it opens the store and holds it for the
// life of the process; the kernel drops it when the process ends, also after kill -9.

#include <string>

#include "gateway/common/operation_error.hpp"

namespace gw {

class storage_lock {
  public:
    // Creates <directory>/lock if needed and takes an exclusive flock on it. storage_unavailable when
    // another process (or another storage_lock in this one) holds it, or the file cannot be opened.
    static operation_result<storage_lock> acquire(const std::string& directory);

    storage_lock(storage_lock&& other) noexcept;
    storage_lock& operator=(storage_lock&& other) noexcept;
    storage_lock(const storage_lock&) = delete;
    storage_lock& operator=(const storage_lock&) = delete;
    ~storage_lock();

  private:
    explicit storage_lock(int fd) : fd_(fd) {}
    int fd_ = -1;
};

}  // namespace gw
