#include "gateway/jobs/job_json.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "gateway/common/timestamp.hpp"

namespace gw::jobs {

namespace {

using json = nlohmann::json;

// One decimal for percentages, three for seconds: stable, readable numbers.
double rounded(double v, double scale) {
    return std::round(v * scale) / scale;
}

json optional_time(const std::optional<job_clock::time_point>& t) {
    return t ? json(format_timestamp(*t)) : json(nullptr);
}

double percent_of(const job_record& job) {
    const auto& p = job.progress;
    if (p.steps_total == 0) return job.state == job_state::succeeded ? 100.0 : 0.0;
    const double done = static_cast<double>(std::min(p.steps_done, p.steps_total));
    return rounded(100.0 * done / static_cast<double>(p.steps_total), 10);
}

double elapsed_of(const job_record& job, job_clock::time_point now) {
    if (!job.started) return 0;
    const auto end = job.finished ? *job.finished : now;
    const double s = std::chrono::duration<double>(end - *job.started).count();
    return rounded(std::max(0.0, s), 1000);
}

json remaining_of(const job_record& job) {
    if (is_terminal(job.state)) return 0.0;
    if (!job.progress.remaining_s) return nullptr;
    return rounded(std::max(0.0, *job.progress.remaining_s), 1000);
}

// Only a queued, running or paused job waits for anything; only a running one has an end to expect.
json waiting_of(const job_record& job) {
    const auto& w = job.progress.waiting_for;
    const bool active =
        job.state == job_state::queued || job.state == job_state::running || job.state == job_state::paused;
    return active && w ? json(std::string(to_string(*w))) : json(nullptr);
}

json eta_of(const job_record& job) {
    return job.state == job_state::running ? optional_time(job.progress.eta) : json(nullptr);
}

}  // namespace

json to_json(const position_um& p) {
    json out = json::object();
    for (const auto& [axis, um] : p)
        out[std::string(1, axis)] = rounded(um, 1000);
    return out;
}

json measured_position_json(const position_um& p) {
    json out = json::object();
    for (const auto& [axis, um] : p)
        out[std::string(1, axis)] = std::round(um * 10.0) / 10.0;
    return out;
}

json record_without_spec(const job_record& job, job_clock::time_point now) {
    const auto& p = job.progress;
    json progress = {
        {"steps_done", p.steps_done},        {"steps_total", p.steps_total},
        {"percent", percent_of(job)},        {"current_step", p.current_step},
        {"elapsed_s", elapsed_of(job, now)}, {"remaining_s", remaining_of(job)},
        {"waiting_for", waiting_of(job)},    {"eta", eta_of(job)},
    };
    return {
        {"id", job.id},
        {"controller", job.controller},
        {"type", std::string(to_string(job.type))},
        {"state", std::string(to_string(job.state))},
        {"progress", std::move(progress)},
        {"estimated_s", rounded(job.estimated_s, 1000)},
        {"path", job.plan_path},
        {"reason", job.reason},
        {"submitted_by", job.submitted_by},
        {"request_id", job.request_id},
        {"idempotency_key", job.idempotency_key ? json(*job.idempotency_key) : json(nullptr)},
        {"created", format_timestamp(job.created)},
        {"started", optional_time(job.started)},
        {"finished", optional_time(job.finished)},
        {"updated", format_timestamp(job.updated)},
    };
}

json to_json(const job_record& job, job_clock::time_point now) {
    auto record = record_without_spec(job, now);
    record["spec"] = job.spec.is_null() ? json::object() : job.spec;
    return record;
}

json to_json(const job_plan& plan, std::size_t max_steps) {
    json steps = json::array();
    for (std::size_t i = 0; i < plan.steps.size() && i < max_steps; ++i) {
        const auto& s = plan.steps[i];
        json step = {{"name", s.name},
                     {"target", s.target ? to_json(*s.target) : json(nullptr)},
                     {"estimated_s", rounded(s.estimated_s, 1000)}};
        if (s.waits_for_trigger) step["waits_for_trigger"] = true;
        steps.push_back(std::move(step));
    }
    json bounds = nullptr;
    if (!plan.bounds.empty()) bounds = {{"min", to_json(plan.bounds.min)}, {"max", to_json(plan.bounds.max)}};
    return {
        {"path", plan.path},
        {"summary", plan.summary},
        {"steps_total", plan.steps.size()},
        {"steps", std::move(steps)},
        {"commands", plan.commands},
        {"commands_omitted", plan.commands_omitted},
        {"estimated_s", rounded(plan.estimated_s, 1000)},
        {"bounds", std::move(bounds)},
        {"warnings", plan.warnings},
        {"record", plan.record},
    };
}

json dry_run_json(const std::string& controller, job_type type, const job_plan& plan) {
    return {{"dry_run", true},
            {"controller", controller},
            {"type", std::string(to_string(type))},
            {"plan", to_json(plan)}};
}

json state_event(const job_record& job, job_clock::time_point now) {
    // The record goes under "job": its own "type" (the job type) would clash with the event's.
    return {{"type", "state"},      {"state", std::string(to_string(job.state))},
            {"reason", job.reason}, {"waiting_for", waiting_of(job)},
            {"eta", eta_of(job)},   {"job", record_without_spec(job, now)}};
}

json step_event(const job_record& job, std::size_t index, const std::string& name, const json& detail,
                job_clock::time_point now) {
    json e = {{"type", "step"}};
    if (detail.is_object()) e.update(detail);
    // The manager's fields win over the detail's.
    e["type"] = "step";
    e["index"] = index;
    e["name"] = name;
    e["steps_done"] = job.progress.steps_done;
    e["steps_total"] = job.progress.steps_total;
    e["percent"] = percent_of(job);
    e["remaining_s"] = remaining_of(job);
    e["elapsed_s"] = elapsed_of(job, now);
    e["waiting_for"] = waiting_of(job);
    e["eta"] = eta_of(job);
    e["at"] = format_timestamp(now);
    return e;
}

std::string job_topic(const std::string& job_id) {
    return "jobs/" + job_id;
}

}  // namespace gw::jobs
