#pragma once
// Which interrupted jobs may have left the controller's TTL output high (a laser or shutter on). A
// gateway that dies (kill -9, power) while such a job runs cannot switch it off; the next gateway
// does, once it finds the job interrupted and the controller connected (job_recovery). Pure.
//
//   gcode  M03 lights the output along the path (always a candidate: the program may switch it on)
//   array  "ttl_pulse": true pulses it (TTL Y=1 then TTL Y=0) at every well
// The other jobs' restore commands switch TTL *input* modes (TTL X=), which are not outputs; the same
// recovery sends those from the job store.

#include <nlohmann/json.hpp>

#include "gateway/jobs/job.hpp"

namespace gw::jobs {

bool may_leave_ttl_output_high(job_type type, const nlohmann::json& spec);

// The request id the recovery's safe-output commands go with: not "job-<id>", so that a job's own
// command trace shows only what the job sent.
std::string safe_output_request_id(const std::string& job_id);

}  // namespace gw::jobs
