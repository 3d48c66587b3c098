#pragma once
// Which job holds each controller (running, or paused keeping it) and the lease it was submitted or
// resumed under. While a job holds a controller, operations that would change what it relies on are
// the business of that lease's holder alone (api/: 409 job-active); reads and HALT are everyone's.
// Written by the job manager's strand at every state change, read by api/ on the I/O threads for
// every operation: thread-safe, a map lookup under a mutex.

#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "gateway/jobs/job.hpp"

namespace gw::jobs {

struct job_hold {
    std::string job_id;
    job_state state = job_state::running;
    std::optional<std::string> lease_id;  // none: nobody but the job changes the controller
};

class job_holds {
  public:
    // `job` holds `controller` now (it runs or is paused there).
    void hold(const std::string& controller, job_hold job);
    // `job_id` no longer holds `controller` (nothing when another job holds it).
    void release(const std::string& controller, const std::string& job_id);
    std::optional<job_hold> find(const std::string& controller) const;

  private:
    mutable std::mutex mutex_;
    std::map<std::string, job_hold> holds_;
};

}  // namespace gw::jobs
