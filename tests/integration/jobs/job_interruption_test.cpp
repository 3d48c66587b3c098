// Every job type on both of its paths (firmware module and host-driven), interrupted three ways:
// paused after a step and resumed, the manager crashed mid-job (like kill -9 of the gateway) and the
// interrupted job resumed, the controller unplugged mid-job and the paused job resumed after replug.
// Each time the job must end succeeded with every step reported, and nothing may be sent for it
// between the crash and the resume.
#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "gateway/jobs/kinds/safe_outputs.hpp"
#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;

struct interruption_case {
    const char* name;
    const char* preset;  // "full": ARRAY, SCAN, RING BUFFER modules; "plain": none of them
    job_type type;
    const char* spec;
    const char* path;          // the plan's path
    std::size_t steps;         // steps in the plan
    bool pause_between_steps;  // false: a firmware scan cannot be held mid-scan (plan warning)
};

// Test names and ctest labels show the case's name, not its bytes.
void PrintTo(const interruption_case& c, std::ostream* os) {
    *os << c.name;
}

// Moves of a few mm at 5.5 mm/s take about a second of simulated time; time_scale 5 makes that
// ~200 ms of real time per step, room enough to interrupt a job between its first and last step.
constexpr const char* grid_spec =
    R"({"grid": {"columns": 4, "rows": 3, "column_step_mm": 4, "row_step_mm": 4}, "a1": {"X": 0, "Y": 0}})";

const interruption_case cases[] = {
    {"array_firmware", "full", job_type::array, grid_spec, "firmware", 12, true},
    {"array_host", "plain", job_type::array, grid_spec, "host", 12, true},
    {"scan_firmware", "full", job_type::scan,
     R"({"fast": {"start_mm": 0, "stop_mm": 0.2, "encoder_divide": 24},
         "slow": {"start_mm": 0, "stop_mm": 0.9, "lines": 10}, "speed_mm_s": 0.1})",
     "firmware", 10, false},
    {"scan_host", "plain", job_type::scan,
     R"({"fast": {"start_mm": 0, "stop_mm": 0.2, "encoder_divide": 24},
         "slow": {"start_mm": 0, "stop_mm": 0.9, "lines": 10}, "speed_mm_s": 0.1})",
     "host", 10, true},
    {"ring_buffer_firmware", "full", job_type::ring_buffer,
     R"({"positions": [{"X": 3000, "Y": 0}, {"X": 3000, "Y": 3000}, {"X": 0, "Y": 3000}, {"X": 0, "Y": 0}],
         "repeat": true, "cycles": 3, "delay_ms": 100})",
     "firmware", 12, true},
    {"ring_buffer_host", "plain", job_type::ring_buffer,
     R"({"positions": [{"X": 3000, "Y": 0}, {"X": 3000, "Y": 3000}, {"X": 0, "Y": 3000}, {"X": 0, "Y": 0}],
         "repeat": true, "cycles": 3, "delay_ms": 100})",
     "host", 12, true},
};

class job_interruption_test : public manager_fixture,
                              public ::testing::WithParamInterface<interruption_case> {
  protected:
    std::shared_ptr<sim::simulator> sim_;

    std::string submit_case() {
        const auto& c = GetParam();
        sim_ = add_sim("sim1", c.preset, 5);
        start();
        auto submitted = submit("sim1", c.type, json::parse(c.spec));
        EXPECT_TRUE(submitted) << submitted.error().message;
        if (!submitted) return {};
        EXPECT_EQ(submitted->job.plan_path, c.path);
        EXPECT_EQ(submitted->job.progress.steps_total, c.steps);
        return submitted->job.id;
    }
    std::size_t steps_done(const std::string& id) {
        auto j = job(id);
        return j ? j->progress.steps_done : 0;
    }
    bool wait_steps(const std::string& id, std::size_t n) {
        return wait_until([&] { return steps_done(id) >= n; });
    }
    // The simulated controller has stood still (no move, no scan, no autoplay) for 300 ms.
    bool wait_quiet() {
        int still = 0;
        return wait_until([&] {
            const auto s = sim_state("sim1");
            const auto flag = [&](const char* module, const char* key) {
                return s.contains(module) && s[module].value(key, false);
            };
            const bool quiet =
                !s.value("busy", true) && !flag("scan", "running") && !flag("ring_buffer", "autoplay");
            still = quiet ? still + 1 : 0;
            return still >= 30;
        });
    }
    // The names of the job's step events; every planned step must be among them.
    void expect_every_step_reported(const std::string& id, std::size_t max_repeats) {
        const auto& c = GetParam();
        std::map<std::string, std::size_t> seen;
        ASSERT_TRUE(wait_until([&] {
            seen.clear();
            for (const auto& e : sink_->of(id))
                if (e.value("type", "") == "step") ++seen[e.value("name", "")];
            return seen.size() >= c.steps;
        })) << seen.size()
            << " distinct steps reported of " << c.steps;
        EXPECT_EQ(seen.size(), c.steps);
        for (const auto& [name, count] : seen)
            EXPECT_LE(count, max_repeats) << name;
    }
};

TEST_P(job_interruption_test, pause_after_a_step_then_resume_finishes_every_step) {
    const auto& c = GetParam();
    const auto id = submit_case();
    ASSERT_FALSE(id.empty());
    ASSERT_TRUE(wait_steps(id, 1));
    auto paused = pause(id);
    ASSERT_TRUE(paused) << paused.error().message;
    if (!c.pause_between_steps) {
        // The SCAN module cannot hold a scan: the pause is honoured when the scan is over, which ends
        // the job (its plan says so in a warning).
        ASSERT_TRUE(wait_state(id, job_state::succeeded));
        EXPECT_EQ(steps_done(id), c.steps);
        expect_every_step_reported(id, 1);
        return;
    }
    ASSERT_TRUE(wait_state(id, job_state::paused));
    const auto at_pause = steps_done(id);
    EXPECT_LT(at_pause, c.steps);
    ASSERT_TRUE(wait_quiet());
    const auto commands_at_pause = commands_of(id).size();
    std::this_thread::sleep_for(300ms);  // room to misbehave: nothing moves or is sent while paused
    EXPECT_EQ(steps_done(id), at_pause);
    EXPECT_EQ(commands_of(id).size(), commands_at_pause);
    EXPECT_EQ(job(id)->state, job_state::paused);

    auto resumed = resume(id);
    ASSERT_TRUE(resumed) << resumed.error().message;
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    EXPECT_EQ(steps_done(id), c.steps);
    expect_every_step_reported(id, 1);  // each step once: the resume went on from where it stopped
}

TEST_P(job_interruption_test, a_crash_mid_job_leaves_it_interrupted_and_resume_finishes_it) {
    const auto& c = GetParam();
    const auto id = submit_case();
    ASSERT_FALSE(id.empty());
    ASSERT_TRUE(wait_steps(id, 2));
    restart_manager();  // destroyed without shutdown, a new manager on the same SQLite store
    ASSERT_TRUE(wait_state(id, job_state::interrupted));
    auto j = job(id);
    EXPECT_EQ(j->reason, "gateway restarted");
    EXPECT_GE(j->progress.steps_done, 2u);
    EXPECT_LT(j->progress.steps_done, c.steps);
    // The controller may finish what it was doing by itself (a firmware scan or autoplay tour); the
    // new manager sends nothing for the job until asked.
    ASSERT_TRUE(wait_quiet());
    const auto commands_before_resume = commands_of(id).size();
    std::this_thread::sleep_for(300ms);
    EXPECT_EQ(commands_of(id).size(), commands_before_resume);
    // None of these jobs drives the TTL output: the restart has nothing to switch off either (what it
    // sends under the recovery's id are the job's restore commands: restore_recovery_test.cpp).
    EXPECT_TRUE(observer_->locked([&] {
        return std::none_of(observer_->traces.begin(), observer_->traces.end(), [&](const auto& t) {
            return t.request_id == safe_output_request_id(id) && t.wire.starts_with("TTL Y=");
        });
    }));

    auto resumed = resume(id);
    ASSERT_TRUE(resumed) << resumed.error().message;
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    EXPECT_EQ(steps_done(id), c.steps);
    // The step in progress at the crash may be done again (at most once more).
    expect_every_step_reported(id, 2);
    auto events = manager_->events(id, 10000);
    ASSERT_TRUE(events) << events.error().message;
    std::vector<std::string> states;
    for (const auto& e : *events)
        if (e.value("type", "") == "state") states.push_back(e.value("state", ""));
    EXPECT_EQ(states, (std::vector<std::string>{"queued", "running", "interrupted", "queued", "running",
                                                "succeeded"}));
}

TEST_P(job_interruption_test, an_unplugged_controller_pauses_the_job_and_resume_finishes_it) {
    const auto& c = GetParam();
    const auto id = submit_case();
    ASSERT_FALSE(id.empty());
    ASSERT_TRUE(wait_steps(id, 2));
    sim_->unplug();
    ASSERT_TRUE(wait_state(id, job_state::paused));
    const auto j = job(id);
    EXPECT_TRUE(j->reason.starts_with("controller disconnected")) << j->reason;
    EXPECT_LT(j->progress.steps_done, c.steps);

    sim_->replug();
    ASSERT_TRUE(wait_until([&] { return registry_->ready(); })) << "never reconnected";
    ASSERT_TRUE(wait_quiet());
    auto resumed = resume(id);
    ASSERT_TRUE(resumed) << resumed.error().message;
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    EXPECT_EQ(steps_done(id), c.steps);
    expect_every_step_reported(id, 2);
}

INSTANTIATE_TEST_SUITE_P(types_and_paths, job_interruption_test, ::testing::ValuesIn(cases),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace gw::jobs::test
