// The job manager across failures: a crash of the manager mid-job (destroyed without shutdown, a new
// one on the same SQLite directory), queued jobs after a restart, a controller unplugged mid-job, a
// clean shutdown, storage errors.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <sys/stat.h>

#include "gateway/jobs/store/job_store.hpp"
#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;
using kind = operation_error_kind;

class manager_recovery_test : public manager_fixture {};

json far_corner_points(double span_um) {
    return {{"action", "set"},
            {"points",
             json::array({json{{"X", span_um}, {"Y", 0}, {"Z", 0}}, json{{"X", 0}, {"Y", span_um}, {"Z", 10}},
                          json{{"X", span_um}, {"Y", span_um}, {"Z", 20}}})},
            {"enable", true}};
}

// Commands that change something (not the STATUS / WHERE polls of a move still being waited for).
std::size_t actions_in(const std::vector<std::string>& commands) {
    return static_cast<std::size_t>(std::count_if(commands.begin(), commands.end(), [](const std::string& c) {
        return c.starts_with("M ") || c.starts_with("CCB") || c.starts_with("TTL") || c == "\\\\";
    }));
}

TEST_F(manager_recovery_test, a_crash_mid_job_leaves_it_interrupted_and_resume_finishes_it) {
    add_sim("sim3", "planar", 3);
    start();
    auto a = submit("sim3", job_type::planar_correction, far_corner_points(5000));
    ASSERT_TRUE(a);
    const auto id = a->job.id;
    ASSERT_TRUE(wait_until([&] {
        auto j = job(id);
        return j && j->progress.steps_done >= 1;
    }));
    restart_manager();  // no shutdown: like kill -9

    ASSERT_TRUE(wait_state(id, job_state::interrupted));
    auto j = job(id);
    EXPECT_EQ(j->reason, "gateway restarted");
    EXPECT_GE(j->progress.steps_done, 1u);
    const auto done_at_restart = j->progress.steps_done;
    // The new manager sends nothing for it. The old manager's last command may still be on the wire
    // at the restart (its trace lands when the reply comes), so the count starts once all is still.
    ASSERT_TRUE(wait_until([&] { return !registry_->get("sim3")->busy; }));
    std::this_thread::sleep_for(300ms);
    const auto actions_at_restart = actions_in(commands_of(id));
    std::this_thread::sleep_for(300ms);
    EXPECT_EQ(actions_in(commands_of(id)), actions_at_restart);
    EXPECT_EQ(job(id)->state, job_state::interrupted);

    auto resumed = resume(id);
    ASSERT_TRUE(resumed) << resumed.error().message;
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    EXPECT_EQ(job(id)->progress.steps_done, 4u);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["points"], 3);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["enabled"], true);
    // The resumed run started at the first step not done: no CCB Z=7 (clear) again, no earlier point.
    const auto all = commands_of(id);
    EXPECT_EQ(std::count(all.begin(), all.end(), "CCB Z=7"), 1);
    EXPECT_EQ(std::count(all.begin(), all.end(), "CCB Z=1"), 1);
    (void)done_at_restart;
    // History survived: the stored events hold the whole story.
    auto events = manager_->events(id, 1000);
    ASSERT_TRUE(events) << events.error().message;
    std::vector<std::string> states;
    for (const auto& e : *events)
        if (e.value("type", "") == "state") states.push_back(e.value("state", ""));
    EXPECT_EQ(states, (std::vector<std::string>{"queued", "running", "interrupted", "queued", "running",
                                                "succeeded"}));
}

class manager_restart_queued_test : public manager_fixture, public ::testing::WithParamInterface<bool> {};

TEST_P(manager_restart_queued_test, queued_jobs_are_kept_and_started_again_only_when_configured) {
    restart_queued_ = GetParam();
    add_sim("sim3", "planar", 2);
    start();
    auto a = submit("sim3", job_type::planar_correction, far_corner_points(5000));
    auto b = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_TRUE(a && b);
    ASSERT_TRUE(wait_state(a->job.id, job_state::running));
    restart_manager();
    ASSERT_TRUE(wait_state(a->job.id, job_state::interrupted));
    if (restart_queued_) {
        ASSERT_TRUE(wait_state(b->job.id, job_state::succeeded));
    } else {
        // Kept, not started: the stage finishes the old move and nothing is sent for b.
        ASSERT_TRUE(wait_until([&] { return !registry_->get("sim3")->busy; }));
        EXPECT_EQ(job(b->job.id)->state, job_state::queued);
        EXPECT_TRUE(commands_of(b->job.id).empty());
        // A client may start it.
        auto resumed = resume(b->job.id);
        ASSERT_TRUE(resumed) << resumed.error().message;
        ASSERT_TRUE(wait_state(b->job.id, job_state::succeeded));
    }
    EXPECT_EQ(job(a->job.id)->state, job_state::interrupted);
}

INSTANTIATE_TEST_SUITE_P(on_off, manager_restart_queued_test, ::testing::Bool());

// The crashed run is owed a HALT before anything else reaches its controller. When the controller is
// away over the restart, the queued job that starts when it is back sends that HALT itself, before its
// own commands (put_back_before_run): the HALT belongs to the crashed run and must not stop this one.
TEST_F(manager_recovery_test, a_queued_job_started_after_a_restart_is_not_stopped_by_the_crashed_runs_halt) {
    restart_queued_ = true;
    auto s = add_sim("sim3", "planar", 2);
    start();
    auto a = submit("sim3", job_type::planar_correction, far_corner_points(5000));
    auto b = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_TRUE(a && b);
    ASSERT_TRUE(wait_state(a->job.id, job_state::running));
    s->unplug();
    const auto before_restart = observer_->locked([&] { return observer_->traces.size(); });
    restart_manager();
    ASSERT_TRUE(wait_state(a->job.id, job_state::interrupted));
    s->replug();
    ASSERT_TRUE(wait_state(b->job.id, job_state::succeeded));
    EXPECT_EQ(commands_of(b->job.id), std::vector<std::string>{"CCB Z=7"});
    // The crashed run's HALT went out before b's command (under the put-back's or the recovery's id).
    // Traces are kept as commands end: a's command cut off by the unplug may be among those since the
    // restart, so b's is found by its request id.
    const auto wire = observer_->locked([&] {
        std::vector<std::pair<std::string, std::string>> out;  // {request id, wire text without CR}
        for (auto t = observer_->traces.begin() + before_restart; t != observer_->traces.end(); ++t) {
            auto w = t->wire;
            if (w.ends_with("\\r")) w.resize(w.size() - 2);
            out.emplace_back(t->request_id, w);
        }
        return out;
    });
    const auto halt =
        std::find_if(wire.begin(), wire.end(), [](const auto& t) { return t.second == "\\\\"; });
    const auto clear =
        std::find_if(wire.begin(), wire.end(), [&](const auto& t) { return t.first == "job-" + b->job.id; });
    ASSERT_NE(halt, wire.end()) << testing::PrintToString(wire);
    ASSERT_NE(clear, wire.end()) << testing::PrintToString(wire);
    EXPECT_LT(halt, clear) << testing::PrintToString(wire);
}

TEST_F(manager_recovery_test, an_unplugged_controller_pauses_the_job_and_resume_finishes_it_after_replug) {
    auto s = add_sim("sim3", "planar", 2);
    start();
    auto a = submit("sim3", job_type::planar_correction, far_corner_points(5000));
    auto b = submit("sim3", job_type::planar_correction, {{"action", "disable"}});
    ASSERT_TRUE(a && b);
    const auto id = a->job.id;
    ASSERT_TRUE(wait_until([&] {
        auto j = job(id);
        return j && j->state == job_state::running && j->progress.steps_done >= 1;
    }));
    s->unplug();
    ASSERT_TRUE(wait_state(id, job_state::paused));
    auto j = job(id);
    EXPECT_TRUE(j->reason.starts_with("controller disconnected")) << j->reason;
    // Resume is refused while it is away; the queued job waits behind the paused one.
    auto early = resume(id);
    ASSERT_FALSE(early);
    EXPECT_EQ(early.error().kind, kind::not_connected);
    EXPECT_EQ(job(b->job.id)->state, job_state::queued);

    s->replug();
    ASSERT_TRUE(wait_until([&] { return registry_->ready(); })) << "never reconnected";
    auto resumed = resume(id);
    ASSERT_TRUE(resumed) << resumed.error().message;
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    EXPECT_EQ(job(id)->progress.steps_done, 4u);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["points"], 3);
    ASSERT_TRUE(wait_state(b->job.id, job_state::succeeded));
}

TEST_F(manager_recovery_test, shutdown_halts_running_jobs_and_marks_them_interrupted) {
    add_sim("sim3", "planar", 1);
    start();
    auto a = submit("sim3", job_type::planar_correction, far_corner_points(20000));
    ASSERT_TRUE(a);
    const auto id = a->job.id;
    ASSERT_TRUE(wait_until([&] {
        auto x = position("sim3", 'X');
        return x && *x > 200;
    }));
    shutdown_manager();
    manager_shut_ = true;
    const auto sent = commands_of(id);
    EXPECT_NE(std::find(sent.begin(), sent.end(), "\\\\"), sent.end()) << "no HALT";
    EXPECT_NE(std::find(sent.begin(), sent.end(), "TTL Y=0"), sent.end()) << "no TTL Y=0";
    // The store was flushed and closed: a new manager reads the state.
    manager_.reset();
    open_manager();
    manager_shut_ = false;
    auto j = job(id);
    ASSERT_TRUE(j);
    EXPECT_EQ(j->state, job_state::interrupted);
    EXPECT_EQ(j->reason, "gateway shutting down");
    ASSERT_TRUE(wait_until([&] { return !registry_->get("sim3")->busy; }));
    EXPECT_LT(*position("sim3", 'X'), 19000);
}

TEST_F(manager_recovery_test, an_unopenable_store_is_an_error_not_a_crash) {
    add_sim("sim3", "planar");
    start();
    // A file where the directory should be.
    const std::string file = dir_ + "/not-a-directory";
    { std::ofstream(file) << "x"; }
    auto s = settings();
    s.storage_path = file;
    auto m = job_manager::create(gw_io_.io.get_executor(), *registry_, hub_, leases_, s);
    ASSERT_FALSE(m);
    EXPECT_EQ(m.error().kind, kind::storage_unavailable);
}

}  // namespace
}  // namespace gw::jobs::test

namespace gw::jobs::test {
namespace {

class manager_storage_test : public manager_fixture {};

TEST_F(manager_storage_test, a_full_store_fails_the_submission_and_the_service_keeps_working) {
    add_sim("sim3", "planar");
    storage_max_size_mb_ = 1;
    start();
    auto first = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_TRUE(first) << first.error().message;
    ASSERT_TRUE(wait_state(first->job.id, job_state::succeeded));
    // Big idempotency keys fill the 1 MB database quickly.
    std::optional<operation_error> refused;
    std::size_t stored = 1;
    for (int i = 0; i < 40 && !refused; ++i) {
        auto r = submit("sim3", job_type::planar_correction, {{"action", "disable"}},
                        std::string(200 * 1024, static_cast<char>('a' + i % 26)) + std::to_string(i));
        if (r)
            ++stored;
        else
            refused = r.error();
    }
    ASSERT_TRUE(refused) << "the store never filled up";
    EXPECT_EQ(refused->kind, operation_error_kind::storage_unavailable);
    EXPECT_FALSE(refused->message.empty());
    // Nothing of the refused submission was queued; what was stored is still readable.
    auto page = manager_->list(job_filter{});
    ASSERT_TRUE(page) << page.error().message;
    EXPECT_EQ(page->jobs.size(), std::min<std::size_t>(stored, 50));
    EXPECT_TRUE(job(first->job.id));
    // The stored jobs run while the store takes their history. One whose history it refuses pauses at
    // its next checkpoint (nothing runs unrecorded) and keeps the controller: the jobs after it wait.
    const auto settled = [&] {
        bool paused = false, queued = false;
        for (const auto& j : page->jobs) {
            auto r = job(j.id);
            if (!r || r->state == job_state::running) return false;
            paused = paused || r->state == job_state::paused;
            queued = queued || r->state == job_state::queued;
        }
        return !queued || paused;
    };
    ASSERT_TRUE(wait_until(settled));
    bool held = false;
    for (auto it = page->jobs.rbegin(); it != page->jobs.rend(); ++it) {  // oldest first
        auto r = job(it->id);
        ASSERT_TRUE(r);
        if (held) {
            EXPECT_EQ(r->state, job_state::queued) << it->id;
        } else if (r->state == job_state::paused) {
            EXPECT_TRUE(r->reason.starts_with("storage unavailable: ")) << r->reason;
            held = true;
        } else {
            EXPECT_EQ(r->state, job_state::succeeded) << it->id << ": " << r->reason;
        }
    }
    // Dry runs still plan.
    EXPECT_TRUE(
        submit("sim3", job_type::planar_correction, {{"action", "clear"}}, std::nullopt, std::nullopt, true));
}

}  // namespace
}  // namespace gw::jobs::test
