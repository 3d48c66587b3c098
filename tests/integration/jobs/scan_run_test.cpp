// scan jobs end to end through the real job_manager and in-process simulators (time_scale 20):
// the SCAN module path ("full": progress per line, final position, SPEED restored), the host path
// ("plain"), serpentine, the firmware's refusals with the seed's numbers, the dry run, and cancel.
#include <cmath>

#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;

class scan_run_test : public manager_fixture {
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
    bool contains(const std::vector<std::string>& commands, const std::string& c) {
        return std::find(commands.begin(), commands.end(), c) != commands.end();
    }
};

// 0.2 mm lines at 0.1 mm/s: 2 s of simulated time (100 ms real) per line.
json small_scan(const std::string& pattern, int lines) {
    return {{"fast", {{"start_mm", 0.0}, {"stop_mm", 0.2}, {"encoder_divide", 24}}},
            {"slow", {{"start_mm", 0.0}, {"stop_mm", 0.1}, {"lines", lines}}},
            {"pattern", pattern},
            {"speed_mm_s", 0.1}};
}

TEST_F(scan_run_test, firmware_scan_reports_every_line_and_ends_at_the_last_line) {
    add_sim("sim1", "full");
    start();
    auto submitted = submit("sim1", job_type::scan, small_scan("raster", 5));
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    EXPECT_EQ(submitted->job.progress.steps_total, 5u);
    ASSERT_TRUE(wait_state(id, job_state::succeeded));

    // The hub delivers the last step event on its own thread, maybe after the state changed.
    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 5; })) << steps_of(id).size();
    const auto steps = steps_of(id);
    ASSERT_EQ(steps.size(), 5u);
    for (std::size_t i = 0; i < steps.size(); ++i) {
        EXPECT_EQ(steps[i]["name"], "line " + std::to_string(i + 1)) << steps[i].dump();
        EXPECT_EQ(steps[i]["line"], i + 1);
        EXPECT_TRUE(steps[i]["position"].is_object());
    }
    // The last line is reported with the position measured after the scan.
    EXPECT_EQ(steps.back()["measured"], true);
    EXPECT_NEAR(steps.back()["position"]["X"].get<double>(), 200, 1);
    EXPECT_NEAR(steps.back()["position"]["Y"].get<double>(), 100, 1);
    EXPECT_NEAR(sim_um("sim1", 'X'), 200, 1);
    EXPECT_NEAR(sim_um("sim1", 'Y'), 100, 1);
    EXPECT_EQ(sim_state("sim1")["scan"]["running"], false);
    EXPECT_EQ(sim_state("sim1")["scan"]["pixels"], 378);  // 0.2 mm x 45397.6 counts/mm / 24
    EXPECT_NEAR(sim_state("sim1")["axes"]["X"]["speed"].get<double>(), 5.5, 1e-6);  // restored

    const auto commands = commands_of(id);
    for (const char* c : {"SCANR X=0 Y=0.2 Z=24", "SCANV X=0 Y=0.1 Z=5", "SCAN Y=0 Z=1 F=0", "SPEED X=0.1",
                          "SCAN", "SPEED X=5.5"})
        EXPECT_TRUE(contains(commands, c)) << c;
    const auto done = job(id);
    ASSERT_TRUE(done);
    EXPECT_EQ(done->progress.steps_done, 5u);
    EXPECT_EQ(done->progress.current_step, "line 5");
}

// A line given by its pixel count (fast.pixels, SCANR F=): the SCAN module takes the count as given and
// derives the stop from it (start + pixels x divide / counts per mm); every line ends there.
TEST_F(scan_run_test, firmware_scan_given_a_pixel_count) {
    add_sim("sim1", "full");
    start();
    json spec = {{"fast", {{"start_mm", 0.05}, {"pixels", 400}, {"encoder_divide", 24}}},
                 {"slow", {{"start_mm", 0.0}, {"stop_mm", 0.1}, {"lines", 3}}},
                 {"speed_mm_s", 0.1},
                 {"mode", "firmware"}};
    auto submitted = submit("sim1", job_type::scan, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    EXPECT_EQ(submitted->job.progress.steps_total, 3u);
    ASSERT_TRUE(wait_state(id, job_state::succeeded));

    const auto snapshot = registry_->get("sim1");  // a copy: the axis pointer below points into it
    ASSERT_TRUE(snapshot);
    const auto* x = snapshot->axis('X');
    ASSERT_TRUE(x && x->counts_per_mm);
    const double stop_um = 50 + 400.0 * 24 / *x->counts_per_mm * 1000;  // about 261.5 um
    EXPECT_TRUE(contains(commands_of(id), "SCANR X=0.05 F=400 Z=24"));
    EXPECT_EQ(sim_state("sim1")["scan"]["pixels"], 400);
    EXPECT_EQ(sim_state("sim1")["scan"]["lines"], 3);
    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 3; })) << steps_of(id).size();
    const auto steps = steps_of(id);
    ASSERT_EQ(steps.size(), 3u);
    for (std::size_t i = 0; i < steps.size(); ++i)
        EXPECT_EQ(steps[i]["name"], "line " + std::to_string(i + 1)) << steps[i].dump();
    EXPECT_EQ(steps.back()["measured"], true);
    EXPECT_NEAR(steps.back()["position"]["X"].get<double>(), stop_um, 1) << steps.back().dump();
    EXPECT_NEAR(steps.back()["position"]["Y"].get<double>(), 100, 1);
    EXPECT_NEAR(sim_um("sim1", 'X'), stop_um, 1);
    EXPECT_NEAR(sim_state("sim1")["axes"]["X"]["speed"].get<double>(), 5.5, 1e-6);  // restored
}

TEST_F(scan_run_test, firmware_serpentine_ends_where_the_even_line_count_returns) {
    add_sim("sim1", "full");
    start();
    auto submitted = submit("sim1", job_type::scan, small_scan("serpentine", 4));
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    EXPECT_TRUE(wait_until([&] { return steps_of(id).size() == 4; })) << steps_of(id).size();
    EXPECT_EQ(sim_state("sim1")["scan"]["pattern"], 1);
    EXPECT_NEAR(sim_um("sim1", 'X'), 0, 1);  // line 4 runs backwards
    EXPECT_NEAR(sim_um("sim1", 'Y'), 100, 1);
    EXPECT_TRUE(contains(commands_of(id), "SCAN Y=0 Z=1 F=1"));
}

TEST_F(scan_run_test, host_scan_on_a_controller_without_the_module) {
    add_sim("sim2", "plain");
    start();
    auto submitted = submit("sim2", job_type::scan, small_scan("raster", 3));
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "host");
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 3; })) << steps_of(id).size();
    const auto steps = steps_of(id);
    ASSERT_EQ(steps.size(), 3u);
    for (std::size_t i = 0; i < steps.size(); ++i) {
        SCOPED_TRACE(steps[i].dump());
        ASSERT_TRUE(steps[i]["position"].contains("Y"));
        EXPECT_EQ(steps[i]["name"], "line " + std::to_string(i + 1));
        EXPECT_EQ(steps[i]["measured"], true);
        EXPECT_NEAR(steps[i]["position"]["X"].get<double>(), 200, 1);
        EXPECT_NEAR(steps[i]["position"]["Y"].get<double>(), 50.0 * static_cast<double>(i), 1);
    }
    EXPECT_NEAR(sim_um("sim2", 'X'), 200, 1);
    EXPECT_NEAR(sim_um("sim2", 'Y'), 100, 1);
    EXPECT_NEAR(sim_state("sim2")["axes"]["X"]["speed"].get<double>(), 5.5, 1e-6);
    const auto commands = commands_of(id);
    for (const char* c :
         {"M X=0 Y=0", "SPEED X=0.1", "M X=2000", "SPEED X=5.5", "M X=0 Y=500", "M X=0 Y=1000"})
        EXPECT_TRUE(contains(commands, c)) << c;
    EXPECT_FALSE(contains(commands, "SCAN"));
}

TEST_F(scan_run_test, firmware_validation_refuses_the_seeds_out_of_range_numbers) {
    add_sim("sim1", "full");
    start();
    struct row {
        json fast;
        const char* field;
    };
    const row rows[] = {
        {{{"start_mm", 0.0}, {"stop_mm", 18.0}, {"encoder_divide", 24}},
         "spec.fast.stop_mm"},  // 34047 pixels
        {{{"start_mm", 0.0}, {"stop_mm", 1.0}, {"encoder_divide", 32768}}, "spec.fast.encoder_divide"},
        {{{"start_mm", 0.0}, {"pixels", 32768}, {"encoder_divide", 1}}, "spec.fast.pixels"},
    };
    for (const auto& r : rows) {
        json spec = {{"fast", r.fast}, {"slow", {{"start_mm", 0.0}, {"stop_mm", 1.0}, {"lines", 1891}}}};
        auto refused = submit("sim1", job_type::scan, spec);
        ASSERT_FALSE(refused) << r.field;
        EXPECT_EQ(refused.error().kind, operation_error_kind::invalid_value);
        EXPECT_EQ(refused.error().field, r.field) << refused.error().message;
    }
    // The seed's own example is accepted; a dry run shows the plan and moves nothing.
    json seed = {{"fast", {{"start_mm", 0.0}, {"stop_mm", 1.0}, {"encoder_divide", 24}}},
                 {"slow", {{"start_mm", 0.0}, {"stop_mm", 1.0}, {"lines", 1891}}},
                 {"speed_mm_s", 0.528}};
    auto dry = submit("sim1", job_type::scan, seed, std::nullopt, std::nullopt, true);
    ASSERT_TRUE(dry) << dry.error().message;
    EXPECT_EQ(dry->plan.steps.size(), 1891u);
    EXPECT_EQ(dry->plan.path, "firmware");
    ASSERT_FALSE(dry->plan.commands.empty());
    EXPECT_EQ(dry->plan.commands.front(), "SCANR X=0 Y=1 Z=24");
    EXPECT_GT(dry->plan.estimated_s, 1891 * 1.89);  // 1891 lines of 1.89 s at 0.528 mm/s
    EXPECT_EQ(sim_state("sim1")["scan"]["running"], false);
    EXPECT_EQ(sim_state("sim1")["scan"]["lines"], 1);  // nothing was sent
}

TEST_F(scan_run_test, cancel_mid_scan_halts_the_stage) {
    add_sim("sim1", "full");
    add_sim("sim2", "plain");
    start();
    auto spec = small_scan("raster", 20);
    auto firmware = submit("sim1", job_type::scan, spec);
    auto host = submit("sim2", job_type::scan, spec);
    ASSERT_TRUE(firmware) << firmware.error().message;
    ASSERT_TRUE(host) << host.error().message;
    for (const auto* j : {&firmware->job, &host->job})
        ASSERT_TRUE(wait_until([&] {
            auto r = job(j->id);
            return r && r->progress.steps_done >= 2;
        })) << j->plan_path;
    ASSERT_TRUE(cancel(firmware->job.id));
    ASSERT_TRUE(cancel(host->job.id));
    ASSERT_TRUE(wait_state(firmware->job.id, job_state::cancelled));
    ASSERT_TRUE(wait_state(host->job.id, job_state::cancelled));
    EXPECT_EQ(sim_state("sim1")["scan"]["running"], false);
    EXPECT_EQ(sim_state("sim1")["busy"], false);
    EXPECT_EQ(sim_state("sim2")["busy"], false);
    EXPECT_LT(job(firmware->job.id)->progress.steps_done, 20u);
    EXPECT_LT(job(host->job.id)->progress.steps_done, 20u);
    EXPECT_LT(sim_um("sim1", 'Y'), 99);  // stopped before the last line
    // The manager put back the SPEED the scans had changed (the cancel answers after that).
    EXPECT_NEAR(sim_state("sim1")["axes"]["X"]["speed"].get<double>(), 5.5, 1e-6);
    EXPECT_NEAR(sim_state("sim2")["axes"]["X"]["speed"].get<double>(), 5.5, 1e-6);
    const auto commands = commands_of(firmware->job.id);
    ASSERT_FALSE(commands.empty());
    EXPECT_EQ(commands.back(), "SPEED X=5.5");
}

}  // namespace
}  // namespace gw::jobs::test
