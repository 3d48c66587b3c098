// What a job waits for and when it is expected to end (progress.waiting_for and progress.eta), as the
// manager keeps them in the record and publishes them on jobs/<id>: a `next` wait with the motion still
// ahead in remaining_s, an eta estimated again at every step, a queued job that waits for its
// controller, a long dwell shown as a timer, a disconnected controller, and ended jobs.
#include <charconv>
#include <chrono>
#include <string>
#include <vector>

#include "gateway/jobs/job_json.hpp"
#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;
using std::chrono::milliseconds;

// A host-driven row of `wells` wells `pitch_mm` apart from (0, 0).
json row(int wells, double pitch_mm, const std::string& advance, int dwell_ms = 0) {
    json spec = {
        {"grid", {{"columns", wells}, {"rows", 1}, {"column_step_mm", pitch_mm}, {"row_step_mm", -1}}},
        {"a1", {{"X", 0}, {"Y", 0}}},
        {"advance", advance},
        {"mode", "host"}};
    if (dwell_ms > 0) spec["dwell_ms"] = dwell_ms;
    return spec;
}

// "2026-11-22T05:30:00.123Z" -> milliseconds since the epoch.
std::int64_t epoch_ms_of(const std::string& t) {
    auto number = [&](std::size_t at, std::size_t length) {
        int v = 0;
        std::from_chars(t.data() + at, t.data() + at + length, v);
        return v;
    };
    using namespace std::chrono;
    const sys_days day{year{number(0, 4)} / month{static_cast<unsigned>(number(5, 2))} / number(8, 2)};
    const auto time =
        hours{number(11, 2)} + minutes{number(14, 2)} + seconds{number(17, 2)} + milliseconds{number(20, 3)};
    return duration_cast<milliseconds>((day + time).time_since_epoch()).count();
}

class manager_progress_test : public manager_fixture {
  protected:
    std::vector<json> of_type(const std::string& id, const std::string& type) {
        std::vector<json> out;
        for (const auto& e : sink_->of(id))
            if (e.value("type", "") == type) out.push_back(e);
        return out;
    }
    std::size_t steps_done(const std::string& id) {
        auto j = job(id);
        return j ? j->progress.steps_done : 0;
    }
    bool waiting_for(const std::string& id, std::optional<job_wait> w) {
        auto j = job(id);
        return j && j->progress.waiting_for == w;
    }
    // The published state events of a job whose waiting_for is `w` (null: "").
    std::size_t state_events_waiting(const std::string& id, const std::string& w) {
        std::size_t n = 0;
        for (const auto& e : of_type(id, "state"))
            if ((w.empty() && e["waiting_for"].is_null()) || e["waiting_for"] == w) ++n;
        return n;
    }
};

TEST_F(manager_progress_test, a_next_advance_job_shows_its_wait_apart_from_the_motion_still_ahead) {
    add_sim("sim2", "plain", 20);
    start();
    auto submitted = submit("sim2", job_type::array, row(3, 2, "next"));
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    // The waits are not in the estimate, the moves are: known from the start.
    ASSERT_TRUE(submitted->job.progress.remaining_s);
    EXPECT_GT(*submitted->job.progress.remaining_s, 0);

    // After the first well it waits for a `next` call: still running, and says what for.
    ASSERT_TRUE(wait_until([&] { return waiting_for(id, job_wait::next); })) << "never waited for next";
    auto waiting = *job(id);
    EXPECT_EQ(waiting.state, job_state::running);
    EXPECT_EQ(waiting.reason, "");
    EXPECT_EQ(waiting.progress.steps_done, 1u);
    ASSERT_TRUE(waiting.progress.remaining_s) << "the two moves ahead are known";
    EXPECT_GT(*waiting.progress.remaining_s, 0);
    EXPECT_LE(*waiting.progress.remaining_s, *submitted->job.progress.remaining_s);
    EXPECT_FALSE(waiting.progress.eta) << "its end depends on when `next` comes";
    const auto shown = to_json(waiting, job_clock::now())["progress"];
    EXPECT_EQ(shown["waiting_for"], "next");
    EXPECT_TRUE(shown["eta"].is_null());
    EXPECT_TRUE(shown["remaining_s"].is_number());
    // Announced on the topic without polling, and the list shows it as get() does.
    ASSERT_TRUE(wait_until([&] { return state_events_waiting(id, "next") >= 1; })) << "no event for the wait";
    job_filter running;
    running.controller = "sim2";
    running.state = job_state::running;
    auto page = manager_->list(running);
    ASSERT_TRUE(page) << page.error().message;
    ASSERT_EQ(page->jobs.size(), 1u);
    EXPECT_EQ(page->jobs[0].progress.waiting_for, job_wait::next);

    // `next`: the answer shows the wait over and an eta of now + the motion ahead.
    const auto before = job_clock::now();
    auto advanced = next(id);
    ASSERT_TRUE(advanced) << advanced.error().message;
    EXPECT_FALSE(advanced->progress.waiting_for);
    ASSERT_TRUE(advanced->progress.eta);
    const auto ahead = std::chrono::duration_cast<job_clock::duration>(
        std::chrono::duration<double>(*waiting.progress.remaining_s));
    EXPECT_GE(*advanced->progress.eta, before + ahead - milliseconds(1));
    EXPECT_LE(*advanced->progress.eta, job_clock::now() + ahead + milliseconds(1));

    ASSERT_TRUE(wait_until([&] { return steps_done(id) == 2 && waiting_for(id, job_wait::next); }));
    ASSERT_TRUE(next(id));
    ASSERT_TRUE(wait_state(id, job_state::succeeded));

    // Ended: nothing to wait for, no end to expect, nothing remaining.
    const auto ended = *job(id);
    EXPECT_FALSE(ended.progress.waiting_for);
    EXPECT_FALSE(ended.progress.eta);
    const auto final_json = to_json(ended, job_clock::now())["progress"];
    EXPECT_TRUE(final_json["waiting_for"].is_null());
    EXPECT_TRUE(final_json["eta"].is_null());
    EXPECT_EQ(final_json["remaining_s"], 0.0);
    // Each wait started and ended with an event: two waits, two ends (and the running/queued events).
    ASSERT_TRUE(wait_until([&] {
        const auto e = sink_->of(id);
        return !e.empty() && e.back().value("state", "") == "succeeded";
    }));
    EXPECT_EQ(state_events_waiting(id, "next"), 2u);
}

TEST_F(manager_progress_test, the_eta_is_estimated_again_at_every_step) {
    add_sim("sim2", "plain", 5);
    start();
    auto submitted = submit("sim2", job_type::array, row(4, 1.5, "timer"));
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    ASSERT_TRUE(wait_until([&] { return of_type(id, "step").size() == 4; }));
    // The job's record says succeeded before its last state event has reached the hub: wait for it.
    ASSERT_TRUE(wait_until([&] {
        const auto events = of_type(id, "state");
        return !events.empty() && events.back()["state"] == "succeeded";
    }));

    // The running event: started now, ends after the whole plan's estimate.
    const auto states = of_type(id, "state");
    ASSERT_GE(states.size(), 2u);
    const auto& run = states[1];
    ASSERT_EQ(run["state"], "running");
    ASSERT_TRUE(run["eta"].is_string()) << run.dump();
    const double planned = run["job"]["progress"]["remaining_s"].get<double>();
    // Both are truncated to the millisecond, remaining_s rounded to it.
    EXPECT_NEAR(epoch_ms_of(run["eta"]) - epoch_ms_of(run["job"]["updated"]), planned * 1000, 2);

    // Every step: eta = when it ended + what remains, so it moves with the steps; the last one ends now.
    const auto steps = of_type(id, "step");
    std::int64_t previous_at = 0;
    for (const auto& s : steps) {
        ASSERT_TRUE(s["eta"].is_string() && s["at"].is_string()) << s.dump();
        EXPECT_TRUE(s["waiting_for"].is_null()) << s.dump();
        const auto at = epoch_ms_of(s["at"]);
        EXPECT_GT(at, previous_at) << "steps end one after the other";
        previous_at = at;
        EXPECT_NEAR(epoch_ms_of(s["eta"]) - at, s["remaining_s"].get<double>() * 1000, 2) << s.dump();
    }
    EXPECT_EQ(steps.back()["remaining_s"], 0.0);
    EXPECT_EQ(steps.back()["eta"], steps.back()["at"]);
    // The final state event: no eta (finished says when it ended).
    EXPECT_TRUE(states.back()["eta"].is_null());
    EXPECT_TRUE(states.back()["job"]["finished"].is_string());
}

TEST_F(manager_progress_test, a_queued_job_waits_for_its_controller_until_it_runs) {
    add_sim("sim2", "plain", 20);
    start();
    auto first = submit("sim2", job_type::array, row(2, 1, "next"));
    ASSERT_TRUE(first) << first.error().message;
    ASSERT_TRUE(wait_until([&] { return waiting_for(first->job.id, job_wait::next); }));
    auto second = submit("sim2", job_type::array, row(1, 1, "timer"));
    ASSERT_TRUE(second) << second.error().message;
    const auto id = second->job.id;
    EXPECT_EQ(second->job.state, job_state::queued);
    EXPECT_EQ(second->job.progress.waiting_for, job_wait::controller);
    EXPECT_FALSE(second->job.progress.eta) << "when it starts is not known";
    EXPECT_EQ(job(id)->progress.waiting_for, job_wait::controller);

    ASSERT_TRUE(cancel(first->job.id));
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    EXPECT_FALSE(job(id)->progress.waiting_for);
    ASSERT_TRUE(wait_until([&] { return of_type(id, "state").size() >= 3; }));
    const auto states = of_type(id, "state");
    EXPECT_EQ(states[0]["state"], "queued");
    EXPECT_EQ(states[0]["waiting_for"], "controller");
    EXPECT_EQ(states[1]["state"], "running");
    EXPECT_TRUE(states[1]["waiting_for"].is_null());
    EXPECT_TRUE(states[1]["eta"].is_string());
}

TEST_F(manager_progress_test, a_long_dwell_is_a_timer_wait_that_keeps_the_eta) {
    add_sim("sim2", "plain", 20);
    start();
    auto submitted = submit("sim2", job_type::array, row(2, 1, "timer", 1200));
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return waiting_for(id, job_wait::timer); })) << "no timer wait seen";
    EXPECT_TRUE(job(id)->progress.eta) << "a timer's end is known";
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    ASSERT_TRUE(wait_until([&] {
        const auto e = sink_->of(id);
        return !e.empty() && e.back().value("state", "") == "succeeded";
    }));
    // Per well: the dwell starts (timer) and ends (null) before its step event; the eta stays.
    std::vector<std::string> seen;
    json eta_before_wait;
    for (const auto& e : sink_->of(id)) {
        const auto type = e.value("type", "");
        if (type == "step") {
            seen.push_back("step");
            eta_before_wait = e["eta"];
        } else if (e["waiting_for"] == "timer") {
            seen.push_back("timer");
            EXPECT_EQ(e["eta"], eta_before_wait) << "a timer wait moved the eta: " << e.dump();
        } else {
            seen.push_back(e.value("state", ""));
            if (e.value("state", "") == "running") eta_before_wait = e["eta"];
        }
    }
    EXPECT_EQ(seen, (std::vector<std::string>{"queued", "running", "timer", "running", "step", "timer",
                                              "running", "step", "succeeded"}));
}

TEST_F(manager_progress_test, a_disconnected_controller_is_waited_for_until_it_is_back) {
    auto sim = add_sim("sim2", "plain", 20);
    start();
    auto submitted = submit("sim2", job_type::array, row(3, 1, "next"));
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return waiting_for(id, job_wait::next); }));
    sim->unplug();
    ASSERT_TRUE(wait_state(id, job_state::paused));
    EXPECT_EQ(job(id)->progress.waiting_for, job_wait::controller);
    EXPECT_FALSE(job(id)->progress.eta);

    sim->replug();
    ASSERT_TRUE(wait_until([&] { return registry_->ready(); })) << "never reconnected";
    // Back: the job waits for a client's resume now, and a page learns it from the topic.
    ASSERT_TRUE(wait_until([&] { return waiting_for(id, std::nullopt); }))
        << "still waits for the controller";
    EXPECT_EQ(job(id)->state, job_state::paused);
    ASSERT_TRUE(wait_until([&] {
        const auto e = sink_->of(id);
        return !e.empty() && e.back().value("state", "") == "paused" && e.back()["waiting_for"].is_null();
    })) << "no event when the controller came back";
    EXPECT_EQ(state_events_waiting(id, "controller"), 1u);
    ASSERT_TRUE(cancel(id));
}

}  // namespace
}  // namespace gw::jobs::test
