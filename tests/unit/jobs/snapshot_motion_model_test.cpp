// motion_model_of: the planner's motion model from a controller snapshot, with the defaults where the
// controller did not answer (pure: the integration test snapshot_motion_model_test checks it against
// the simulator's moves).
#include "gateway/jobs/snapshot_motion_model.hpp"

#include <gtest/gtest.h>

namespace gw::jobs {
namespace {

TEST(motion_model_of, takes_the_snapshots_settings_and_defaults_for_the_rest) {
    devices::controller_snapshot s;
    s.id = "unit";
    const double b_screw = default_lead_screw().counts_per_mm;
    devices::axis_state x;
    x.axis = 'X';
    x.counts_per_mm = b_screw;
    x.speed_mm_s = 2.5;
    x.ramp_ms = 75;
    x.finish_error_mm = 0.000088;
    x.backlash_mm = 0.4;
    x.overshoot_mm = 0.1;
    x.lower_limit_mm = -30;
    x.upper_limit_mm = 30;
    devices::axis_state y;  // nothing answered
    y.axis = 'Y';
    devices::axis_state z;
    z.axis = 'Z';
    z.counts_per_mm = b_screw;
    z.speed_mm_s = 0;               // unusable: the default
    z.finish_error_mm = 0.0000223;  // prints as the default 0.000022
    z.finish_error_printed_step_mm = 5e-7;
    s.axes = {x, y, z};

    const auto m = motion_model_of(s, 9600);
    EXPECT_DOUBLE_EQ(m.axis('X').speed_mm_s, 2.5);
    EXPECT_DOUBLE_EQ(m.axis('X').ramp_ms, 75);
    EXPECT_NEAR(m.axis('X').settle_ms, 7, 1e-6);  // 14 ms * sqrt(0.000022 / 0.000088)
    EXPECT_DOUBLE_EQ(m.axis('X').backlash_mm, 0.4);
    EXPECT_DOUBLE_EQ(m.axis('X').overshoot_mm, 0.1);
    EXPECT_EQ(m.axis('X').lower_limit_mm, -30);
    EXPECT_EQ(m.axis('X').upper_limit_mm, 30);
    EXPECT_DOUBLE_EQ(m.axis('Y').speed_mm_s, 5.5);
    EXPECT_DOUBLE_EQ(m.axis('Y').ramp_ms, 20);
    EXPECT_NEAR(m.axis('Y').settle_ms, 14, 1e-6);
    EXPECT_DOUBLE_EQ(m.axis('Y').backlash_mm, 0);
    EXPECT_FALSE(m.axis('Y').lower_limit_mm);
    EXPECT_DOUBLE_EQ(m.axis('Z').speed_mm_s, 5.5);
    EXPECT_NEAR(m.axis('Z').settle_ms, 14, 1e-6);
    EXPECT_EQ(m.link().baud, 9600u);
}

}  // namespace
}  // namespace gw::jobs
