// Wiring from the config file to the job manager; kept apart so the manager needs no config.
#include "gateway/config/config.hpp"
#include "gateway/jobs/manager/job_manager.hpp"

namespace gw::jobs {

job_manager_settings make_job_manager_settings(const gateway_config& config) {
    job_manager_settings s;
    s.storage_path = config.storage.path;
    s.storage_max_size_mb = config.storage.max_size_mb;
    s.restart_queued = config.jobs.restart_queued;
    s.max_queued_per_controller = config.jobs.max_queued_per_controller;
    s.ended_job_topic_ttl = config.events.ended_job_topic_ttl;
    s.retention = config.storage.retention;
    return s;
}

}  // namespace gw::jobs
