#pragma once
// The API's JSON for jobs (openapi/openapi.yaml, schemas Job, JobEvent, JobPlan): the job record, the dry-run
// plan, and the events published on "jobs/<id>". Pure: the caller passes `now` (elapsed_s of a running job).
//
//   to_json(job, now)  -> {"id","controller","type","state","spec","progress":{steps_done,
//                          steps_total,percent,current_step,elapsed_s,remaining_s,waiting_for,
//                          eta},"estimated_s",
//                          "path","reason","submitted_by","request_id","idempotency_key",
//                          "created","started","finished","updated"}
//   to_json(plan, 1000) -> {"path","summary","steps_total","steps":[{"name","target","estimated_s"}],
//                          "commands","commands_omitted","estimated_s","bounds","warnings"}
//   state_event(job, now) -> {"type":"state","state":"running","reason":"","waiting_for":null,
//                          "eta":"2026-11-22T05:31:20.500Z","job":{...to_json(job) without "spec"}}
//   step_event(job, index, name, detail, now) -> {"type":"step","index","name","steps_done",
//                          "steps_total","percent","remaining_s","elapsed_s","waiting_for","eta",
//                          "at", ...detail}

#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>

#include "gateway/jobs/job.hpp"
#include "gateway/jobs/job_plan.hpp"

namespace gw::jobs {

// Positions: {"X": 1000.0, "Y": -250.5} (micrometres).
nlohmann::json to_json(const position_um& p);
// A position read back from the controller (WHERE), to its resolution: tenths of a micrometre.
nlohmann::json measured_position_json(const position_um& p);

// elapsed_s: from `started` to `finished` (or to `now` while not finished); 0 before it started.
// percent: 100 * steps_done / steps_total (100 for a succeeded job without steps), one decimal.
// remaining_s: null when unknown, 0 once terminal; the waits for a trigger are not in it.
// waiting_for: "next", "ttl", "timer", "controller", "storage" (job_wait) or null; always null unless
// queued, running or paused. eta: progress.eta as a timestamp while running, else null.
nlohmann::json to_json(const job_record& job, job_clock::time_point now);

// At most `max_steps` entries in "steps" (steps_total says how many there are).
nlohmann::json to_json(const job_plan& plan, std::size_t max_steps = 1000);

// The dry-run answer: {"dry_run":true,"controller","type","plan":to_json(plan)}.
nlohmann::json dry_run_json(const std::string& controller, job_type type, const job_plan& plan);

// The record as to_json gives it, but for its spec.
nlohmann::json record_without_spec(const job_record& job, job_clock::time_point now);
// The state event repeats state, reason, waiting_for and eta of the record next to it. The record goes
// without its spec: the spec never changes after the submission, and an inline G-code program would
// otherwise be sent and stored again with every transition (up to 4 MiB each).
nlohmann::json state_event(const job_record& job, job_clock::time_point now);
// "at": `now`, when the step ended (the stored history keeps no other time for it).
nlohmann::json step_event(const job_record& job, std::size_t index, const std::string& name,
                          const nlohmann::json& detail, job_clock::time_point now);

// The hub topic of a job: "jobs/<id>".
std::string job_topic(const std::string& job_id);

}  // namespace gw::jobs
