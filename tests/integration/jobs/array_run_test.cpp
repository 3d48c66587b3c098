// Array jobs end to end: the real job_manager, controller_registry and SQLite store over in-process
// simulators ("full" has the ARRAY module and TTL_REPORT, "plain" has neither, "xy" has ARRAY without
// TTL_REPORT). Checks the well events (names, order, measured positions), the serial commands and the
// simulator's state for both paths and every advance source, resume_from, soft limits, pause, cancel.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "gateway/jobs/kinds/plate.hpp"
#include "gateway/jobs/kinds/safe_outputs.hpp"
#include "tests/integration/jobs/manager_fixture.hpp"
#include "tests/support/sim_serial_client.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;
using kind = operation_error_kind;

class array_run_test : public manager_fixture {
  protected:
    std::vector<json> steps(const std::string& id) {
        std::vector<json> out;
        for (const auto& e : sink_->of(id))
            if (e.value("type", "") == "step") out.push_back(e);
        return out;
    }
    // The wells of the step events, once `expected` of them have arrived (the hub delivers them
    // asynchronously: the job may already read succeeded).
    std::vector<std::string> wells(const std::string& id, std::size_t expected) {
        wait_until([&] { return steps(id).size() >= expected; }, 10s);
        std::vector<std::string> out;
        for (const auto& e : steps(id))
            out.push_back(e.value("well", ""));
        return out;
    }
    std::size_t steps_done(const std::string& id) {
        auto j = job(id);
        return j ? j->progress.steps_done : 0;
    }
    bool wait_steps(const std::string& id, std::size_t n) {
        const bool ok = wait_until([&] { return steps_done(id) >= n; }, 90s);
        if (!ok) ADD_FAILURE() << "job " << id << " did only " << steps_done(id) << " of " << n << " steps";
        return ok;
    }
    std::vector<std::string> commands_starting(const std::string& id, const std::string& prefix) {
        std::vector<std::string> out;
        for (const auto& c : commands_of(id))
            if (c.starts_with(prefix)) out.push_back(c);
        return out;
    }
    // Every step event: measured position within `tolerance_um` of the planned target.
    void expect_arrivals(const std::string& id, const std::vector<std::pair<double, double>>& targets,
                         double tolerance_um = 1.0) {
        wait_until([&] { return steps(id).size() >= targets.size(); }, 10s);
        const auto s = steps(id);
        ASSERT_EQ(s.size(), targets.size());
        for (std::size_t i = 0; i < s.size(); ++i) {
            ASSERT_TRUE(s[i]["position"].is_object()) << s[i].dump();
            EXPECT_NEAR(s[i]["position"]["X"].get<double>(), targets[i].first, tolerance_um) << s[i].dump();
            EXPECT_NEAR(s[i]["position"]["Y"].get<double>(), targets[i].second, tolerance_um) << s[i].dump();
            EXPECT_EQ(s[i]["name"], s[i]["well"]);
        }
    }
};

std::vector<std::pair<double, double>> plate_targets(const std::string& plate, double x0, double y0,
                                                     well_order order, double rotation = 0,
                                                     const std::vector<std::string>& subset = {}) {
    const auto g = *plate_preset(plate);
    std::vector<std::pair<double, double>> out;
    for (const auto& w : visit_order(g, order)) {
        if (!subset.empty() && std::find(subset.begin(), subset.end(), well_name(w)) == subset.end())
            continue;
        const auto [dx, dy] = well_offset_um(g, w, rotation);
        out.emplace_back(x0 + dx, y0 + dy);
    }
    return out;
}

std::vector<std::pair<double, double>> grid_targets(const plate_geometry& g, double x0, double y0,
                                                    well_order order) {
    std::vector<std::pair<double, double>> out;
    for (const auto& w : visit_order(g, order)) {
        const auto [dx, dy] = well_offset_um(g, w, 0);
        out.emplace_back(x0 + dx, y0 + dy);
    }
    return out;
}

std::vector<std::string> plate_names(const std::string& plate, well_order order) {
    std::vector<std::string> out;
    for (const auto& w : visit_order(*plate_preset(plate), order))
        out.push_back(well_name(w));
    return out;
}

TEST_F(array_run_test, firmware_96_wells_timer_advance) {
    add_sim("sim1", "full", 100);
    start();
    auto submitted =
        submit("sim1", job_type::array, {{"plate", "96"}, {"a1", {{"X", -40000}, {"Y", 30000}}}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    EXPECT_EQ(submitted->job.progress.steps_total, 96u);
    EXPECT_GT(submitted->job.estimated_s, 0);
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 180s));

    EXPECT_EQ(wells(id, plate_names("96", well_order::serpentine).size()),
              plate_names("96", well_order::serpentine));
    expect_arrivals(id, plate_targets("96", -40000, 30000, well_order::serpentine));
    const auto cmds = commands_of(id);
    auto pos = [&](const std::string& c) { return std::find(cmds.begin(), cmds.end(), c) - cmds.begin(); };
    ASSERT_LT(pos("TTL X=7"), pos("RM X=0"));
    EXPECT_LT(pos("ARRAY X=12 Y=8 Z=9 F=-9"), pos("RM X=0"));
    EXPECT_LT(pos("AHOME X=-40 Y=30"), pos("RM X=0"));
    EXPECT_EQ(std::count(cmds.begin(), cmds.end(), "RM"), 95);
    EXPECT_TRUE(commands_starting(id, "M ").empty());  // the ARRAY module moved the stage
    EXPECT_EQ(cmds.back(), "TTL X=0");                 // IN0 mode restored
    const auto st = sim_state("sim1");
    EXPECT_EQ(st["array"]["index"], 95);
    EXPECT_EQ(st["ttl"]["in0_mode"], 0);
    const auto done = job(id);
    EXPECT_EQ(done->progress.steps_done, 96u);
    EXPECT_EQ(done->progress.current_step, "H1");
}

TEST_F(array_run_test, host_run_with_rotation_subset_dwell_and_pulse) {
    add_sim("sim1", "full", 50);
    start();
    const std::vector<std::string> subset{"D6", "A1", "B2", "C5"};
    auto submitted = submit("sim1", job_type::array,
                            {{"plate", "24"},
                             {"a1", {{"X", -40000}, {"Y", 30000}}},
                             {"rotation_deg", 30},
                             {"order", "raster"},
                             {"wells", subset},
                             {"dwell_ms", 20},
                             {"ttl_pulse", true}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "host");
    EXPECT_EQ(submitted->plan.steps.size(), 4u);
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    EXPECT_EQ(wells(id, (std::vector<std::string>{"A1", "B2", "C5", "D6"}).size()),
              (std::vector<std::string>{"A1", "B2", "C5", "D6"}));
    expect_arrivals(id, plate_targets("24", -40000, 30000, well_order::raster, 30, subset));
    EXPECT_EQ(commands_starting(id, "M ").size(), 4u);
    EXPECT_TRUE(commands_starting(id, "RM").empty());
    EXPECT_EQ(commands_starting(id, "TTL Y=1").size(), 4u);  // one pulse per arrival
    EXPECT_EQ(commands_starting(id, "TTL Y=0").size(), 4u);
    EXPECT_EQ(sim_state("sim1")["ttl"]["out0_mode"], 0);  // the output ends low
}

// dwell_ms holds the stage at each well (real time, after the arrival and before the step event):
// each well's step event comes at least one dwell after the previous one (the first at least one
// dwell after the start), on both paths. The 0.5 mm grid keeps the moves themselves short, so the
// gaps would be far below 300 ms if the run ignored the dwell. No upper bound: the machine may be slow.
TEST_F(array_run_test, dwell_holds_every_well_on_both_paths) {
    add_sim("sim1", "full", 50);
    start();
    constexpr double dwell_s = 0.3;
    constexpr double rounding_s = 0.002;  // elapsed_s is rounded to the millisecond
    for (const std::string mode : {"firmware", "host"}) {
        SCOPED_TRACE(mode);
        auto submitted =
            submit("sim1", job_type::array,
                   {{"grid", {{"columns", 3}, {"rows", 2}, {"column_step_mm", 0.5}, {"row_step_mm", -0.5}}},
                    {"a1", {{"X", 1000}, {"Y", 1000}}},
                    {"dwell_ms", 300},
                    {"mode", mode}});
        ASSERT_TRUE(submitted) << submitted.error().message;
        const auto id = submitted->job.id;
        EXPECT_EQ(submitted->job.plan_path, mode);
        ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
        ASSERT_EQ(wells(id, 6).size(), 6u);
        const auto s = steps(id);
        double previous = 0;
        for (const auto& e : s) {
            const double elapsed = e["elapsed_s"].get<double>();
            EXPECT_GE(elapsed - previous, dwell_s - rounding_s) << e.dump();
            previous = elapsed;
        }
        const auto done = job(id);
        ASSERT_TRUE(done && done->started && done->finished);
        EXPECT_GE(std::chrono::duration<double>(*done->finished - *done->started).count(),
                  6 * dwell_s - rounding_s);
    }
}

// The TTL OUT0 pulse on arrival on the firmware path (ARRAY module, RM stepping): one "TTL Y=1" then
// "TTL Y=0" after each well's arrival was confirmed, before the next RM; the output ends low.
TEST_F(array_run_test, firmware_run_pulses_ttl_on_every_arrival) {
    add_sim("sim1", "full", 50);
    start();
    auto submitted =
        submit("sim1", job_type::array,
               {{"plate", "6"}, {"a1", {{"X", 0}, {"Y", 0}}}, {"ttl_pulse", true}, {"mode", "firmware"}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    expect_arrivals(id, plate_targets("6", 0, 0, well_order::serpentine));
    EXPECT_EQ(commands_starting(id, "TTL Y=1").size(), 6u);
    EXPECT_EQ(commands_starting(id, "TTL Y=0").size(), 6u);
    EXPECT_TRUE(commands_starting(id, "M ").empty());  // still the ARRAY module's moves
    // Each pulse follows its well's move command (RM X=0 for A1, RM after) and precedes the next one.
    std::vector<std::string> sequence;
    for (const auto& c : commands_of(id))
        if (c.starts_with("RM") || c.starts_with("TTL Y=")) sequence.push_back(c);
    std::vector<std::string> expected{"RM X=0", "TTL Y=1", "TTL Y=0"};
    for (int i = 1; i < 6; ++i)
        expected.insert(expected.end(), {"RM", "TTL Y=1", "TTL Y=0"});
    EXPECT_EQ(sequence, expected);
    EXPECT_EQ(sim_state("sim1")["ttl"]["out0_mode"], 0);  // the output ends low
}

// a1 "current": A1 is where the stage stands when the job starts. Both simulators are first moved to
// (x0, y0) = (5000, -3000) um over their own serial port; every arrival is then relative to that.
TEST_F(array_run_test, a1_current_is_the_position_at_the_start_on_both_paths) {
    constexpr double x0 = 5000, y0 = -3000;
    const std::vector<std::pair<std::string, std::string>> runs{{"sim1", "firmware"}, {"sim5", "host"}};
    for (const auto& run : runs) {
        const std::string& controller = run.first;
        auto sim = add_sim(controller, "full", 50);
        gw::tests::sim_serial_client client(sim->port_path());
        ASSERT_TRUE(client.command("M X=50000 Y=-30000"));  // tenths of a micrometre
        ASSERT_TRUE(wait_until([&] { return !sim_state(controller).value("busy", true); }, 10s));
    }
    start();
    const plate_geometry g{3, 2, 0.5, -0.5};
    for (const auto& run : runs) {
        const std::string& controller = run.first;
        const std::string& mode = run.second;
        SCOPED_TRACE(mode);
        ASSERT_TRUE(wait_until([&] {
            const auto x = position(controller, 'X'), y = position(controller, 'Y');
            return x && y && std::abs(*x - x0) < 1 && std::abs(*y - y0) < 1;
        })) << "the registry never saw the stage at (x0, y0)";
        auto submitted =
            submit(controller, job_type::array,
                   {{"grid", {{"columns", 3}, {"rows", 2}, {"column_step_mm", 0.5}, {"row_step_mm", -0.5}}},
                    {"a1", "current"},
                    {"mode", mode}});
        ASSERT_TRUE(submitted) << submitted.error().message;
        const auto id = submitted->job.id;
        EXPECT_EQ(submitted->job.plan_path, mode);
        ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
        expect_arrivals(id, grid_targets(g, x0, y0, well_order::serpentine));
        if (mode == "firmware") {
            EXPECT_EQ(commands_starting(id, "AHOME"), (std::vector<std::string>{"AHOME X=5 Y=-3"}));
        } else {
            EXPECT_EQ(commands_starting(id, "M ").size(), 6u);
        }
    }
}

// A crash can fall between a pulse's "TTL Y=1" and its "TTL Y=0": after the restart the new manager
// switches the output off for the interrupted pulsing job, under its own request id, and sends
// nothing as the job. (Where the crash fell is up to the timing; the command is sent either way.)
TEST_F(array_run_test, a_crash_of_a_pulsing_run_gets_ttl_y0_under_the_recovery_id_and_nothing_as_the_job) {
    add_sim("sim1", "full", 5);
    start();
    auto submitted =
        submit("sim1", job_type::array,
               {{"grid", {{"columns", 4}, {"rows", 3}, {"column_step_mm", 4}, {"row_step_mm", 4}}},
                {"a1", {{"X", 0}, {"Y", 0}}},
                {"mode", "host"},
                {"ttl_pulse", true}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return steps_done(id) >= 2; }, 30s));
    restart_manager();
    ASSERT_TRUE(wait_state(id, job_state::interrupted));
    const auto recovery = [&] {
        return observer_->locked([&] {
            std::vector<std::string> out;
            for (const auto& t : observer_->traces)
                if (t.request_id == safe_output_request_id(id)) out.push_back(t.wire);
            return out;
        });
    };
    // HALT first. Waited for whole: TTL Y=0 is traced a round trip after the HALT.
    const std::vector<std::string> expected{"\\\\\\r", "TTL Y=0\\r"};
    ASSERT_TRUE(wait_until([&] { return recovery() == expected; }, 10s))
        << testing::PrintToString(recovery());
    EXPECT_TRUE(wait_until([&] { return sim_state("sim1")["ttl"]["out0_mode"] == 0; }, 10s));
    // The crashed manager's run may still see its last move end (a test process cannot kill -9 a
    // coroutine): wait until the stage has stood still for 300 ms, as job_interruption_test does.
    int still = 0;
    ASSERT_TRUE(wait_until(
        [&] {
            still = sim_state("sim1").value("busy", true) ? 0 : still + 1;
            return still >= 30;
        },
        30s));
    EXPECT_EQ(sim_state("sim1")["ttl"]["out0_mode"], 0);
    EXPECT_EQ(recovery(), expected);  // once
    const auto as_job = commands_of(id);
    std::this_thread::sleep_for(300ms);
    const auto later = commands_of(id);
    EXPECT_EQ(later, as_job);
}

TEST_F(array_run_test, plain_controller_runs_host_driven_and_refuses_firmware) {
    add_sim("sim2", "plain", 50);
    start();
    auto refused = submit("sim2", job_type::array, {{"plate", "6"}, {"mode", "firmware"}});
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, kind::missing_module);
    auto submitted = submit("sim2", job_type::array, {{"plate", "6"}, {"a1", {{"X", 0}, {"Y", 0}}}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    EXPECT_EQ(submitted->job.plan_path, "host");
    ASSERT_TRUE(wait_state(submitted->job.id, job_state::succeeded, 120s));
    EXPECT_EQ(wells(submitted->job.id, plate_names("6", well_order::serpentine).size()),
              plate_names("6", well_order::serpentine));
    expect_arrivals(submitted->job.id, plate_targets("6", 0, 0, well_order::serpentine));
}

TEST_F(array_run_test, next_advance_waits_for_each_call_on_both_paths) {
    add_sim("sim1", "full", 50);
    start();
    for (const std::string mode : {"firmware", "host"}) {
        auto submitted =
            submit("sim1", job_type::array,
                   {{"plate", "6"}, {"a1", {{"X", 500}, {"Y", 500}}}, {"advance", "next"}, {"mode", mode}});
        ASSERT_TRUE(submitted) << submitted.error().message;
        const auto id = submitted->job.id;
        EXPECT_EQ(submitted->job.plan_path, mode);
        ASSERT_TRUE(wait_steps(id, 1));  // the first well needs no call
        for (std::size_t n = 2; n <= 6; ++n) {
            std::this_thread::sleep_for(150ms);  // room to misbehave: it must still wait here
            EXPECT_EQ(steps_done(id), n - 1) << mode;
            EXPECT_EQ(job(id)->state, job_state::running);
            ASSERT_TRUE(next(id));
            ASSERT_TRUE(wait_steps(id, n));
        }
        ASSERT_TRUE(wait_state(id, job_state::succeeded));
        EXPECT_EQ(wells(id, plate_names("6", well_order::serpentine).size()),
                  plate_names("6", well_order::serpentine));
        expect_arrivals(id, plate_targets("6", 500, 500, well_order::serpentine));
        if (mode == "firmware") {
            EXPECT_EQ(commands_starting(id, "RM").size(), 6u);  // RM X=0 + 5 RM
        }
    }
}

// TTL advance, firmware path, with TTL_REPORT ("full"): the gateway sees each IN0 edge as a report
// frame and forwards it as RM.
TEST_F(array_run_test, ttl_advance_firmware_with_ttl_report) {
    auto sim = add_sim("sim1", "full", 50);
    start();
    auto submitted =
        submit("sim1", job_type::array, {{"plate", "6"}, {"a1", {{"X", 0}, {"Y", 0}}}, {"advance", "ttl"}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    ASSERT_TRUE(wait_steps(id, 1));
    // It waits for an edge, which no one can predict: shown apart from the motion still ahead.
    ASSERT_TRUE(wait_until([&] { return job(id)->progress.waiting_for == job_wait::ttl; }));
    EXPECT_GT(job(id)->progress.remaining_s.value_or(0), 0);
    EXPECT_FALSE(job(id)->progress.eta);
    for (std::size_t n = 2; n <= 6; ++n) {
        sim->ttl_pulse();
        ASSERT_TRUE(wait_steps(id, n));
    }
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    EXPECT_EQ(wells(id, plate_names("6", well_order::serpentine).size()),
              plate_names("6", well_order::serpentine));
    expect_arrivals(id, plate_targets("6", 0, 0, well_order::serpentine));
}

// TTL advance, firmware path, without TTL_REPORT ("xy"): the controller steps itself on IN0 edges
// (TTL X=7) and the gateway follows the stage to each well.
TEST_F(array_run_test, ttl_advance_firmware_controller_steps_itself) {
    auto sim = add_sim("sim4", "xy", 50);
    start();
    auto submitted =
        submit("sim4", job_type::array, {{"plate", "6"}, {"a1", {{"X", 0}, {"Y", 0}}}, {"advance", "ttl"}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    ASSERT_TRUE(wait_steps(id, 1));
    // The gateway polls while the controller waits for the edge: the job still shows it waits for one.
    ASSERT_TRUE(wait_until([&] { return job(id)->progress.waiting_for == job_wait::ttl; }));
    for (std::size_t n = 2; n <= 6; ++n) {
        sim->ttl_pulse();
        ASSERT_TRUE(wait_steps(id, n));
    }
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    EXPECT_EQ(wells(id, plate_names("6", well_order::serpentine).size()),
              plate_names("6", well_order::serpentine));
    expect_arrivals(id, plate_targets("6", 0, 0, well_order::serpentine));
    EXPECT_EQ(commands_starting(id, "RM").size(), 1u);  // only RM X=0: the edges did the rest
}

TEST_F(array_run_test, ttl_advance_host_path) {
    auto sim = add_sim("sim1", "full", 50);
    start();
    auto submitted =
        submit("sim1", job_type::array,
               {{"plate", "6"}, {"a1", {{"X", 0}, {"Y", 0}}}, {"advance", "ttl"}, {"order", "raster"}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "host");
    ASSERT_TRUE(wait_steps(id, 1));
    for (std::size_t n = 2; n <= 6; ++n) {
        sim->ttl_pulse();
        ASSERT_TRUE(wait_steps(id, n));
    }
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    EXPECT_EQ(wells(id, plate_names("6", well_order::raster).size()), plate_names("6", well_order::raster));
    expect_arrivals(id, plate_targets("6", 0, 0, well_order::raster));
}

TEST_F(array_run_test, resume_from_a_well_on_both_paths) {
    add_sim("sim1", "full", 50);
    start();
    for (const std::string mode : {"firmware", "host"}) {
        auto submitted =
            submit("sim1", job_type::array,
                   {{"plate", "12"}, {"a1", {{"X", 0}, {"Y", 0}}}, {"resume_from", "B2"}, {"mode", mode}});
        ASSERT_TRUE(submitted) << submitted.error().message;
        const auto id = submitted->job.id;
        ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
        // Serpentine 4x3: A1 A2 A3 A4 B4 B3 B2 B1 C1 ...; B2 is the 7th well.
        auto all = plate_names("12", well_order::serpentine);
        EXPECT_EQ(wells(id, std::vector<std::string>(all.begin() + 6, all.end()).size()),
                  std::vector<std::string>(all.begin() + 6, all.end()))
            << mode;
        auto targets = plate_targets("12", 0, 0, well_order::serpentine);
        expect_arrivals(id, {targets.begin() + 6, targets.end()});
        EXPECT_EQ(job(id)->progress.steps_done, 12u);
        if (mode == "firmware") {
            EXPECT_EQ(commands_starting(id, "AIJ"), (std::vector<std::string>{"AIJ X=2 Y=2"}));
            EXPECT_EQ(commands_starting(id, "RM").size(), 5u);
        }
    }
}

TEST_F(array_run_test, soft_limits_refuse_the_job_naming_the_well) {
    auto sim = add_sim("sim1", "full", 50);
    {
        gw::tests::sim_serial_client client(sim->port_path());
        ASSERT_TRUE(client.command("SU X=30"));
        ASSERT_TRUE(client.command("SL Y=-20"));
    }
    start();
    auto refused = submit("sim1", job_type::array, {{"plate", "96"}, {"a1", {{"X", 0}, {"Y", 0}}}});
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, kind::invalid_value);
    EXPECT_NE(refused.error().message.find("A5"), std::string::npos) << refused.error().message;  // X = 36 mm
    auto refused_y =
        submit("sim1", job_type::array,
               {{"plate", "96"}, {"a1", {{"X", 0}, {"Y", 0}}}, {"mode", "host"}, {"wells", {"A1", "D1"}}});
    ASSERT_FALSE(refused_y);
    EXPECT_NE(refused_y.error().message.find("D1"), std::string::npos)
        << refused_y.error().message;  // Y = -27 mm
    auto fits = submit("sim1", job_type::array,
                       {{"plate", "96"}, {"a1", {{"X", 0}, {"Y", 0}}}, {"wells", {"A1", "B2"}}});
    EXPECT_TRUE(fits) << fits.error().message;
}

TEST_F(array_run_test, pause_in_the_middle_of_a_plate_then_resume) {
    add_sim("sim1", "full", 20);
    start();
    auto submitted = submit("sim1", job_type::array, {{"plate", "24"}, {"a1", {{"X", 0}, {"Y", 0}}}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_steps(id, 3));
    ASSERT_TRUE(pause(id));
    ASSERT_TRUE(wait_state(id, job_state::paused));
    const auto at_pause = steps_done(id);
    EXPECT_LT(at_pause, 24u);
    std::this_thread::sleep_for(200ms);  // room to misbehave: nothing moves while paused
    EXPECT_EQ(steps_done(id), at_pause);
    EXPECT_FALSE(registry_->get("sim1")->busy);
    ASSERT_TRUE(resume(id));
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    EXPECT_EQ(wells(id, plate_names("24", well_order::serpentine).size()),
              plate_names("24", well_order::serpentine));  // each well once, in order
    expect_arrivals(id, plate_targets("24", 0, 0, well_order::serpentine));
}

TEST_F(array_run_test, cancel_of_a_firmware_run_sets_in0_back) {
    add_sim("sim1", "full", 5);
    start();
    auto submitted = submit("sim1", job_type::array, {{"plate", "96"}, {"a1", {{"X", 0}, {"Y", 0}}}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    EXPECT_EQ(submitted->job.plan_path, "firmware");
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_steps(id, 2));
    EXPECT_EQ(sim_state("sim1")["ttl"]["in0_mode"], 7);  // the ARRAY module steps on IN0 edges
    ASSERT_TRUE(cancel(id));
    ASSERT_TRUE(wait_state(id, job_state::cancelled));
    EXPECT_EQ(sim_state("sim1")["ttl"]["in0_mode"], 0);
    EXPECT_EQ(sim_state("sim1")["ttl"]["out0_mode"], 0);
}

TEST_F(array_run_test, cancel_in_the_middle_of_a_plate_halts) {
    add_sim("sim1", "full", 5);
    start();
    auto submitted =
        submit("sim1", job_type::array,
               {{"plate", "96"}, {"a1", {{"X", 0}, {"Y", 0}}}, {"mode", "host"}, {"ttl_pulse", true}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_steps(id, 2));
    ASSERT_TRUE(cancel(id));
    ASSERT_TRUE(wait_state(id, job_state::cancelled));
    const auto n = steps_done(id);
    EXPECT_LT(n, 96u);
    ASSERT_TRUE(wait_until([&] { return !sim_state("sim1").value("busy", true); }, 10s))
        << sim_state("sim1").dump();
    EXPECT_EQ(sim_state("sim1")["ttl"]["out0_mode"], 0);
    EXPECT_EQ(wells(id, n).size(), n);
}

}  // namespace
}  // namespace gw::jobs::test
