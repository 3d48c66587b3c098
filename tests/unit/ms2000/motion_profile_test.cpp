// The approach leg of a point-to-point move (BACKLASH, OVERSHOOT) and its limit at the end of travel.
#include "devices/ms2000/motion_profile.hpp"

#include <gtest/gtest.h>

namespace gw::devices::ms2000 {
namespace {

struct leg_case {
    double distance, backlash, overshoot, leg;
};

TEST(approach_leg, backlash_acts_on_moves_down_and_overshoot_on_every_move) {
    const leg_case cases[] = {
        {-5, 0.5, 0, 0.5},    // down with backlash: past the target, then up to it
        {5, 0.5, 0, 0},       // up: the target is approached moving up already
        {5, 0, 0.2, 0.2},     // overshoot: every direction
        {-5, 0, 0.2, 0.2},    //
        {-5, 0.5, 0.2, 0.5},  // the larger applies
        {-5, 0.1, 0.2, 0.2},  //
        {0, 0.5, 0.2, 0},     // no move, no leg
        {-5, -1, -1, 0},      // negative settings count as none
    };
    for (const auto& c : cases)
        EXPECT_DOUBLE_EQ(approach_leg_mm(c.distance, c.backlash, c.overshoot), c.leg)
            << c.distance << " " << c.backlash << " " << c.overshoot;
}

struct within_case {
    double distance, leg, target, lower, upper, expected;
};

TEST(approach_leg, is_cut_to_the_room_beyond_the_target) {
    const within_case cases[] = {
        {-5, 0.5, 0, -110, 110, 0.5},       // far from both ends: the whole leg
        {-5, 0.5, -109.8, -110, 110, 0.2},  // down, 0.2 mm above the lower end
        {-5, 0.5, -110, -110, 110, 0},      // down onto the lower end: none
        {5, 0.3, 109.9, -110, 110, 0.1},    // up (overshoot), 0.1 mm below the upper end
        {5, 0.3, 110, -110, 110, 0},        //
        {5, 0.3, -109.9, -110, 110, 0.3},   // up, near the lower end: room enough above
        {-5, 0.5, -111, -110, 110, 0},      // a target beyond the end (HOME past a soft limit): none
        {0, 0.5, 0, -110, 110, 0},          // no move
        {-5, 0, 0, -110, 110, 0},           // no leg
    };
    for (const auto& c : cases)
        EXPECT_NEAR(approach_leg_within_mm(c.distance, c.leg, c.target, c.lower, c.upper), c.expected, 1e-12)
            << c.distance << " to " << c.target;
}

TEST(approach_leg, move_time_grows_by_the_leg_out_and_back) {
    const double plain = move_with_approach_s(10, 0, 5, 20);
    EXPECT_DOUBLE_EQ(plain, move_time_s(10, 5, 20));
    const double with = move_with_approach_s(10, 0.5, 5, 20);
    EXPECT_DOUBLE_EQ(with, move_time_s(10.5, 5, 20) + move_time_s(0.5, 5, 20));
}

}  // namespace
}  // namespace gw::devices::ms2000
