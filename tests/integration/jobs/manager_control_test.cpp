// The job manager's queueing and control: FIFO per controller, controllers in parallel, cancel with
// HALT and TTL low, pause after the current step and resume, a refused command failing the job,
// idempotency, leases (and jobs from before a lease), queue bound.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <future>

#include "devices/ms2000/error.hpp"
#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;
using kind = operation_error_kind;

class manager_control_test : public manager_fixture {
  protected:
    // The states the hub published for the job, once the last one is `last` (the hub delivers later). A
    // state event that repeats the state (what the job waits for changed) counts once.
    std::vector<std::string> published_states(const std::string& id, const std::string& last) {
        std::vector<std::string> states;
        const bool ended = wait_until([&] {
            states.clear();
            for (const auto& e : sink_->of(id))
                if (e.value("type", "") == "state" &&
                    (states.empty() || states.back() != e.value("state", "")))
                    states.push_back(e.value("state", ""));
            return !states.empty() && states.back() == last;
        });
        EXPECT_TRUE(ended) << "no \"" << last << "\" state event for " << id;
        return states;
    }
};

// Three given points far apart: a few seconds of motion per point at a low time scale.
json far_points(double span_um, bool enable = true) {
    return {{"action", "set"},
            {"points",
             json::array({json{{"X", span_um}, {"Y", 0}, {"Z", 0}}, json{{"X", 0}, {"Y", span_um}, {"Z", 10}},
                          json{{"X", span_um}, {"Y", span_um}, {"Z", 20}}})},
            {"enable", enable}};
}

TEST_F(manager_control_test, jobs_on_one_controller_run_one_at_a_time_in_submission_order) {
    add_sim("sim3", "planar");
    start();
    auto a = submit("sim3", job_type::planar_correction, far_points(3000));
    auto b = submit("sim3", job_type::planar_correction, {{"action", "disable"}});
    auto c = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_TRUE(a && b && c);
    // While the first runs, the others wait.
    ASSERT_TRUE(wait_state(a->job.id, job_state::running));
    EXPECT_EQ(job(b->job.id)->state, job_state::queued);
    EXPECT_EQ(job(c->job.id)->state, job_state::queued);
    ASSERT_TRUE(wait_state(c->job.id, job_state::succeeded));
    const auto ja = job(a->job.id), jb = job(b->job.id), jc = job(c->job.id);
    ASSERT_TRUE(ja && jb && jc);
    EXPECT_EQ(ja->state, job_state::succeeded);
    EXPECT_EQ(jb->state, job_state::succeeded);
    EXPECT_LE(*ja->finished, *jb->started);
    EXPECT_LE(*jb->finished, *jc->started);
    // On the wire too: every command of A before B's, B's before C's.
    std::vector<std::string> order;
    observer_->locked([&] {
        for (const auto& t : observer_->traces)
            if (t.request_id.starts_with("job-") && (order.empty() || order.back() != t.request_id))
                order.push_back(t.request_id);
        return 0;
    });
    EXPECT_EQ(order, (std::vector<std::string>{"job-" + a->job.id, "job-" + b->job.id, "job-" + c->job.id}));
    // Listing: newest first.
    auto page = manager_->list(job_filter{});
    ASSERT_TRUE(page) << page.error().message;
    ASSERT_EQ(page->jobs.size(), 3u);
    EXPECT_EQ(page->jobs.front().id, c->job.id);
}

// Planning happens on the planner's own thread: while one submission's plan is being computed (held
// here by the on_plan_started hook, as a program of megabytes would hold it), the manager answers a
// pause and a cancel of another controller's running job. Before, plan_job ran on the manager's strand,
// and both waited for the plan.
TEST_F(manager_control_test, a_plan_being_computed_holds_up_no_other_job) {
    add_sim("sim3", "planar", 1);  // real time: the job's first move takes seconds
    add_sim("sim4", "planar");
    // Shared with the hook, which the manager keeps until the fixture tears down.
    struct gate {
        std::promise<void> entered;
        std::promise<void> release;
        std::shared_future<void> released = release.get_future().share();
        std::atomic<bool> held{false};
    };
    auto g = std::make_shared<gate>();
    on_plan_started_ = [g](const std::string& controller) {
        if (controller != "sim4" || g->held.exchange(true)) return;
        g->entered.set_value();
        g->released.wait();
    };
    // Whatever fails below, the held plan is let go before the fixture tears down.
    struct release_at_exit {
        std::shared_ptr<gate> g;
        ~release_at_exit() {
            try {
                g->release.set_value();
            } catch (const std::future_error&) {
            }
        }
    } guard{g};
    start();
    auto a = submit("sim3", job_type::planar_correction, far_points(20000));
    ASSERT_TRUE(a) << a.error().message;
    ASSERT_TRUE(wait_state(a->job.id, job_state::running));

    submit_request r;
    r.controller = "sim4";
    r.type = job_type::planar_correction;
    r.spec = {{"action", "clear"}};
    r.request_id = "test-held-plan";
    auto b = call<submit_result>([&](auto h) { manager_->async_submit(std::move(r), std::move(h)); });
    ASSERT_EQ(g->entered.get_future().wait_for(30s), std::future_status::ready)
        << "sim4's plan never started";

    auto paused = pause(a->job.id);
    ASSERT_TRUE(paused) << paused.error().message;
    auto cancelled = cancel(a->job.id);
    ASSERT_TRUE(cancelled) << cancelled.error().message;
    EXPECT_EQ(cancelled->state, job_state::cancelled);
    EXPECT_EQ(b.wait_for(0s), std::future_status::timeout)
        << "sim4's submission was answered while its plan was held";

    g->release.set_value();
    auto planned = await(std::move(b));
    ASSERT_TRUE(planned) << planned.error().message;
    EXPECT_TRUE(wait_state(planned->job.id, job_state::succeeded));
}

TEST_F(manager_control_test, jobs_on_two_controllers_run_in_parallel) {
    add_sim("pa", "planar", 4);
    add_sim("pb", "planar", 4);
    start();
    auto a = submit("pa", job_type::planar_correction, far_points(4000));
    auto b = submit("pb", job_type::planar_correction, far_points(4000));
    ASSERT_TRUE(a && b);
    EXPECT_TRUE(wait_until([&] {
        auto ja = job(a->job.id), jb = job(b->job.id);
        return ja && jb && ja->state == job_state::running && jb->state == job_state::running;
    })) << "both jobs should be running at the same time";
    ASSERT_TRUE(wait_state(a->job.id, job_state::succeeded));
    ASSERT_TRUE(wait_state(b->job.id, job_state::succeeded));
}

TEST_F(manager_control_test, cancel_halts_the_move_and_sets_ttl_out_low) {
    add_sim("sim3", "planar", 1);  // real time: the first move takes seconds
    start();
    ttl_request high;
    high.output_high = true;
    ASSERT_TRUE(await(registry_->async_ttl("sim3", high, "test-ttl", net::use_future)));
    EXPECT_EQ(sim_state("sim3")["ttl"]["out0_mode"], 1);

    auto a = submit("sim3", job_type::planar_correction, far_points(20000));
    auto queued = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_TRUE(a && queued);
    ASSERT_TRUE(wait_state(a->job.id, job_state::running));
    ASSERT_TRUE(wait_until([&] {
        auto x = position("sim3", 'X');
        return x && *x > 200;
    })) << "the stage never moved";
    auto cancelled = cancel(a->job.id);
    ASSERT_TRUE(cancelled) << cancelled.error().message;
    EXPECT_EQ(cancelled->state, job_state::cancelled);
    EXPECT_EQ(cancelled->reason, "cancelled");

    const auto sent = commands_of(a->job.id);
    EXPECT_NE(std::find(sent.begin(), sent.end(), "\\\\"), sent.end()) << "no HALT";
    EXPECT_NE(std::find(sent.begin(), sent.end(), "TTL Y=0"), sent.end()) << "no TTL Y=0";
    EXPECT_EQ(sim_state("sim3")["ttl"]["out0_mode"], 0);
    // The stage stopped short of the first point.
    ASSERT_TRUE(wait_until([&] { return !registry_->get("sim3")->busy; }));
    auto x = position("sim3", 'X');
    ASSERT_TRUE(x);
    EXPECT_LT(*x, 19000);
    // No CCB point was stored after the cancel, and the queued job runs next.
    ASSERT_TRUE(wait_state(queued->job.id, job_state::succeeded));
    EXPECT_EQ(job(a->job.id)->state, job_state::cancelled);

    // Cancelling a finished job is refused; a queued one just becomes cancelled.
    auto again = cancel(a->job.id);
    ASSERT_FALSE(again);
    EXPECT_EQ(again.error().kind, kind::invalid_state);
}

TEST_F(manager_control_test, cancel_of_a_queued_job_sends_nothing) {
    add_sim("sim3", "planar", 4);
    start();
    auto a = submit("sim3", job_type::planar_correction, far_points(3000));
    auto b = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_TRUE(a && b);
    auto cancelled = cancel(b->job.id);
    ASSERT_TRUE(cancelled) << cancelled.error().message;
    EXPECT_EQ(cancelled->state, job_state::cancelled);
    ASSERT_TRUE(wait_state(a->job.id, job_state::succeeded));
    EXPECT_TRUE(commands_of(b->job.id).empty());
}

TEST_F(manager_control_test, pause_takes_effect_after_the_current_step_and_resume_finishes) {
    add_sim("sim3", "planar", 2);
    start();
    auto a = submit("sim3", job_type::planar_correction, far_points(6000));
    ASSERT_TRUE(a);
    const auto id = a->job.id;
    ASSERT_TRUE(wait_state(id, job_state::running));
    ASSERT_TRUE(wait_until([&] {
        auto x = position("sim3", 'X');
        return x && *x > 200;
    })) << "the move to point 1 never started";
    auto paused = pause(id);
    ASSERT_TRUE(paused) << paused.error().message;
    ASSERT_TRUE(wait_state(id, job_state::paused));
    const auto p = job(id);
    EXPECT_EQ(p->progress.steps_done, 1u) << "the move to point 1 finished, then the job paused";
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["points"], 1);
    // The stage stands (the registry's snapshot may lag a poll behind the simulator) and stays there.
    ASSERT_TRUE(wait_until([&] { return !sim_state("sim3").value("busy", true); }, 2s));
    const auto x_paused = sim_state("sim3")["axes"]["X"]["position"].get<double>();
    std::this_thread::sleep_for(200ms);
    EXPECT_EQ(sim_state("sim3")["axes"]["X"]["position"].get<double>(), x_paused);
    EXPECT_EQ(job(id)->progress.steps_done, 1u);
    // Paused: a second pause is harmless, `next` is refused.
    EXPECT_TRUE(pause(id));
    auto resumed = resume(id);
    ASSERT_TRUE(resumed) << resumed.error().message;
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    EXPECT_EQ(job(id)->progress.steps_done, 4u);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["points"], 3);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["enabled"], true);
    // The transitions: running -> paused -> queued -> running -> succeeded (the hub delivers later).
    EXPECT_EQ(published_states(id, "succeeded"),
              (std::vector<std::string>{"queued", "running", "paused", "queued", "running", "succeeded"}));
    // Resume of a finished job is refused.
    auto late = resume(id);
    ASSERT_FALSE(late);
    EXPECT_EQ(late.error().kind, kind::invalid_state);
}

TEST_F(manager_control_test, the_same_idempotency_key_returns_the_first_job) {
    add_sim("sim3", "planar");
    start();
    auto first = submit("sim3", job_type::planar_correction, {{"action", "clear"}}, "key-1");
    ASSERT_TRUE(first) << first.error().message;
    EXPECT_FALSE(first->replayed);
    auto again = submit("sim3", job_type::planar_correction, {{"action", "clear"}}, "key-1");
    ASSERT_TRUE(again) << again.error().message;
    EXPECT_TRUE(again->replayed);
    EXPECT_EQ(again->job.id, first->job.id);
    // The key reused for a different request, or by another client: refused, not answered with a job
    // that is not what was asked for.
    auto other = submit("sim3", job_type::planar_correction, {{"action", "disable"}}, "key-1");
    ASSERT_FALSE(other);
    EXPECT_EQ(other.error().kind, kind::invalid_value);
    EXPECT_EQ(other.error().field, "Idempotency-Key");
    EXPECT_NE(other.error().message.find(first->job.id), std::string::npos) << other.error().message;
    auto other_client = submit("sim3", job_type::planar_correction, {{"action", "clear"}}, "key-1",
                               std::nullopt, false, "bob");
    ASSERT_FALSE(other_client);
    EXPECT_EQ(other_client.error().field, "Idempotency-Key");
    EXPECT_EQ(other_client.error().message.find(first->job.id), std::string::npos)
        << "another client's job is named: " << other_client.error().message;
    auto different = submit("sim3", job_type::planar_correction, {{"action", "clear"}}, "key-2");
    ASSERT_TRUE(different);
    EXPECT_NE(different->job.id, first->job.id);
    ASSERT_TRUE(wait_state(different->job.id, job_state::succeeded));
    auto page = manager_->list(job_filter{});
    ASSERT_TRUE(page);
    EXPECT_EQ(page->jobs.size(), 2u);
    EXPECT_EQ(job(first->job.id)->idempotency_key, "key-1");
}

TEST_F(manager_control_test, a_leased_controller_takes_jobs_only_from_the_lease_holder) {
    add_sim("sim3", "planar", 4);
    start();
    auto l = leases_->acquire("sim3", "alice", 60s);
    ASSERT_TRUE(l) << l.error().message;
    auto refused = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, kind::leased);
    auto wrong = submit("sim3", job_type::planar_correction, {{"action", "clear"}}, std::nullopt, "l-wrong");
    ASSERT_FALSE(wrong);
    EXPECT_EQ(wrong.error().kind, kind::leased);

    auto allowed = submit("sim3", job_type::planar_correction, far_points(3000), std::nullopt, l->id);
    ASSERT_TRUE(allowed) << allowed.error().message;
    ASSERT_TRUE(wait_state(allowed->job.id, job_state::running));
    // Control actions follow the same rule.
    job_action a;
    a.job_id = allowed->job.id;
    auto not_holder = await(call<job_record>([&](auto h) { manager_->async_cancel(a, std::move(h)); }));
    ASSERT_FALSE(not_holder);
    EXPECT_EQ(not_holder.error().kind, kind::leased);
    ASSERT_TRUE(wait_state(allowed->job.id, job_state::succeeded));
    auto page = manager_->list(job_filter{});
    ASSERT_TRUE(page);
    EXPECT_EQ(page->jobs.size(), 1u);
}

TEST_F(manager_control_test, a_lease_is_refused_while_jobs_from_before_it_hold_or_wait_for_the_controller) {
    add_sim("sim3", "planar", 4);
    start();
    auto running = submit("sim3", job_type::planar_correction, far_points(3000));
    ASSERT_TRUE(running) << running.error().message;
    ASSERT_TRUE(wait_state(running->job.id, job_state::running));
    auto queued = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_TRUE(queued) << queued.error().message;

    auto busy = acquire_lease("sim3", "alice");
    ASSERT_FALSE(busy) << "a lease was granted while another client's jobs hold and wait for sim3";
    EXPECT_EQ(busy.error().kind, kind::busy);
    EXPECT_NE(busy.error().message.find(running->job.id + " running"), std::string::npos)
        << busy.error().message;
    EXPECT_NE(busy.error().message.find(queued->job.id + " queued"), std::string::npos)
        << busy.error().message;
    EXPECT_FALSE(leases_->current("sim3"));

    ASSERT_TRUE(cancel(running->job.id));
    ASSERT_TRUE(wait_state(running->job.id, job_state::cancelled));
    ASSERT_TRUE(wait_state(queued->job.id, job_state::succeeded));
    // Nothing left on the controller: granted, and a job without the lease is refused again.
    auto granted = acquire_lease("sim3", "alice");
    ASSERT_TRUE(granted) << granted.error().message;
    auto refused = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, kind::leased);
}

TEST_F(manager_control_test, a_lease_can_be_taken_as_soon_as_the_cancel_of_the_last_job_answered) {
    add_sim("sim3", "planar", 4);
    start();
    for (int i = 0; i < 5; ++i) {
        auto running = submit("sim3", job_type::planar_correction, far_points(3000));
        ASSERT_TRUE(running) << running.error().message;
        ASSERT_TRUE(wait_state(running->job.id, job_state::running));
        ASSERT_TRUE(cancel(running->job.id));
        auto l = acquire_lease("sim3", "alice");
        ASSERT_TRUE(l) << "round " << i << ": " << l.error().message;
        ASSERT_TRUE(leases_->release("sim3", l->id, false));
    }
}

TEST_F(manager_control_test, a_queued_job_cannot_slip_under_a_lease_taken_while_it_planned) {
    add_sim("sim3", "planar", 4);
    start();
    // Submit and lease at the same time, many times: either the lease is refused (the job got queued
    // first) or the job is refused (the lease came first); never both granted.
    for (int i = 0; i < 20; ++i) {
        auto job = call<submit_result>([&](auto h) {
            submit_request r;
            r.controller = "sim3";
            r.type = job_type::planar_correction;
            r.spec = {{"action", "clear"}};
            r.request_id = "race";
            manager_->async_submit(std::move(r), std::move(h));
        });
        auto l = acquire_lease("sim3", "alice");
        auto submitted = await(std::move(job));
        EXPECT_FALSE(submitted && l) << "round " << i << ": job " << submitted->job.id
                                     << " was queued and a lease granted";
        if (l) {
            ASSERT_TRUE(leases_->release("sim3", l->id, false));
        } else {
            ASSERT_TRUE(submitted) << submitted.error().message;
            ASSERT_TRUE(wait_state(submitted->job.id, job_state::succeeded));
        }
    }
}

TEST_F(manager_control_test, a_command_the_controller_refuses_fails_the_job_and_the_queue_goes_on) {
    auto sim = add_sim("sim1", "full", 50);
    start();
    auto a = submit("sim1", job_type::array,
                    {{"plate", "6"},
                     {"a1", {{"X", 500}, {"Y", 500}}},
                     {"advance", "next"},
                     {"mode", "host"},
                     {"ttl_pulse", true}});
    auto b = submit("sim1", job_type::array,
                    {{"plate", "6"}, {"a1", {{"X", 0}, {"Y", 0}}}, {"wells", {"A1"}}, {"mode", "host"}});
    ASSERT_TRUE(a && b);
    const auto id = a->job.id;
    ASSERT_TRUE(wait_until([&] {
        auto j = job(id);
        return j && j->progress.steps_done == 1;
    })) << "the first well was never reached";
    // The move to the second well is refused by the controller (not a disconnect): the job fails.
    sim->refuse_next_command("MOVE", devices::ms2000::parameter_out_of_range);
    ASSERT_TRUE(next(id));
    ASSERT_TRUE(wait_state(id, job_state::failed));
    const auto failed = job(id);
    EXPECT_EQ(failed->progress.steps_done, 1u);
    EXPECT_NE(failed->reason.find("-4"), std::string::npos) << failed->reason;
    ASSERT_TRUE(failed->finished);
    // It ended with the output low, and the queue went on to the next job.
    ASSERT_TRUE(wait_state(b->job.id, job_state::succeeded));
    EXPECT_EQ(sim_state("sim1")["ttl"]["out0_mode"], 0);
    const auto sent = commands_of(id);
    ASSERT_FALSE(sent.empty());
    EXPECT_EQ(std::count(sent.begin(), sent.end(), "TTL Y=1"), 1) << "one pulse, at the first well";
    // A failed job is final: resume is refused.
    auto again = resume(id);
    ASSERT_FALSE(again);
    EXPECT_EQ(again.error().kind, kind::invalid_state);
    EXPECT_EQ(published_states(id, "failed"), (std::vector<std::string>{"queued", "running", "failed"}));
}

TEST_F(manager_control_test, a_full_queue_refuses_more_jobs) {
    max_queued_ = 2;
    add_sim("sim3", "planar", 2);
    start();
    auto a = submit("sim3", job_type::planar_correction, far_points(3000));
    ASSERT_TRUE(a);
    ASSERT_TRUE(wait_state(a->job.id, job_state::running));
    ASSERT_TRUE(submit("sim3", job_type::planar_correction, {{"action", "clear"}}));
    ASSERT_TRUE(submit("sim3", job_type::planar_correction, {{"action", "clear"}}));
    auto full = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_FALSE(full);
    EXPECT_EQ(full.error().kind, kind::queue_full);
}

}  // namespace
}  // namespace gw::jobs::test
