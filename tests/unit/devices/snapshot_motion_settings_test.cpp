// The motion settings in a controller's snapshot (S, AC, PC, B, OS): which commands set one, and how
// their query answers land in the axes (snapshot_update).
#include <gtest/gtest.h>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/reply.hpp"
#include "devices/serial/snapshot_update.hpp"

namespace gw::devices {
namespace {

controller_snapshot xy() {
    controller_snapshot s;
    for (const char letter : {'X', 'Y'}) {
        axis_state a;
        a.axis = letter;
        s.axes.push_back(a);
    }
    return s;
}

ms2000::reply answer(const char* line) {
    auto r = ms2000::parse_reply(ms2000::reply_shape::standard, line);
    EXPECT_TRUE(r) << line;
    return r ? *r : ms2000::reply{};
}

TEST(motion_settings, answers_land_in_their_fields) {
    auto s = xy();
    apply_motion_setting(s, "S", answer(":A X=2.500000 Y=5.745760"));
    apply_motion_setting(s, "AC", answer(":X=75 Y=20 A"));
    apply_motion_setting(s, "B", answer(":X=0.04 A"));  // Y not answered: unset
    apply_motion_setting(s, "OS", answer(":A X=0 Y=0.1"));
    apply_motion_setting(s, "PC", answer(":A X=0.000005 Y=0.0002"));
    EXPECT_EQ(s.axes[0].speed_mm_s, 2.5);
    EXPECT_EQ(s.axes[1].speed_mm_s, 5.74576);
    EXPECT_EQ(s.axes[0].ramp_ms, 75.0);
    EXPECT_EQ(s.axes[0].backlash_mm, 0.04);
    EXPECT_FALSE(s.axes[1].backlash_mm);
    EXPECT_EQ(s.axes[1].overshoot_mm, 0.1);
    EXPECT_EQ(s.axes[0].finish_error_mm, 0.000005);
    EXPECT_DOUBLE_EQ(s.axes[0].finish_error_printed_step_mm, 0.0000005);  // six decimals printed
    EXPECT_DOUBLE_EQ(s.axes[1].finish_error_printed_step_mm, 0.00005);    // four
    // A refused query (":N-1") leaves nothing behind from before.
    apply_motion_setting(s, "S", answer(":N-1"));
    EXPECT_FALSE(s.axes[0].speed_mm_s);
}

TEST(motion_settings, the_commands_that_set_one) {
    struct row {
        const char* line;
        const char* sets;
    };
    const row rows[] = {
        {"S X=2", "S"},      {"speed x=1 y=2", "S"},  {"S X?", ""},
        {"AC X=50", "AC"},   {"ACCEL Y=5", "AC"},     {"PC X=0.0001", "PC"},
        {"PCROS X=1", "PC"}, {"B X=0", "B"},          {"BACKLASH Y=1", "B"},
        {"OS X=0.1", "OS"},  {"OVERSHOOT X=0", "OS"}, {"O X=0", "OS"},
        {"M X=1", ""},       {"SL X=-5", ""},         {"W X", ""},
    };
    for (const auto& r : rows) {
        const auto cmd = ms2000::verbatim_command(r.line);
        ASSERT_TRUE(cmd) << r.line;
        EXPECT_EQ(motion_setting_set_by(*cmd), r.sets) << r.line;
    }
}

}  // namespace
}  // namespace gw::devices
