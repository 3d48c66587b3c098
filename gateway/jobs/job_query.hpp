#pragma once
// A query on the job history and one page of its answer: what job_manager::list takes from the API
// and passes to job_store::list. Kept apart so that the store does not depend on the manager above it.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "gateway/jobs/job.hpp"

namespace gw::jobs {

struct job_filter {
    std::optional<std::string> controller;
    std::optional<job_type> type;
    std::optional<job_state> state;
    std::size_t limit = 50;             // 1..500
    std::optional<std::string> before;  // cursor: jobs created before this job id (newest first)
};

struct job_page {
    std::vector<job_record> jobs;     // newest first
    std::optional<std::string> next;  // cursor for the next page, when there is one
};

}  // namespace gw::jobs
