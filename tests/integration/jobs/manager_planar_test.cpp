// The job manager running planar_correction jobs end to end on a simulated PLANAR CORRECTION
// controller: the simulator's CCB state, the plane event, `next`-captured points, refusals.
#include <cmath>

#include "gateway/jobs/job_json.hpp"
#include "tests/integration/jobs/manager_fixture.hpp"
#include "tests/support/sim_serial_client.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;
using kind = operation_error_kind;

class manager_planar_test : public manager_fixture {};

json three_points(bool enable) {
    return {
        {"action", "set"},
        {"points", json::array({json{{"X", 0}, {"Y", 0}, {"Z", 0}}, json{{"X", 2000}, {"Y", 0}, {"Z", 20}},
                                json{{"X", 0}, {"Y", 2000}, {"Z", -10}}})},
        {"enable", enable}};
}

std::vector<json> of_type(const std::vector<json>& events, const std::string& type) {
    std::vector<json> out;
    for (const auto& e : events)
        if (e.value("type", "") == type) out.push_back(e);
    return out;
}

TEST_F(manager_planar_test, set_stores_three_points_enables_and_reports_the_plane) {
    add_sim("sim3", "planar");
    start();
    auto submitted = submit("sim3", job_type::planar_correction, three_points(true));
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.state, job_state::queued);
    EXPECT_EQ(submitted->job.progress.steps_total, 4u);
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    ASSERT_TRUE(wait_state(id, job_state::succeeded));

    const auto done = job(id);
    ASSERT_TRUE(done);
    EXPECT_EQ(done->progress.steps_done, 4u);
    EXPECT_EQ(done->progress.current_step, "enable");
    EXPECT_TRUE(done->started);
    EXPECT_TRUE(done->finished);
    const auto pc = sim_state("sim3")["planar_correction"];
    EXPECT_EQ(pc["points"], 3);
    EXPECT_EQ(pc["enabled"], true);

    // The serial commands, in order, all tagged with the job's request id.
    std::vector<std::string> ccb;
    for (const auto& c : commands_of(id))
        if (c.starts_with("CCB")) ccb.push_back(c);
    EXPECT_EQ(ccb, (std::vector<std::string>{"CCB Z=7", "CCB Z=1", "CCB Z=2", "CCB Z=3", "CCB Z=4"}));

    // The plane through (0,0,0), (2000,0,20), (0,2000,-10): z = 0.01 x - 0.005 y.
    ASSERT_TRUE(wait_until([&] { return !of_type(sink_->of(id), "plane").empty(); }));
    const auto plane = of_type(sink_->of(id), "plane").front();
    ASSERT_TRUE(plane["plane"].is_object()) << plane.dump();
    EXPECT_NEAR(plane["plane"]["a"].get<double>(), 0.01, 1e-3);
    EXPECT_NEAR(plane["plane"]["b"].get<double>(), -0.005, 1e-3);
    EXPECT_NEAR(plane["plane"]["c"].get<double>(), 0.0, 0.5);
    EXPECT_EQ(plane["points"].size(), 3u);
    EXPECT_EQ(plane["enabled"], true);

    // The plane event is stored with the job's history too.
    auto stored = manager_->events(id, 1000);
    ASSERT_TRUE(stored) << stored.error().message;
    EXPECT_EQ(of_type(*stored, "plane").size(), 1u);
}

TEST_F(manager_planar_test, events_on_the_hub_topic_come_in_order) {
    add_sim("sim3", "planar");
    start();
    auto submitted = submit("sim3", job_type::planar_correction, three_points(true));
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    ASSERT_TRUE(wait_until([&] {
        auto e = sink_->of(id);
        return !e.empty() && e.back().value("state", "") == "succeeded";
    }));
    const auto events = sink_->of(id);
    std::vector<std::string> seen;
    for (const auto& e : events) {
        const auto type = e.value("type", "");
        seen.push_back(type == "state"  ? "state:" + e.value("state", "")
                       : type == "step" ? "step:" + e.value("name", "")
                                        : type);
    }
    EXPECT_EQ(seen, (std::vector<std::string>{"state:queued", "state:running", "step:point 1", "step:point 2",
                                              "step:point 3", "step:enable", "plane", "state:succeeded"}));
    // Step events carry the progress and the measured position.
    const auto steps = of_type(events, "step");
    ASSERT_EQ(steps.size(), 4u);
    EXPECT_EQ(steps[1]["index"], 1);
    EXPECT_EQ(steps[1]["steps_done"], 2);
    EXPECT_EQ(steps[1]["steps_total"], 4);
    EXPECT_DOUBLE_EQ(steps[1]["percent"].get<double>(), 50.0);
    EXPECT_NEAR(steps[1]["position"]["X"].get<double>(), 2000, 1.0);
    EXPECT_NEAR(steps[1]["position"]["Z"].get<double>(), 20, 1.0);
    // Hub sequence numbers have no gaps.
    std::uint64_t seq = 0;
    for (const auto& m : sink_->all()) {
        if (m.value("topic", "") != "jobs/" + id) continue;
        EXPECT_EQ(m["seq"].get<std::uint64_t>(), ++seq);
    }
}

TEST_F(manager_planar_test, disable_and_clear_are_one_step_each) {
    add_sim("sim3", "planar");
    start();
    auto set = submit("sim3", job_type::planar_correction, three_points(true));
    ASSERT_TRUE(set) << set.error().message;
    auto disable = submit("sim3", job_type::planar_correction, {{"action", "disable"}});
    ASSERT_TRUE(disable) << disable.error().message;
    EXPECT_EQ(disable->job.progress.steps_total, 1u);
    ASSERT_TRUE(wait_state(disable->job.id, job_state::succeeded));
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["enabled"], false);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["points"], 3);

    auto enable = submit("sim3", job_type::planar_correction, {{"action", "enable"}});
    ASSERT_TRUE(enable) << enable.error().message;
    ASSERT_TRUE(wait_state(enable->job.id, job_state::succeeded));
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["enabled"], true);

    auto clear = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_TRUE(clear) << clear.error().message;
    ASSERT_TRUE(wait_state(clear->job.id, job_state::succeeded));
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["points"], 0);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["enabled"], false);
    EXPECT_EQ(commands_of(clear->job.id), (std::vector<std::string>{"CCB Z=7"}));
}

TEST_F(manager_planar_test, current_points_wait_for_next_calls_and_none_is_lost) {
    add_sim("sim3", "planar");
    start();
    json spec = {{"action", "set"},
                 {"points", json::array({"current", json{{"X", 1500}, {"Y", 0}, {"Z", 5}}, "current"})},
                 {"enable", false}};
    auto submitted = submit("sim3", job_type::planar_correction, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    // The waits for `next` are not in the estimate; the motion to point 2 is.
    EXPECT_GE(submitted->job.progress.remaining_s.value_or(-1), 0);
    ASSERT_TRUE(wait_state(id, job_state::running));
    // Nothing happens without `next`: point 1 waits, and says so.
    ASSERT_TRUE(wait_until([&] { return job(id)->progress.waiting_for == job_wait::next; }));
    EXPECT_EQ(job(id)->progress.steps_done, 0u);
    EXPECT_FALSE(job(id)->progress.eta) << "its end cannot be predicted";
    // Two calls at once: the second is kept for point 3.
    ASSERT_TRUE(next(id));
    ASSERT_TRUE(next(id));
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    EXPECT_EQ(job(id)->progress.steps_done, 3u);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["points"], 3);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["enabled"], false);
    // `next` on a finished job is refused.
    auto late = next(id);
    ASSERT_FALSE(late);
    EXPECT_EQ(late.error().kind, kind::invalid_state);
}

TEST_F(manager_planar_test, refusals_name_the_problem_and_store_nothing) {
    add_sim("sim1", "plain");
    add_sim("sim3", "planar");
    start();
    auto missing = submit("sim1", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_FALSE(missing);
    EXPECT_EQ(missing.error().kind, kind::missing_module);

    auto unknown_field = submit("sim3", job_type::planar_correction, {{"action", "clear"}, {"speed", 2}});
    ASSERT_FALSE(unknown_field);
    EXPECT_EQ(unknown_field.error().kind, kind::invalid_value);
    EXPECT_EQ(unknown_field.error().field, "spec.speed");

    auto two_points = submit("sim3", job_type::planar_correction,
                             {{"action", "set"}, {"points", json::array({"current", "current"})}});
    ASSERT_FALSE(two_points);
    EXPECT_EQ(two_points.error().field, "spec.points");

    auto collinear = submit(
        "sim3", job_type::planar_correction,
        {{"action", "set"},
         {"points", json::array({json{{"X", 0}, {"Y", 0}, {"Z", 0}}, json{{"X", 100}, {"Y", 100}, {"Z", 0}},
                                 json{{"X", 200}, {"Y", 200}, {"Z", 5}}})}});
    ASSERT_FALSE(collinear);
    EXPECT_EQ(collinear.error().field, "spec.points");

    auto beyond = submit(
        "sim3", job_type::planar_correction,
        {{"action", "set"},
         {"points", json::array({json{{"X", 0}, {"Y", 0}, {"Z", 0}}, json{{"X", 5e6}, {"Y", 0}, {"Z", 0}},
                                 json{{"X", 0}, {"Y", 100}, {"Z", 0}}})}});
    ASSERT_FALSE(beyond);
    EXPECT_EQ(beyond.error().kind, kind::invalid_value);
    EXPECT_EQ(beyond.error().field, "spec.points[1]");
    EXPECT_NE(beyond.error().message.find("point 2"), std::string::npos) << beyond.error().message;

    auto nobody = submit("nope", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_FALSE(nobody);
    EXPECT_EQ(nobody.error().kind, kind::unknown_controller);

    auto page = manager_->list(job_filter{});
    ASSERT_TRUE(page) << page.error().message;
    EXPECT_TRUE(page->jobs.empty());
}

// The controller's own soft limits (SU/SL, read by the registry), well inside the travel range: a given
// point beyond them is refused naming that point, and nothing is sent to the controller.
TEST_F(manager_planar_test, points_beyond_the_controllers_soft_limits_are_refused_naming_the_point) {
    auto sim = add_sim("sim3", "planar");
    {
        gw::tests::sim_serial_client client(sim->port_path());
        ASSERT_TRUE(client.command("SU X=5"));
        ASSERT_TRUE(client.command("SL Y=-3"));
    }
    start();
    const auto point = [](double x, double y, double z) { return json{{"X", x}, {"Y", y}, {"Z", z}}; };
    struct row {
        json points;
        const char* field;
        const char* name;
    };
    const row rows[] = {
        {json::array({point(0, 0, 0), point(6000, 0, 10), point(0, 2000, -5)}), "spec.points[1]", "point 2"},
        {json::array({point(0, 0, 0), point(2000, 0, 10), point(0, -4000, -5)}), "spec.points[2]", "point 3"},
        {json::array({point(5001, 0, 0), point(2000, 0, 10), point(0, 2000, -5)}), "spec.points[0]",
         "point 1"},
    };
    for (const auto& r : rows) {
        auto refused = submit("sim3", job_type::planar_correction,
                              {{"action", "set"}, {"points", r.points}, {"enable", true}});
        ASSERT_FALSE(refused) << r.field;
        EXPECT_EQ(refused.error().kind, kind::invalid_value) << refused.error().message;
        EXPECT_EQ(refused.error().field, r.field) << refused.error().message;
        EXPECT_NE(refused.error().message.find(r.name), std::string::npos) << refused.error().message;
        EXPECT_NE(refused.error().message.find("soft limit"), std::string::npos) << refused.error().message;
    }
    // Within the limits the same controller takes a plane (the limits are the reason, not the points).
    auto fits = submit("sim3", job_type::planar_correction,
                       {{"action", "set"},
                        {"points", json::array({point(0, 0, 0), point(5000, 0, 10), point(0, -3000, -5)})},
                        {"enable", false}},
                       std::nullopt, std::nullopt, true);
    EXPECT_TRUE(fits) << fits.error().message;

    // Nothing stored, nothing sent as a job, the stage and the correction untouched.
    auto page = manager_->list(job_filter{});
    ASSERT_TRUE(page) << page.error().message;
    EXPECT_TRUE(page->jobs.empty());
    const auto job_traces = observer_->locked([&] {
        std::size_t n = 0;
        for (const auto& t : observer_->traces)
            if (t.request_id.starts_with("job-")) ++n;
        return n;
    });
    EXPECT_EQ(job_traces, 0u);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["points"], 0);
    EXPECT_NEAR(sim_state("sim3")["axes"]["X"]["position"].get<double>(), 0, 1);
}

TEST_F(manager_planar_test, dry_run_returns_the_plan_and_moves_nothing) {
    add_sim("sim3", "planar");
    start();
    auto dry =
        submit("sim3", job_type::planar_correction, three_points(true), std::nullopt, std::nullopt, true);
    ASSERT_TRUE(dry) << dry.error().message;
    EXPECT_TRUE(dry->job.id.empty());
    EXPECT_EQ(dry->plan.steps.size(), 4u);
    EXPECT_EQ(dry->plan.commands.front(), "CCB Z=7");
    EXPECT_EQ(dry->plan.commands.back(), "CCB Z=4");
    EXPECT_EQ(dry->plan.bounds.max.at('X'), 2000);
    const auto j = dry_run_json("sim3", job_type::planar_correction, dry->plan);
    EXPECT_EQ(j["plan"]["steps_total"], 4);
    EXPECT_EQ(j["plan"]["steps"][1]["target"]["X"], 2000.0);
    EXPECT_EQ(sim_state("sim3")["planar_correction"]["points"], 0);
    auto page = manager_->list(job_filter{});
    ASSERT_TRUE(page) << page.error().message;
    EXPECT_TRUE(page->jobs.empty());
}

}  // namespace
}  // namespace gw::jobs::test
