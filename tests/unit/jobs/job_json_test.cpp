// job_json: the API's job record, dry-run plan and event shapes (openapi/openapi.yaml).
#include "gateway/jobs/job_json.hpp"

#include <chrono>

#include <gtest/gtest.h>

namespace gw::jobs {
namespace {

using json = nlohmann::json;
using namespace std::chrono_literals;

// 2026-11-22T05:30:00.123Z
job_clock::time_point at(std::chrono::milliseconds offset = 0ms) {
    return job_clock::time_point(std::chrono::seconds(1795325400)) + 123ms + offset;
}

job_record running_job() {
    job_record r;
    r.id = "j-01JD0000000000000000000000";
    r.controller = "sim1";
    r.type = job_type::array;
    r.spec = {{"plate", "96"}};
    r.state = job_state::running;
    r.progress.steps_done = 12;
    r.progress.steps_total = 96;
    r.progress.current_step = "B1";
    r.progress.remaining_s = 70.1234;
    r.estimated_s = 81;
    r.plan_path = "firmware";
    r.submitted_by = "alice";
    r.request_id = "req-1";
    r.created = at();
    r.started = at(1000ms);
    r.updated = at(5000ms);
    return r;
}

TEST(job_json, a_running_job_has_every_field_of_the_contract) {
    const auto j = to_json(running_job(), at(11200ms));
    EXPECT_EQ(j["id"], "j-01JD0000000000000000000000");
    EXPECT_EQ(j["controller"], "sim1");
    EXPECT_EQ(j["type"], "array");
    EXPECT_EQ(j["state"], "running");
    EXPECT_EQ(j["spec"], (json{{"plate", "96"}}));
    EXPECT_EQ(j["progress"]["steps_done"], 12);
    EXPECT_EQ(j["progress"]["steps_total"], 96);
    EXPECT_DOUBLE_EQ(j["progress"]["percent"].get<double>(), 12.5);
    EXPECT_EQ(j["progress"]["current_step"], "B1");
    EXPECT_DOUBLE_EQ(j["progress"]["elapsed_s"].get<double>(), 10.2);
    EXPECT_DOUBLE_EQ(j["progress"]["remaining_s"].get<double>(), 70.123);
    EXPECT_DOUBLE_EQ(j["estimated_s"].get<double>(), 81.0);
    EXPECT_EQ(j["path"], "firmware");
    EXPECT_EQ(j["reason"], "");
    EXPECT_EQ(j["submitted_by"], "alice");
    EXPECT_EQ(j["request_id"], "req-1");
    EXPECT_TRUE(j["idempotency_key"].is_null());
    EXPECT_EQ(j["created"], "2026-11-22T05:30:00.123Z");
    EXPECT_EQ(j["started"], "2026-11-22T05:30:01.123Z");
    EXPECT_TRUE(j["finished"].is_null());
    EXPECT_EQ(j["updated"], "2026-11-22T05:30:05.123Z");
    EXPECT_TRUE(j["progress"]["waiting_for"].is_null());
    EXPECT_TRUE(j["progress"]["eta"].is_null()) << "no eta estimated";
}

TEST(job_json, waiting_for_and_eta_show_only_while_they_mean_something) {
    struct row {
        const char* what;
        job_state state;
        std::optional<job_wait> waiting;
        json waiting_json, eta_json;
    };
    const row rows[] = {
        {"running, moving", job_state::running, std::nullopt, nullptr, "2026-11-22T05:31:20.623Z"},
        {"running, waits for next", job_state::running, job_wait::next, "next", "2026-11-22T05:31:20.623Z"},
        {"running, dwells", job_state::running, job_wait::timer, "timer", "2026-11-22T05:31:20.623Z"},
        {"running, waits for an edge", job_state::running, job_wait::ttl, "ttl", "2026-11-22T05:31:20.623Z"},
        {"queued behind another job", job_state::queued, job_wait::controller, "controller", nullptr},
        {"paused, disconnected", job_state::paused, job_wait::controller, "controller", nullptr},
        {"paused, store refuses", job_state::paused, job_wait::storage, "storage", nullptr},
        {"ended: no wait, no eta", job_state::succeeded, job_wait::next, nullptr, nullptr},
        {"cancelled", job_state::cancelled, job_wait::timer, nullptr, nullptr},
        {"interrupted", job_state::interrupted, job_wait::controller, nullptr, nullptr},
    };
    for (const auto& r : rows) {
        auto job = running_job();
        job.state = r.state;
        job.progress.waiting_for = r.waiting;
        job.progress.eta = at(80500ms);  // to_json shows it only while running
        const auto p = to_json(job, at(11200ms))["progress"];
        EXPECT_EQ(p["waiting_for"], r.waiting_json) << r.what;
        EXPECT_EQ(p["eta"], r.eta_json) << r.what;
    }
    EXPECT_EQ(to_string(job_wait::storage), "storage");
    EXPECT_FALSE(is_unbounded(job_wait::timer));
    for (auto w : {job_wait::next, job_wait::ttl, job_wait::controller, job_wait::storage})
        EXPECT_TRUE(is_unbounded(w)) << to_string(w);
}

TEST(job_json, elapsed_remaining_and_percent_follow_the_state) {
    struct row {
        const char* what;
        job_state state;
        std::optional<job_clock::time_point> started;
        std::optional<job_clock::time_point> finished;
        std::optional<double> remaining;
        std::size_t done, total;
        json elapsed, remaining_json, percent;
    };
    const row rows[] = {
        {"queued: nothing elapsed", job_state::queued, std::nullopt, std::nullopt, 5.0, 0, 4, 0.0, 5.0, 0.0},
        {"waits for a trigger", job_state::running, at(), std::nullopt, std::nullopt, 1, 3, 10.0, nullptr,
         33.3},
        {"finished: elapsed stops", job_state::succeeded, at(), at(4000ms), 3.0, 4, 4, 4.0, 0.0, 100.0},
        {"no steps, succeeded", job_state::succeeded, at(), at(), std::nullopt, 0, 0, 0.0, 0.0, 100.0},
        {"no steps, failed", job_state::failed, at(), at(), std::nullopt, 0, 0, 0.0, 0.0, 0.0},
        {"interrupted keeps remaining", job_state::interrupted, at(), std::nullopt, 2.5, 2, 4, 10.0, 2.5,
         50.0},
    };
    for (const auto& r : rows) {
        job_record job;
        job.state = r.state;
        job.started = r.started;
        job.finished = r.finished;
        job.progress.remaining_s = r.remaining;
        job.progress.steps_done = r.done;
        job.progress.steps_total = r.total;
        const auto p = to_json(job, at(10000ms))["progress"];
        EXPECT_EQ(p["elapsed_s"], r.elapsed) << r.what;
        EXPECT_EQ(p["remaining_s"], r.remaining_json) << r.what;
        EXPECT_EQ(p["percent"], r.percent) << r.what;
    }
}

TEST(job_json, the_plan_lists_steps_commands_and_bounds) {
    job_plan plan;
    plan.path = "host";
    plan.summary = "3 points";
    plan.steps.push_back({"point 1", position_um{{'X', 1000}, {'Y', -2.5}}, 1.25, false});
    plan.steps.push_back({"point 2", std::nullopt, 0, true});
    plan.steps.push_back({"enable", std::nullopt, 0, false});
    plan.commands = {"M X=10000 Y=-25", "CCB Z=1"};
    plan.commands_omitted = 7;
    plan.estimated_s = 1.25;
    plan.bounds.include({{'X', 1000}, {'Y', -2.5}});
    plan.bounds.include({{'X', -50}, {'Y', 3}});
    plan.warnings = {"slow"};

    const auto j = to_json(plan, 2);
    EXPECT_EQ(j["path"], "host");
    EXPECT_EQ(j["summary"], "3 points");
    EXPECT_EQ(j["steps_total"], 3);
    ASSERT_EQ(j["steps"].size(), 2u) << "at most max_steps";
    EXPECT_EQ(j["steps"][0],
              (json{{"name", "point 1"}, {"target", {{"X", 1000.0}, {"Y", -2.5}}}, {"estimated_s", 1.25}}));
    EXPECT_TRUE(j["steps"][1]["target"].is_null());
    EXPECT_EQ(j["steps"][1]["waits_for_trigger"], true);
    EXPECT_EQ(j["commands"], (json{"M X=10000 Y=-25", "CCB Z=1"}));
    EXPECT_EQ(j["commands_omitted"], 7);
    EXPECT_EQ(j["bounds"]["min"], (json{{"X", -50.0}, {"Y", -2.5}}));
    EXPECT_EQ(j["bounds"]["max"], (json{{"X", 1000.0}, {"Y", 3.0}}));
    EXPECT_EQ(j["warnings"], (json{"slow"}));

    const auto dry = dry_run_json("sim1", job_type::scan, plan);
    EXPECT_EQ(dry["dry_run"], true);
    EXPECT_EQ(dry["controller"], "sim1");
    EXPECT_EQ(dry["type"], "scan");
    EXPECT_EQ(dry["plan"]["steps"].size(), 3u);

    EXPECT_TRUE(to_json(job_plan{})["bounds"].is_null()) << "no targets, no box";
}

TEST(job_json, events_carry_the_type_and_the_progress) {
    const auto job = running_job();
    const auto state = state_event(job, at(11200ms));
    EXPECT_EQ(state["type"], "state");
    EXPECT_EQ(state["state"], "running");
    EXPECT_EQ(state["reason"], "");
    // The record without its spec (it never changes; an inline program would be stored each time).
    auto record = to_json(job, at(11200ms));
    record.erase("spec");
    EXPECT_EQ(state["job"], record);
    EXPECT_FALSE(state["job"].contains("spec"));
    EXPECT_EQ(state["job"]["type"], "array");
    EXPECT_TRUE(state["waiting_for"].is_null());
    EXPECT_TRUE(state["eta"].is_null());
    auto waiting = job;
    waiting.progress.waiting_for = job_wait::next;
    waiting.progress.eta = at(80500ms);
    const auto waits = state_event(waiting, at(11200ms));
    EXPECT_EQ(waits["waiting_for"], "next");
    EXPECT_EQ(waits["eta"], "2026-11-22T05:31:20.623Z");
    EXPECT_EQ(waits["job"]["progress"]["waiting_for"], "next");

    // The detail adds fields; it cannot override the manager's.
    auto stepped = job;
    stepped.progress.eta = at(81323ms);
    const auto step =
        step_event(stepped, 11, "B1",
                   {{"well", "B1"}, {"position", {{"X", 1.0}}}, {"index", 99}, {"at", "then"}}, at(11200ms));
    EXPECT_EQ(step["type"], "step");
    EXPECT_EQ(step["index"], 11);
    EXPECT_EQ(step["name"], "B1");
    EXPECT_EQ(step["well"], "B1");
    EXPECT_EQ(step["position"]["X"], 1.0);
    EXPECT_EQ(step["steps_done"], 12);
    EXPECT_EQ(step["steps_total"], 96);
    EXPECT_DOUBLE_EQ(step["percent"].get<double>(), 12.5);
    EXPECT_DOUBLE_EQ(step["remaining_s"].get<double>(), 70.123);
    EXPECT_TRUE(step["waiting_for"].is_null());
    EXPECT_EQ(step["eta"], "2026-11-22T05:31:21.446Z");
    EXPECT_EQ(step["at"], "2026-11-22T05:30:11.323Z") << "when the step ended, not the detail's";
    EXPECT_EQ(job_topic(job.id), "jobs/j-01JD0000000000000000000000");
}

}  // namespace
}  // namespace gw::jobs
