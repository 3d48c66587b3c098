// The ETA motion model: closed-form table of moves (long, short/triangle, multi-axis, zero), settle
// scaling with the finish error, the lead-screw table, and agreement with the pure simulator model
// in simulated time (same formula, so to the microsecond).
#include "gateway/jobs/motion_model.hpp"

#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "devices/sim/ms2000_model.hpp"

namespace gw::jobs {
namespace {

struct move_row {
    const char* name;
    std::vector<axis_delta_mm> deltas;
    double expected_s;
};

// Default B screw: v = 5.5 mm/s, r = 20 ms (a = 275 mm/s^2, v*r = 0.11 mm), settle 14 ms.
const move_row move_table[] = {
    {"nine_mm", {{'X', 9.0}}, 9.0 / 5.5 + 0.020 + 0.014},
    {"nine_mm_backwards", {{'X', -9.0}}, 9.0 / 5.5 + 0.020 + 0.014},
    {"fifth_mm", {{'Y', 0.2}}, 0.2 / 5.5 + 0.020 + 0.014},
    {"triangle_50um", {{'X', 0.05}}, 2 * std::sqrt(0.05 / 275.0) + 0.014},
    {"triangle_1um", {{'Z', -0.001}}, 2 * std::sqrt(0.001 / 275.0) + 0.014},
    {"boundary_v_times_r", {{'X', 0.11}}, 0.040 + 0.014},
    {"long_travel_100mm", {{'X', 100.0}}, 100.0 / 5.5 + 0.020 + 0.014},
    {"multi_axis_slowest_wins", {{'X', 9.0}, {'Y', -1.0}, {'Z', 0.05}}, 9.0 / 5.5 + 0.020 + 0.014},
    {"multi_axis_y_slowest", {{'X', 0.5}, {'Y', 27.0}}, 27.0 / 5.5 + 0.020 + 0.014},
    {"zero_axis_ignored", {{'X', 0.0}, {'Y', 0.2}}, 0.2 / 5.5 + 0.020 + 0.014},
    {"zero_move", {{'X', 0.0}, {'Y', 0.0}}, 0.0},
    {"no_axes", {}, 0.0},
};

class motion_model_moves : public ::testing::TestWithParam<move_row> {};

TEST_P(motion_model_moves, default_screw) {
    const auto& row = GetParam();
    EXPECT_NEAR(motion_model{}.move_seconds(row.deltas), row.expected_s, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(table, motion_model_moves, ::testing::ValuesIn(move_table),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(motion_model, defaults_are_the_simulators_default_screw) {
    const auto& p = motion_model{}.axis('X');
    EXPECT_DOUBLE_EQ(p.speed_mm_s, 5.5);
    EXPECT_DOUBLE_EQ(p.ramp_ms, 20);
    EXPECT_DOUBLE_EQ(p.settle_ms, 14);
    EXPECT_DOUBLE_EQ(p.max_speed_mm_s, 6.8);
    // The struct's own defaults say the same (an axis_motion_params{} built by a planner).
    const axis_motion_params plain{};
    EXPECT_DOUBLE_EQ(plain.speed_mm_s, p.speed_mm_s);
    EXPECT_DOUBLE_EQ(plain.ramp_ms, p.ramp_ms);
    EXPECT_DOUBLE_EQ(plain.settle_ms, p.settle_ms);
    EXPECT_DOUBLE_EQ(plain.max_speed_mm_s, p.max_speed_mm_s);
}

struct settle_row {
    const char* name;
    double pc_mm;
    double expected_settle_ms;
};

// settle = 14 ms * clamp(sqrt(0.000022 / pc), 0.1, 3.0)
const settle_row settle_table[] = {
    {"default_pc", 0.000022, 14.0},
    {"four_times_wider", 0.000088, 7.0},
    {"ten_counts", 0.00022, 14.0 * std::sqrt(0.1)},
    {"wide_clamped_at_tenth", 0.1, 1.4},
    {"four_times_tighter", 0.0000055, 28.0},
    {"tight_clamped_at_three", 0.0000001, 42.0},
};

class motion_model_settle : public ::testing::TestWithParam<settle_row> {};

TEST_P(motion_model_settle, scales_with_finish_error) {
    const auto& row = GetParam();
    const auto p = axis_params_for(default_lead_screw(), std::nullopt, std::nullopt, row.pc_mm);
    EXPECT_NEAR(p.settle_ms, row.expected_settle_ms, 1e-9);
    motion_model m;
    m.set_axis('X', p);
    EXPECT_NEAR(m.move_seconds({{'X', 9.0}}), 9.0 / 5.5 + 0.020 + row.expected_settle_ms / 1000, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(table, motion_model_settle, ::testing::ValuesIn(settle_table),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(motion_model, per_axis_parameters) {
    motion_model m;
    m.set_axis('X', axis_params_for(default_lead_screw(), 1.0, 100.0, std::nullopt));
    // X: v = 1, r = 0.1 s, v*r = 0.1 mm. 2 mm: 2 + 0.1 + 0.014. Y keeps the defaults.
    EXPECT_NEAR(m.move_seconds({{'X', 2.0}}), 2.114, 1e-9);
    EXPECT_NEAR(m.move_seconds({{'X', 2.0}, {'Y', 9.0}}), 2.114, 1e-9);
    EXPECT_NEAR(m.move_seconds({{'X', 0.1}, {'Y', 9.0}}), 9.0 / 5.5 + 0.034, 1e-9);
    // A speed above the screw's top speed is what the firmware clamps it to.
    EXPECT_DOUBLE_EQ(axis_params_for(default_lead_screw(), 50.0).speed_mm_s, 6.8);
}

TEST(motion_model, travel_and_axis_move_seconds) {
    const motion_model m;
    // A scan line of 1 mm at 0.528 mm/s: v*r = 0.01 mm, long move, no settle.
    EXPECT_NEAR(m.travel_seconds('X', 1.0, 0.528), 1.0 / 0.528 + 0.020, 1e-9);
    EXPECT_NEAR(m.travel_seconds('X', -1.0, 0.528), 1.0 / 0.528 + 0.020, 1e-9);
    EXPECT_EQ(m.travel_seconds('X', 0.0, 0.528), 0.0);
    EXPECT_EQ(m.travel_seconds('X', 1.0, 0.0), 0.0);
    // With settle, at a given speed (the SCAN start move runs at the screw's top speed).
    EXPECT_NEAR(m.axis_move_seconds('X', 6.8, 6.8), 1.0 + 0.020 + 0.014, 1e-9);
    EXPECT_NEAR(m.axis_move_seconds('X', 9.0), 9.0 / 5.5 + 0.034, 1e-9);
    EXPECT_EQ(m.axis_move_seconds('X', 0.0), 0.0);
}

TEST(motion_model, lead_screw_by_counts_per_mm) {
    struct row {
        double counts;
        char id;
    };
    for (const auto& r : {row{181590.4, 'A'}, row{45397.6, 'B'}, row{45396, 'B'}, row{45398, 'B'},
                          row{22698.8, 'C'}, row{11349.4, 'D'}}) {
        const auto s = lead_screw_for_counts(r.counts);
        ASSERT_TRUE(s) << r.counts;
        EXPECT_EQ(s->id, r.id) << r.counts;
    }
    EXPECT_FALSE(lead_screw_for_counts(10000));
    EXPECT_FALSE(lead_screw_for_counts(0));
    EXPECT_FALSE(lead_screw_for_counts(-45397.6));
    // The A screw settles longer and is slower.
    const auto a = axis_params_for(*lead_screw_for_counts(181590.4));
    EXPECT_DOUBLE_EQ(a.settle_ms, 68);
    EXPECT_DOUBLE_EQ(a.speed_mm_s, 1.361);
    EXPECT_DOUBLE_EQ(a.max_speed_mm_s, 1.7);
}

// The estimate against the pure simulator model: the same moves, settings and screws, in simulated
// time. Both use devices/ms2000/motion_profile, so they agree to the rounding of a microsecond (and
// the quantisation of targets to encoder counts).
struct agreement_row {
    const char* name;
    char screw;
    std::vector<std::string> settings;  // sent before the move
    std::string move;                   // "M X=.. Y=.." in tenths of a micron
    std::vector<axis_delta_mm> deltas;
    std::optional<double> speed, ramp, pc;   // what the settings set on X and Y
    double backlash = 0, overshoot = 0;      // likewise
    std::optional<double> lower{}, upper{};  // SL / SU on X and Y
};

const agreement_row agreement_table[] = {
    {"nine_mm_b", 'B', {}, "M X=90000", {{'X', 9.0}}, {}, {}, {}},
    {"fifth_mm_b", 'B', {}, "M X=2000", {{'X', 0.2}}, {}, {}, {}},
    {"triangle_b", 'B', {}, "M Y=-300", {{'Y', -0.03}}, {}, {}, {}},
    {"diagonal_b", 'B', {}, "M X=90000 Y=-270000", {{'X', 9.0}, {'Y', -27.0}}, {}, {}, {}},
    {"slow_long_ramp",
     'B',
     {"S X=1.25 Y=1.25", "AC X=150 Y=150"},
     "M X=50000 Y=1000",
     {{'X', 5.0}, {'Y', 0.1}},
     1.25,
     150.0,
     {}},
    {"wide_finish_error", 'B', {"PC X=0.0002 Y=0.0002"}, "M X=90000", {{'X', 9.0}}, {}, {}, 0.0002},
    {"tight_finish_error", 'B', {"PC X=0.000005 Y=0.000005"}, "M X=2000", {{'X', 0.2}}, {}, {}, 0.000005},
    {"screw_a", 'A', {}, "M X=90000", {{'X', 9.0}}, {}, {}, {}},
    {"screw_d", 'D', {}, "M X=2000 Y=90000", {{'X', 0.2}, {'Y', 9.0}}, {}, {}, {}},
    // A move down with backlash runs past the target and back; a move up does not.
    {"backlash_down", 'B', {"B X=0.5 Y=0.5"}, "M X=-90000", {{'X', -9.0}}, {}, {}, {}, 0.5, 0},
    {"backlash_up", 'B', {"B X=0.5 Y=0.5"}, "M X=90000", {{'X', 9.0}}, {}, {}, {}, 0.5, 0},
    // Overshoot: every move, and the larger leg wins when both apply.
    {"overshoot_up", 'B', {"OS X=0.05 Y=0.05"}, "M X=2000", {{'X', 0.2}}, {}, {}, {}, 0, 0.05},
    {"backlash_and_overshoot",
     'B',
     {"B X=0.02 Y=0.02", "O X=0.3 Y=0.3"},
     "M X=-90000 Y=-1000",
     {{'X', -9.0}, {'Y', -0.1}},
     {},
     {},
     {},
     0.02,
     0.3},
    // Near the end of travel the leg is cut to the room left: 0.2 mm above SL, then none at SU.
    {"backlash_near_the_lower_limit",
     'B',
     {"B X=0.5 Y=0.5", "SL X=-9.2 Y=-9.2"},
     "M X=-90000",
     {{'X', -9.0, -9.0}},
     {},
     {},
     {},
     0.5,
     0,
     -9.2},
    {"overshoot_onto_the_upper_limit",
     'B',
     {"OS X=0.3 Y=0.3", "SU X=9 Y=9"},
     "M X=90000 Y=20000",
     {{'X', 9.0, 9.0}, {'Y', 2.0, 2.0}},
     {},
     {},
     {},
     0,
     0.3,
     {},
     9.0},
};

class motion_model_agreement : public ::testing::TestWithParam<agreement_row> {};

TEST_P(motion_model_agreement, with_the_simulator_model) {
    using devices::sim::sim_time;
    const auto& row = GetParam();
    auto config = devices::sim::preset("plain").value();
    config.lead_screw = row.screw;
    devices::sim::ms2000_model sim(config);
    for (const auto& s : row.settings)
        ASSERT_EQ(sim.feed(s + "\r", sim_time{0}).substr(0, 2), ":A") << s;
    ASSERT_EQ(sim.feed(row.move + "\r", sim_time{0}), ":A\r\n");
    const double simulated_s = std::chrono::duration<double>(sim.idle_at()).count();

    const auto counts = devices::sim::lead_screw_for(row.screw).value().counts_per_mm;
    const auto screw = lead_screw_for_counts(counts);
    ASSERT_TRUE(screw);
    motion_model m;
    for (const char a : {'X', 'Y'}) {
        auto p = axis_params_for(*screw, row.speed, row.ramp, row.pc);
        p.backlash_mm = row.backlash;
        p.overshoot_mm = row.overshoot;
        p.lower_limit_mm = row.lower;
        p.upper_limit_mm = row.upper;
        m.set_axis(a, p);
    }
    EXPECT_NEAR(m.move_seconds(row.deltas), simulated_s, 5e-6) << row.move;
}

INSTANTIATE_TEST_SUITE_P(table, motion_model_agreement, ::testing::ValuesIn(agreement_table),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace gw::jobs
