// gcode jobs end to end through the real job_manager and an in-process simulator (time_scale 20):
// the traced encoder path against the ideal path, the TTL transitions at the planned points, cancel
// and unplug with the TTL output on, pause/resume, Z analog mode, and the refusals (program error,
// soft limits) before anything moves.
//
// The path is recorded by polling the simulator's state (positions and TTL out of one instant) every
// millisecond of real time, or as fast as a state can be read (every 7-8 ms in the sanitizer build
// on a loaded machine); the traced run's simulator runs at time_scale 5, so that even then the samples
// lie a few tens of micrometres apart. The simulator's positions are exact on each axis's trapezoid, so every
// sample of a coordinated trace lies on a chord of the ideal path: within the arc tolerance (the
// chords' sagitta, 1 um) plus the finish error (targets are quantised to one encoder count, 0.022 um
// on the B screw) plus a sampling margin of 0.1 um (SPEED's six decimals make the axes' arrival times
// differ by a few nanoseconds' travel). An uncoordinated trace (every axis at one SPEED) misses by
// hundreds of micrometres on the diagonals and arcs below.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

#include "gateway/gcode/gcode_planner.hpp"
#include "gateway/jobs/kinds/safe_outputs.hpp"
#include "gateway/storage/gcode_files.hpp"
#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;

constexpr double arc_tolerance_um = 1.0;
constexpr double finish_error_um = 0.022;
constexpr double sampling_margin_um = 0.1;
constexpr double path_tolerance_um = arc_tolerance_um + finish_error_um + sampling_margin_um;

struct sample {
    double x_um = 0, y_um = 0;
    bool ttl = false;
};

// A piece of the ideal path (micrometres) and whether the TTL output is on along it.
struct piece {
    double ax, ay, bx, by;
    bool ttl;
};

double distance_to(const piece& p, double x, double y) {
    const double dx = p.bx - p.ax, dy = p.by - p.ay;
    const double len2 = dx * dx + dy * dy;
    double t = len2 > 0 ? ((x - p.ax) * dx + (y - p.ay) * dy) / len2 : 0;
    t = std::clamp(t, 0.0, 1.0);
    return std::hypot(x - (p.ax + t * dx), y - (p.ay + t * dy));
}

// The ideal path of a program: straight moves as they are, arcs as 200 chords per segment the job
// traces (their sagitta is 40 000 times smaller than the tolerance: the true arc).
std::vector<piece> ideal_path(const std::string& program) {
    std::istringstream in(program);
    gcode::gcode_options options;
    gcode::gcode_planner planner(in, options);
    std::vector<piece> out;
    bool ttl = false;
    while (const auto* m = planner.next()) {
        if (m->kind == gcode::move_kind::ttl) ttl = m->ttl_on;
        if (m->kind != gcode::move_kind::rapid && m->kind != gcode::move_kind::linear &&
            m->kind != gcode::move_kind::arc)
            continue;
        const int dense = m->kind == gcode::move_kind::arc ? 200 * static_cast<int>(m->segments) : 1;
        gcode::vec3 a = m->start;
        for (int i = 1; i <= dense; ++i) {
            const gcode::vec3 b = m->kind == gcode::move_kind::arc
                                      ? gcode::arc_point(m->arc, static_cast<double>(i) / dense)
                                      : m->end;
            out.push_back({a.x * 1000, a.y * 1000, b.x * 1000, b.y * 1000, ttl});
            a = b;
        }
    }
    EXPECT_FALSE(planner.error()) << planner.error()->message;
    return out;
}

// The smallest distance from (x, y) to a piece with the given TTL state (any piece: nullopt).
double distance_to_path(const std::vector<piece>& path, double x, double y, std::optional<bool> ttl) {
    double best = 1e18;
    for (const auto& p : path)
        if (!ttl || p.ttl == *ttl) best = std::min(best, distance_to(p, x, y));
    return best;
}

class gcode_run_test : public manager_fixture {
  protected:
    // Polls the simulator until stop_recording().
    void start_recording(const std::string& sim) {
        recording_ = true;
        recorder_ = std::thread([this, sim] {
            while (recording_) {
                const auto st = sim_state(sim);
                sample s;
                s.x_um = st["axes"]["X"]["position"].get<double>() / 10.0;
                s.y_um = st["axes"]["Y"]["position"].get<double>() / 10.0;
                s.ttl = st["ttl"]["out0_mode"].get<int>() == 1;
                {
                    std::lock_guard lock(samples_mutex_);
                    samples_.push_back(s);
                }
                std::this_thread::sleep_for(1ms);
            }
        });
    }
    std::vector<sample> stop_recording() {
        recording_ = false;
        if (recorder_.joinable()) recorder_.join();
        std::lock_guard lock(samples_mutex_);
        return samples_;
    }
    std::vector<sample> samples() {
        std::lock_guard lock(samples_mutex_);
        return samples_;
    }
    void TearDown() override {
        stop_recording();
        manager_fixture::TearDown();
    }

    std::vector<json> steps_of(const std::string& id) {
        std::vector<json> out;
        for (const auto& e : sink_->of(id))
            if (e.value("type", "") == "step") out.push_back(e);
        return out;
    }
    int ttl_out(const std::string& sim) { return sim_state(sim)["ttl"]["out0_mode"].get<int>(); }
    double sim_um(const std::string& sim, char axis) {
        return sim_state(sim)["axes"][std::string(1, axis)]["position"].get<double>() / 10.0;
    }
    bool sim_busy(const std::string& sim) { return sim_state(sim)["busy"].get<bool>(); }
    // Every command on the wire so far (any request id): {request id, wire text without CR}.
    std::vector<std::pair<std::string, std::string>> all_commands() {
        return observer_->locked([&] {
            std::vector<std::pair<std::string, std::string>> out;
            for (const auto& t : observer_->traces) {
                auto w = t.wire;
                if (w.ends_with("\\r")) w.resize(w.size() - 2);
                out.emplace_back(t.request_id, w);
            }
            return out;
        });
    }

    std::atomic<bool> recording_{false};
    std::thread recorder_;
    std::mutex samples_mutex_;
    std::vector<sample> samples_;
};

// A diagonal, a square, and a full circle (radius 1.414 mm, 1 um chords: 75 segments) with the TTL
// on along the square's two sides and the circle only.
const std::string trace_program =
    "%\n"
    "G21 G90\n"
    "G00 X1 Y0.5\n"
    "M03\n"
    "G01 X3 F120\n"
    "G01 Y2.5\n"
    "M05\n"
    "G01 X1 Y2 F90\n"
    "M03\n"
    "G02 X1 Y2 I1 J-1 F60\n"
    "M05\n"
    "G00 X0 Y0\n"
    "%\n";

TEST_F(gcode_run_test, the_traced_path_stays_on_the_ideal_path_and_the_ttl_switches_at_the_planned_points) {
    add_sim("sim1", "full", 5);
    start();
    const auto path = ideal_path(trace_program);
    start_recording("sim1");
    auto submitted = submit("sim1", job_type::gcode, {{"program", trace_program}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    EXPECT_EQ(submitted->job.plan_path, "host");
    // Lines 3-12: ten lines that move or switch.
    EXPECT_EQ(submitted->job.progress.steps_total, 10u);
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    std::this_thread::sleep_for(50ms);
    const auto trace = stop_recording();

    ASSERT_GT(trace.size(), 500u);
    double worst = 0, worst_on = 0, worst_off = 0;
    std::size_t on_samples = 0, rises = 0, falls = 0;
    for (std::size_t i = 0; i < trace.size(); ++i) {
        const auto& s = trace[i];
        worst = std::max(worst, distance_to_path(path, s.x_um, s.y_um, std::nullopt));
        if (s.ttl) {
            ++on_samples;
            worst_on = std::max(worst_on, distance_to_path(path, s.x_um, s.y_um, true));
        } else {
            worst_off = std::max(worst_off, distance_to_path(path, s.x_um, s.y_um, false));
        }
        if (i > 0 && s.ttl && !trace[i - 1].ttl) ++rises;
        if (i > 0 && !s.ttl && trace[i - 1].ttl) ++falls;
    }
    EXPECT_LE(worst, path_tolerance_um);
    // TTL on only along the stretches the program lights, off only along the others.
    EXPECT_LE(worst_on, path_tolerance_um);
    EXPECT_LE(worst_off, path_tolerance_um);
    EXPECT_GT(on_samples, 100u);
    EXPECT_EQ(rises, 2u);
    EXPECT_EQ(falls, 2u);
    // The circle was traced all round while lit: samples near each of its four extremes.
    for (const auto& [x, y] :
         {std::pair{3414.2, 1000.0}, {2000.0, 2414.2}, {585.8, 1000.0}, {2000.0, -414.2}}) {
        double nearest = 1e18;
        for (const auto& s : trace)
            if (s.ttl) nearest = std::min(nearest, std::hypot(s.x_um - x, s.y_um - y));
        // A sample every 5-40 ms of simulated time (1-8 ms real at time_scale 5): 5-40 um apart at
        // 1 mm/s; a tenth of the radius proves the extreme was reached.
        EXPECT_LT(nearest, 141.0) << x << "," << y;
    }

    EXPECT_NEAR(sim_um("sim1", 'X'), 0, 0.1);
    EXPECT_NEAR(sim_um("sim1", 'Y'), 0, 0.1);
    EXPECT_EQ(ttl_out("sim1"), 0);
    // The SPEEDs the trace changed are back.
    EXPECT_NEAR(sim_state("sim1")["axes"]["X"]["speed"].get<double>(), 5.5, 1e-6);
    EXPECT_NEAR(sim_state("sim1")["axes"]["Y"]["speed"].get<double>(), 5.5, 1e-6);
    // Z (not in the program) was never commanded.
    for (const auto& c : commands_of(id))
        if (c.starts_with("M ")) {
            EXPECT_EQ(c.find('Z'), std::string::npos) << c;
        }

    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 10; }));
    const auto steps = steps_of(id);
    ASSERT_EQ(steps.size(), 10u);
    EXPECT_EQ(steps.front()["name"], "line 3");
    EXPECT_EQ(steps.back()["name"], "line 12");
    EXPECT_EQ(steps[2]["line"], 5);
    EXPECT_NEAR(steps[2]["position"]["X"].get<double>(), 3000, 0.1);
}

// A 20 mm line at 1 mm/s with the TTL on: 20 s of simulated time, 1 s of real time.
const std::string long_lit_line = "G21 G90\nM03\nG01 X20 F60\nM05\n";

TEST_F(gcode_run_test, cancel_mid_trace_with_the_ttl_on_leaves_the_output_low_and_the_stage_stopped) {
    add_sim("sim1", "full");
    start();
    auto submitted = submit("sim1", job_type::gcode, {{"program", long_lit_line}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return ttl_out("sim1") == 1 && sim_um("sim1", 'X') > 500; }, 30s));
    ASSERT_TRUE(cancel(id));
    ASSERT_TRUE(wait_state(id, job_state::cancelled));
    EXPECT_EQ(ttl_out("sim1"), 0);
    EXPECT_FALSE(sim_busy("sim1"));
    const double x = sim_um("sim1", 'X');
    EXPECT_LT(x, 19000);
    std::this_thread::sleep_for(100ms);
    EXPECT_EQ(sim_um("sim1", 'X'), x);                                              // stopped, not coasting
    EXPECT_NEAR(sim_state("sim1")["axes"]["X"]["speed"].get<double>(), 5.5, 1e-6);  // restored
}

TEST_F(gcode_run_test, an_unplugged_controller_gets_its_ttl_output_low_when_it_is_back_and_resume_finishes) {
    add_sim("sim1", "full");
    start();
    auto submitted = submit("sim1", job_type::gcode, {{"program", long_lit_line}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return ttl_out("sim1") == 1 && sim_um("sim1", 'X') > 500; }, 30s));
    sims_.at("sim1")->unplug();
    ASSERT_TRUE(wait_state(id, job_state::paused));
    EXPECT_TRUE(job(id)->reason.starts_with("controller disconnected")) << job(id)->reason;
    // Unplugged, the controller keeps its output: nobody can reach it.
    EXPECT_EQ(ttl_out("sim1"), 1);
    sims_.at("sim1")->replug();
    ASSERT_TRUE(wait_until([&] { return ttl_out("sim1") == 0; }, 30s)) << "TTL still on after the replug";
    EXPECT_EQ(job(id)->state, job_state::paused);  // low, and nothing else: the job waits for resume

    ASSERT_TRUE(wait_until([&] { return registry_->ready(); }));
    ASSERT_TRUE(resume(id));
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 60s));
    EXPECT_NEAR(sim_um("sim1", 'X'), 20000, 0.1);
    EXPECT_EQ(ttl_out("sim1"), 0);
    // The resumed run re-lit the output for line 3 after moving back to where the line starts.
    const auto sent = commands_of(id);
    EXPECT_GE(std::count(sent.begin(), sent.end(), "TTL Y=1"), 2);
}

// kill -9 of the gateway with the laser on: the new manager finds the job interrupted and switches
// the output off, under a request id of its own (not the job's, whose trace must stay as the crash
// left it), and sends nothing of the program again until the job is resumed.
TEST_F(gcode_run_test, a_crash_with_the_ttl_on_gets_the_output_low_after_the_restart_and_resends_no_move) {
    add_sim("sim1", "full");
    start();
    auto submitted = submit("sim1", job_type::gcode, {{"program", long_lit_line}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return ttl_out("sim1") == 1 && sim_um("sim1", 'X') > 500; }, 30s));
    const auto is_move = [](const std::string& c) { return c.starts_with("M "); };
    const auto before = commands_of(id);
    ASSERT_EQ(std::count_if(before.begin(), before.end(), is_move), 1);  // line 3 is one MOVE
    restart_manager();  // destroyed without shutdown: nothing of the old one switches the output off
    ASSERT_TRUE(wait_state(id, job_state::interrupted));
    ASSERT_TRUE(wait_until([&] { return ttl_out("sim1") == 0; }, 30s)) << "TTL still on after the restart";
    // The controller ends its move by itself (and the crashed manager's run may still see it end: a
    // test process cannot kill -9 a coroutine): wait until the stage has stood still for 300 ms.
    int still = 0;
    ASSERT_TRUE(wait_until(
        [&] {
            still = sim_busy("sim1") ? 0 : still + 1;
            return still >= 30;
        },
        30s));
    const auto job_commands = commands_of(id);
    std::this_thread::sleep_for(300ms);
    EXPECT_EQ(commands_of(id), job_commands);  // nothing sent for the job after the crash
    EXPECT_EQ(std::count_if(job_commands.begin(), job_commands.end(), is_move), 1);
    // The job's own "TTL Y=0" is only the one every run starts with: the output went low by the
    // recovery's command.
    EXPECT_EQ(std::count(job_commands.begin(), job_commands.end(), "TTL Y=0"), 1);
    const auto sent = all_commands();
    std::size_t halts = 0, lows = 0, moves = 0;
    for (const auto& [rid, wire] : sent) {
        if (rid == safe_output_request_id(id)) {
            // HALT first, then the output, then the job's restore commands (its SPEEDs; its own
            // "TTL Y=0" is not sent twice).
            if (halts == 0) {
                EXPECT_EQ(wire, "\\\\") << "HALT before anything else";
            }
            if (wire == "\\\\") {
                ++halts;
                continue;
            }
            if (lows == 0) {
                EXPECT_EQ(wire, "TTL Y=0");
            }
            if (wire == "TTL Y=0") {
                ++lows;
            } else {
                EXPECT_TRUE(wire.starts_with("SPEED ")) << wire;
            }
        }
        if (is_move(wire)) ++moves;
    }
    EXPECT_EQ(halts, 1u);  // the stage may have been moving when the gateway went down
    EXPECT_EQ(lows, 1u);   // once, under the recovery's id
    EXPECT_NEAR(sim_state("sim1")["axes"]["X"]["speed"].get<double>(), 5.5, 1e-6);  // restored
    EXPECT_EQ(moves, 1u);  // the program's one MOVE, before the crash
    EXPECT_EQ(job(id)->state, job_state::interrupted);

    ASSERT_TRUE(resume(id));
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 60s));
    EXPECT_NEAR(sim_um("sim1", 'X'), 20000, 0.1);
    EXPECT_EQ(ttl_out("sim1"), 0);
}

// The crash happens while the controller is unplugged (the job paused, the output still on): the new
// manager cannot reach it at start-up and switches the output off when it is back.
TEST_F(gcode_run_test, a_crash_while_unplugged_gets_the_output_low_once_the_controller_is_back) {
    add_sim("sim1", "full");
    start();
    auto submitted = submit("sim1", job_type::gcode, {{"program", long_lit_line}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return ttl_out("sim1") == 1 && sim_um("sim1", 'X') > 500; }, 30s));
    sims_.at("sim1")->unplug();
    ASSERT_TRUE(wait_state(id, job_state::paused));
    restart_manager();
    ASSERT_TRUE(wait_state(id, job_state::interrupted));
    std::this_thread::sleep_for(200ms);
    EXPECT_EQ(ttl_out("sim1"), 1);  // unreachable meanwhile
    sims_.at("sim1")->replug();
    ASSERT_TRUE(wait_until([&] { return ttl_out("sim1") == 0; }, 30s)) << "TTL still on after the replug";
    // The simulator switches the output as it reads the command; the gateway records the command when
    // its answer is back, and only then sends the job's restore (SPEED): wait for both before counting.
    const auto lows = [&] {
        std::size_t n = 0;
        for (const auto& [rid, wire] : all_commands())
            if (rid == safe_output_request_id(id) && wire == "TTL Y=0") ++n;
        return n;
    };
    ASSERT_TRUE(wait_until(
        [&] {
            return lows() >= 1 &&
                   std::abs(sim_state("sim1")["axes"]["X"]["speed"].get<double>() - 5.5) < 1e-6;
        },
        30s))
        << "the output's command or the speed restore never came";
    EXPECT_EQ(lows(), 1u);
    EXPECT_EQ(job(id)->state, job_state::interrupted);
}

TEST_F(gcode_run_test, pause_waits_between_lines_with_the_ttl_off_and_resume_continues_on_the_path) {
    add_sim("sim1", "full");
    start();
    // Four lit 2 mm sides at 2 mm/s: 1 s of simulated time each.
    const std::string square = "G21 G90\nG00 X1 Y1\nM03\nG01 X3 F120\nG01 Y3\nG01 X1\nG01 Y1\nM05\n";
    const auto path = ideal_path(square);
    start_recording("sim1");
    auto submitted = submit("sim1", job_type::gcode, {{"program", square}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return ttl_out("sim1") == 1; }, 30s));
    ASSERT_TRUE(pause(id));
    ASSERT_TRUE(wait_state(id, job_state::paused));
    const auto paused = job(id);
    // The pause can land while M03 (step 2) is still being acknowledged: then the run stops right
    // after it, and the resume lights the output again before the first lit side.
    EXPECT_GE(paused->progress.steps_done, 2u);
    EXPECT_LT(paused->progress.steps_done, 7u);
    EXPECT_EQ(ttl_out("sim1"), 0);
    EXPECT_FALSE(sim_busy("sim1"));
    std::this_thread::sleep_for(200ms);
    EXPECT_EQ(ttl_out("sim1"), 0);
    ASSERT_TRUE(resume(id));
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 60s));
    const auto trace = stop_recording();
    for (const auto& s : trace) {
        ASSERT_LE(distance_to_path(path, s.x_um, s.y_um, std::nullopt), path_tolerance_um)
            << s.x_um << "," << s.y_um;
        if (s.ttl) {
            ASSERT_LE(distance_to_path(path, s.x_um, s.y_um, true), path_tolerance_um);
        }
    }
    EXPECT_NEAR(sim_um("sim1", 'X'), 1000, 0.1);
    EXPECT_NEAR(sim_um("sim1", 'Y'), 1000, 0.1);
    ASSERT_TRUE(wait_until([&] { return steps_of(id).size() >= 7; }));
    const auto steps = steps_of(id);
    ASSERT_EQ(steps.size(), 7u);  // every line once: none repeated, none skipped
    for (std::size_t i = 0; i < steps.size(); ++i)
        EXPECT_EQ(steps[i]["line"], static_cast<int>(i) + 2);
}

TEST_F(gcode_run_test, z_analog_mode_sets_the_dac_through_wrdac) {
    add_sim("sim1", "planar");  // the preset with DAC OUT
    add_sim("sim2", "full");
    start();
    auto no_dac = submit("sim2", job_type::gcode,
                         {{"program", "G01 X0.5 Z0.02 F60\n"}, {"options", {{"z_mode", "analog"}}}});
    ASSERT_FALSE(no_dac);
    EXPECT_EQ(no_dac.error().kind, operation_error_kind::missing_module);
    EXPECT_EQ(no_dac.error().field, "spec.options.z_mode");
    // Standard piezo range: V = 0.1 * Z[um] + 5; Z0.02 mm = 20 um -> 7 V.
    auto submitted =
        submit("sim1", job_type::gcode,
               {{"program", "G21 G90\nG01 X0.5 Z0.02 F60\n"}, {"options", {{"z_mode", "analog"}}}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    ASSERT_TRUE(wait_state(submitted->job.id, job_state::succeeded));
    EXPECT_NEAR(sim_state("sim1")["dac_volts"].get<double>(), 7.0, 1e-6);
    EXPECT_NEAR(sim_um("sim1", 'X'), 500, 0.1);
    EXPECT_NEAR(sim_um("sim1", 'Z'), 0, 0.1);  // the stage Z stays
    const auto sent = commands_of(submitted->job.id);
    EXPECT_NE(std::find(sent.begin(), sent.end(), "WRDAC X=7"), sent.end());
}

TEST_F(gcode_run_test, a_program_error_or_a_soft_limit_is_refused_before_anything_moves) {
    add_sim("sim1", "full");
    start();
    auto error = submit("sim1", job_type::gcode, {{"program", "G21 G90\nG01 X1 F60\nG28 X0\n"}});
    ASSERT_FALSE(error);
    EXPECT_EQ(error.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(error.error().field, "spec.program");
    EXPECT_NE(error.error().message.find("line 3, column 1"), std::string::npos) << error.error().message;

    // Soft limits of the simulator: +-110 mm.
    auto beyond = submit("sim1", job_type::gcode, {{"program", "G21 G90\nG01 X1 F60\nG01 X150\nG01 X0\n"}});
    ASSERT_FALSE(beyond);
    EXPECT_EQ(beyond.error().field, "spec.program");
    EXPECT_NE(beyond.error().message.find("line 3"), std::string::npos) << beyond.error().message;
    EXPECT_NE(beyond.error().message.find("upper soft limit"), std::string::npos) << beyond.error().message;
    // An arc whose end points are inside but whose extreme is not (centre X=100, radius 20, 270
    // degrees counter-clockwise through X=120).
    auto arc = submit("sim1", job_type::gcode, {{"program", "G21 G90\nG00 X80\nG03 X100 Y20 I20 F60\n"}});
    ASSERT_FALSE(arc);
    EXPECT_NE(arc.error().message.find("line 3"), std::string::npos) << arc.error().message;

    auto spec_errors = std::vector<std::pair<json, std::string>>{
        {{{"program", "G01 X1 F60"}, {"file", "g-x"}}, "spec.file"},
        {json::object(), "spec.program"},
        {{{"program", 12}}, "spec.program"},
        {{{"program", "G00 X1"}, {"speed", 2}}, "spec.speed"},
        {{{"program", "G00 X1"}, {"options", {{"arc_tolerance_mm", 0}}}}, "spec.options.arc_tolerance_mm"},
        {{{"program", "G00 X1"}, {"options", {{"colour", "red"}}}}, "spec.options.colour"},
    };
    for (const auto& [spec, field] : spec_errors) {
        auto refused = submit("sim1", job_type::gcode, spec);
        ASSERT_FALSE(refused) << spec.dump();
        EXPECT_EQ(refused.error().field, field) << spec.dump() << ": " << refused.error().message;
    }
    // Nothing moved, nothing was stored.
    EXPECT_EQ(sim_um("sim1", 'X'), 0);
    auto listed = manager_->list(job_filter{});
    ASSERT_TRUE(listed);
    EXPECT_TRUE(listed->jobs.empty());
}

TEST_F(gcode_run_test, the_dry_run_previews_the_commands_and_steps_per_line) {
    add_sim("sim1", "full");
    start();
    auto dry =
        submit("sim1", job_type::gcode, {{"program", trace_program}}, std::nullopt, std::nullopt, true);
    ASSERT_TRUE(dry) << dry.error().message;
    const auto& plan = dry->plan;
    ASSERT_EQ(plan.steps.size(), 10u);
    EXPECT_EQ(plan.steps[0].name, "line 3");
    ASSERT_TRUE(plan.steps[2].target);
    EXPECT_NEAR(plan.steps[2].target->at('X'), 3000, 1e-6);
    EXPECT_FALSE(plan.steps[2].target->contains('Z'));
    EXPECT_GT(plan.estimated_s, 10);  // 2 + 2 + 2.06 s of lines, the circle 8.9 s at 1 mm/s ...
    ASSERT_GE(plan.commands.size(), 6u);
    EXPECT_EQ(plan.commands[0], "TTL Y=0");
    // The diagonal rapid from (0, 0) to (1, 0.5) at 5.5 mm/s: X 4.919350, Y 2.459675 mm/s.
    EXPECT_EQ(plan.commands[1], "SPEED X=4.91935 Y=2.459675");
    EXPECT_EQ(plan.commands[2], "M X=10000 Y=5000");
    EXPECT_EQ(plan.commands[3], "TTL Y=1");
    EXPECT_EQ(plan.commands[4], "SPEED X=2");  // G01 X3 F120: only X moves
    EXPECT_EQ(plan.commands[5], "M X=30000");
    EXPECT_EQ(sim_um("sim1", 'X'), 0);
}

TEST_F(gcode_run_test, an_uploaded_program_runs_by_its_file_id) {
    add_sim("sim1", "full");
    start();
    // The API's store lives in <storage.path>/gcode; the manager reads the same directory.
    gcode_file_store store(
        gcode_file_store_settings{std::filesystem::path(settings().storage_path) / "gcode"});
    std::istringstream program("G21 G90\nG01 X0.4 Y0.3 F60\nG04 P100\nG01 X0 Y0\n");
    auto saved = store.save(program, "triangle.ngc");
    ASSERT_TRUE(saved) << saved.error().message;
    auto submitted = submit("sim1", job_type::gcode, {{"file", saved->id}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    EXPECT_EQ(submitted->job.progress.steps_total, 3u);
    ASSERT_TRUE(wait_state(submitted->job.id, job_state::succeeded));
    const auto sent = commands_of(submitted->job.id);
    EXPECT_NE(std::find(sent.begin(), sent.end(), "M X=4000 Y=3000"), sent.end());
    EXPECT_NE(std::find(sent.begin(), sent.end(), "SPEED X=0.8 Y=0.6"), sent.end());

    auto unknown = submit("sim1", job_type::gcode, {{"file", "g-01JAAAAAAAAAAAAAAAAAAAAAAA"}});
    ASSERT_FALSE(unknown);
    EXPECT_EQ(unknown.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(unknown.error().field, "spec.file");
}

}  // namespace
}  // namespace gw::jobs::test
