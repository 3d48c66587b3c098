// ring_buffer jobs end to end through the real job_manager and in-process simulators (time_scale
// 20): autoplay once and repeating tours on the RING BUFFER module ("full"), TTL-triggered and
// `next`-triggered tours ("planar": a ring buffer without TTL_REPORT_INT), the host fallback
// ("plain"), and cancel of a tour that repeats until cancelled.
#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;

class ring_buffer_run_test : public manager_fixture {
  protected:
    std::vector<json> steps_of(const std::string& id) {
        std::vector<json> out;
        for (const auto& e : sink_->of(id))
            if (e.value("type", "") == "step") out.push_back(e);
        return out;
    }
    double sim_um(const std::string& sim, char axis) {
        return sim_state(sim)["axes"][std::string(1, axis)]["position"].get<double>() / 10.0;
    }
    bool wait_steps(const std::string& id, std::size_t n) {
        return wait_until([&] {
            auto j = job(id);
            return j && j->progress.steps_done >= n;
        });
    }
};

json three_positions() {
    return json::parse(R"({"positions": [{"X": 500, "Y": 0}, {"X": 1000, "Y": 500}, {"X": 0, "Y": 1000}]})");
}

TEST_F(ring_buffer_run_test, autoplay_once_loads_the_buffer_and_reports_every_position) {
    add_sim("sim1", "full");
    start();
    auto spec = three_positions();
    spec["delay_ms"] = 100;
    auto submitted = submit("sim1", job_type::ring_buffer, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    ASSERT_TRUE(wait_state(id, job_state::succeeded));

    // The hub delivers the last step event on its own thread, maybe after the state changed.
    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 3; })) << steps_of(id).size();
    const auto steps = steps_of(id);
    ASSERT_EQ(steps.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(steps[i]["name"], "position " + std::to_string(i + 1));
        EXPECT_EQ(steps[i]["slot"], i + 1);
        EXPECT_EQ(steps[i]["tour"], 1);
        EXPECT_NEAR(steps[i]["position"]["X"].get<double>(), spec["positions"][i]["X"].get<double>(), 1);
        EXPECT_NEAR(steps[i]["position"]["Y"].get<double>(), spec["positions"][i]["Y"].get<double>(), 1);
    }
    EXPECT_EQ(steps.back()["measured"], true);
    EXPECT_NEAR(sim_um("sim1", 'X'), 0, 1);
    EXPECT_NEAR(sim_um("sim1", 'Y'), 1000, 1);
    const auto rb = sim_state("sim1")["ring_buffer"];
    EXPECT_EQ(rb["count"], 3);
    EXPECT_EQ(rb["mode"], 2);
    EXPECT_EQ(rb["autoplay"], false);
    const auto commands = commands_of(id);
    const std::vector<std::string> setup(commands.begin(), commands.begin() + 7);
    EXPECT_EQ(setup, (std::vector<std::string>{"RM X=0", "LD X=5000 Y=0", "LD X=10000 Y=5000",
                                               "LD X=0 Y=10000", "RM Y=3 Z=0 F=2", "RT Z=100", "RM"}));
}

TEST_F(ring_buffer_run_test, repeating_autoplay_runs_the_given_number_of_tours) {
    add_sim("sim1", "full");
    start();
    auto spec = three_positions();
    spec["repeat"] = true;
    spec["cycles"] = 2;
    auto submitted = submit("sim1", job_type::ring_buffer, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 6; })) << steps_of(id).size();
    const auto steps = steps_of(id);
    ASSERT_EQ(steps.size(), 6u);
    EXPECT_EQ(steps[0]["name"], "tour 1 position 1");
    EXPECT_EQ(steps[5]["name"], "tour 2 position 3");
    EXPECT_EQ(steps[4]["tour"], 2);
    EXPECT_EQ(steps[4]["slot"], 2);
    EXPECT_NEAR(sim_um("sim1", 'Y'), 1000, 1);
    EXPECT_EQ(job(id)->progress.steps_done, 6u);
}

TEST_F(ring_buffer_run_test, repeating_until_cancelled_follows_the_pointer_across_tours) {
    add_sim("sim1", "full");
    start();
    auto spec = three_positions();
    spec["repeat"] = true;
    spec["delay_ms"] = 200;
    auto submitted = submit("sim1", job_type::ring_buffer, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 5; }));
    EXPECT_EQ(sim_state("sim1")["ring_buffer"]["mode"], 3);
    ASSERT_TRUE(cancel(id));
    ASSERT_TRUE(wait_state(id, job_state::cancelled));
    EXPECT_EQ(sim_state("sim1")["ring_buffer"]["autoplay"], false);
    const auto steps = steps_of(id);
    EXPECT_EQ(steps[3]["slot"], 1);  // the second tour starts again at slot 1
    EXPECT_EQ(steps[3]["tour"], 2);
    EXPECT_EQ(steps[3]["name"], "position 1");
}

TEST_F(ring_buffer_run_test, ttl_triggered_tour_steps_on_each_in0_edge) {
    auto sim = add_sim("sim3", "planar");
    start();
    auto spec = three_positions();
    spec["trigger"] = "ttl";
    auto submitted = submit("sim3", job_type::ring_buffer, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    ASSERT_TRUE(wait_until([&] { return sim_state("sim3")["ttl"]["in0_mode"] == 1; }));
    EXPECT_EQ(job(id)->progress.steps_done, 0u);  // nothing moves without an edge
    for (std::size_t i = 1; i <= 3; ++i) {
        sim->ttl_pulse();
        ASSERT_TRUE(wait_steps(id, i)) << "edge " << i;
    }
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    // The hub delivers the last step event on its own thread, maybe after the state changed.
    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 3; })) << steps_of(id).size();
    const auto steps = steps_of(id);
    ASSERT_EQ(steps.size(), 3u);
    EXPECT_EQ(steps[1]["measured"], true);
    EXPECT_NEAR(steps[1]["position"]["X"].get<double>(), 1000, 1);
    EXPECT_NEAR(sim_um("sim3", 'Y'), 1000, 1);
    EXPECT_EQ(sim_state("sim3")["ttl"]["in0_mode"], 0);  // IN0 restored after the tour
}

TEST_F(ring_buffer_run_test, cancel_of_a_ttl_tour_sets_in0_back_so_later_edges_move_nothing) {
    auto sim = add_sim("sim3", "planar");
    start();
    auto spec = three_positions();
    spec["trigger"] = "ttl";
    auto submitted = submit("sim3", job_type::ring_buffer, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return sim_state("sim3")["ttl"]["in0_mode"] == 1; }));
    sim->ttl_pulse();
    ASSERT_TRUE(wait_steps(id, 1));
    ASSERT_TRUE(cancel(id));
    ASSERT_TRUE(wait_state(id, job_state::cancelled));
    EXPECT_EQ(sim_state("sim3")["ttl"]["in0_mode"], 0);
    // An edge now must not take the stage to the next buffered position.
    const double x = sim_um("sim3", 'X');
    sim->ttl_pulse();
    std::this_thread::sleep_for(200ms);
    EXPECT_EQ(sim_state("sim3")["busy"], false);
    EXPECT_NEAR(sim_um("sim3", 'X'), x, 1);
}

TEST_F(ring_buffer_run_test, next_triggered_tour_sends_rm_per_next_call) {
    add_sim("sim3", "planar");
    start();
    auto spec = three_positions();
    spec["trigger"] = "next";
    auto submitted = submit("sim3", job_type::ring_buffer, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_state(id, job_state::running));
    for (std::size_t i = 1; i <= 3; ++i) {
        ASSERT_TRUE(next(id));
        ASSERT_TRUE(wait_steps(id, i)) << "next " << i;
        EXPECT_NEAR(sim_um("sim3", 'X'), spec["positions"][i - 1]["X"].get<double>(), 1);
    }
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    const auto commands = commands_of(id);
    EXPECT_EQ(std::count(commands.begin(), commands.end(), "RM"), 3);
    EXPECT_EQ(std::count(commands.begin(), commands.end(), "RM Y=3 Z=0 F=1"), 1);
}

TEST_F(ring_buffer_run_test, host_fallback_moves_to_each_position) {
    add_sim("sim2", "plain");
    start();
    auto spec = three_positions();
    spec["delay_ms"] = 50;
    auto submitted = submit("sim2", job_type::ring_buffer, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "host");
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    // The hub delivers the last step event on its own thread, maybe after the state changed.
    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 3; })) << steps_of(id).size();
    const auto steps = steps_of(id);
    ASSERT_EQ(steps.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(steps[i]["measured"], true);
        EXPECT_NEAR(steps[i]["position"]["X"].get<double>(), spec["positions"][i]["X"].get<double>(), 1);
    }
    const auto commands = commands_of(id);
    EXPECT_EQ(std::count(commands.begin(), commands.end(), "LD X=5000 Y=0"), 0);
    EXPECT_NE(std::find(commands.begin(), commands.end(), "M X=10000 Y=5000"), commands.end());
}

}  // namespace
}  // namespace gw::jobs::test
