// Move times of the simulated stage against the seed's "Stage Scanning Speed and Accuracy" table,
// computed from simulated time only (no clock): each must be within +-10 % of the table.
#include <chrono>
#include <cmath>

#include <gtest/gtest.h>

#include "tests/unit/sim/model_test_util.hpp"

namespace gw::devices::sim {
namespace {

using namespace test;

struct table_row {
    char screw;
    double plate_s;    // 96 well-plate traverse
    double nine_mm_s;  // 9 mm move
    double small_ms;   // 0.2 mm move
};

constexpr table_row table[] = {
    {'A', 644, 6.7, 235},
    {'B', 160, 1.67, 70},
    {'C', 79, 0.82, 49},
    {'D', 47, 0.48, 40},
};

double seconds(sim_time t) {
    return std::chrono::duration<double>(t).count();
}

// A single-axis move from 0 by `tenths` (tenths of a micron) until STATUS answers "N".
double move_time_s(char screw, const std::string& tenths) {
    ms2000_model m(config_for("plain", screw));
    EXPECT_EQ(send(m, "M X=" + tenths, sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "/", sim_time{1}), "B\r\n");
    const auto done = run_to_completion(m);
    EXPECT_EQ(send(m, "/", done), "N\r\n");
    EXPECT_EQ(send(m, "/", done - sim_time{1}), "B\r\n");
    return seconds(done);
}

class calibration : public ::testing::TestWithParam<table_row> {};

TEST_P(calibration, nine_millimetre_move) {
    const auto& row = GetParam();
    EXPECT_NEAR(move_time_s(row.screw, "90000"), row.nine_mm_s, row.nine_mm_s * 0.10) << row.screw;
}

TEST_P(calibration, fifth_of_a_millimetre_move) {
    const auto& row = GetParam();
    EXPECT_NEAR(move_time_s(row.screw, "2000") * 1000, row.small_ms, row.small_ms * 0.10) << row.screw;
}

TEST_P(calibration, well_plate_traverse) {
    // ARRAY defaults: 12 x 8 wells, 9 mm pitch; the self-scan goes serpentine: 95 moves of 9 mm.
    const auto& row = GetParam();
    ms2000_model m(config_for("full", row.screw));
    ASSERT_EQ(send(m, "ARRAY X=12 Y=8 Z=9.0 F=-9.0", sim_time{0}), ":A\r\n");
    ASSERT_EQ(send(m, "ARRAY", sim_time{0}), ":A\r\n");
    const auto done = run_to_completion(m);
    EXPECT_EQ(m.array_state(), 'C');
    EXPECT_NEAR(seconds(done), row.plate_s, row.plate_s * 0.10) << row.screw;
    // The last well of a serpentine 12 x 8 plate is column 1 of row 8.
    EXPECT_NEAR(m.position_units('X', done), 0, 1);
    EXPECT_NEAR(m.position_units('Y', done), -7 * 9 * 10000, 1);
}

INSTANTIATE_TEST_SUITE_P(lead_screws, calibration, ::testing::ValuesIn(table),
                         [](const auto& info) { return std::string(1, info.param.screw); });

TEST(motion, where_interpolates_and_is_monotonic) {
    ms2000_model m(config_for("plain"));
    send(m, "M X=90000", sim_time{0});
    double last = -1;
    for (int ms_step = 0; ms_step <= 2000; ms_step += 50) {
        const double pos = m.position_units('X', std::chrono::milliseconds(ms_step));
        EXPECT_GE(pos, last);
        last = pos;
    }
    const double mid = m.position_units('X', std::chrono::milliseconds(800));
    EXPECT_GT(mid, 30000);
    EXPECT_LT(mid, 60000);
    EXPECT_NEAR(last, 90000, 0.5);
}

}  // namespace
}  // namespace gw::devices::sim
