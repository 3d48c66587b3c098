// The simulated CRISP focus lock and AUTOFOCUS (the "crisp" preset: focus plane at Z = 150 um).
#include <string>

#include <gtest/gtest.h>

#include "tests/unit/sim/model_test_util.hpp"

namespace gw::devices::sim {
namespace {

using namespace test;
using std::chrono::milliseconds;

// "LK Y?" -> ":A -1234 ": the focus error as a number.
long focus_error(ms2000_model& m, sim_time at) {
    return std::stol(send(m, "LK Y?", at).substr(3));
}

// "W Z" in tenths of a micrometre.
double z_tenths(ms2000_model& m, sim_time at) {
    return std::stod(send(m, "W Z", at).substr(3));
}

// Targets are whole encoder counts (22 nm on this lead screw).
constexpr double count_nm = 22;

TEST(model_crisp, locks_near_focus_and_servos_z_to_the_set_point) {
    ms2000_model m(config_for("crisp"));
    EXPECT_EQ(send(m, "LK Y?", sim_time{0}), ":A 0 \r\n") << "LED off: no signal";
    send(m, "M Z=1400", sim_time{0});  // 140 um: 10 um from focus
    const auto near = milliseconds(2000);
    EXPECT_EQ(send(m, "LK", near), ":A\r\n");
    EXPECT_EQ(send(m, "LK X?", near), ":A R\r\n");
    EXPECT_NEAR(focus_error(m, near), -10000, count_nm) << "10 um below focus, in nm";
    EXPECT_EQ(send(m, "LK T?", near), ":A 2400 \r\n");
    EXPECT_EQ(send(m, "LK F=83", near), ":A\r\n");  // 'S': lock
    EXPECT_EQ(send(m, "LK X?", near + milliseconds(100)), ":A K\r\n");
    EXPECT_EQ(send(m, "LK X?", near + milliseconds(600)), ":A F\r\n");
    EXPECT_NEAR(focus_error(m, near + milliseconds(2000)), 0, count_nm) << "locked: Z at the focus plane";
    EXPECT_NEAR(z_tenths(m, near + milliseconds(2000)), 1500, count_nm / 100);
    EXPECT_EQ(send(m, "LK F=85", near + milliseconds(2100)), ":A\r\n");  // 'U': unlock
    EXPECT_EQ(send(m, "LK X?", near + milliseconds(2100)), ":A R\r\n");
    EXPECT_EQ(send(m, "LK F=79", near + milliseconds(2200)), ":A\r\n");  // 'O': LED off
    EXPECT_EQ(send(m, "LK X?", near + milliseconds(2200)), ":A I\r\n");
}

TEST(model_crisp, too_far_from_focus_ends_in_the_error_state) {
    ms2000_model m(config_for("crisp"));
    send(m, "LK F=85", sim_time{0});  // ready, Z at 0: 150 um from focus
    EXPECT_EQ(send(m, "LK T?", sim_time{0}), ":A 300 \r\n") << "a weak reflection";
    EXPECT_EQ(send(m, "EX Y?", sim_time{0}), ":A 2 \r\n");
    send(m, "LK F=83", sim_time{0});
    EXPECT_EQ(send(m, "LK X?", milliseconds(600)), ":A E\r\n");
    EXPECT_EQ(send(m, "W Z", milliseconds(600)), ":A 0.0 \r\n") << "Z was not moved";
}

TEST(model_crisp, the_lock_offset_moves_the_set_point) {
    ms2000_model m(config_for("crisp"));
    EXPECT_EQ(send(m, "LK Z?", sim_time{0}), ":A Z=0 \r\n");
    EXPECT_EQ(send(m, "LK Z=2000", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "LK Z?", sim_time{0}), ":A Z=2000 \r\n");
    EXPECT_EQ(send(m, "LK Z=40000", sim_time{0}), ":N-4\r\n");
    send(m, "M Z=1480", sim_time{0});
    send(m, "LK F=83", milliseconds(2000));
    EXPECT_EQ(send(m, "LK X?", milliseconds(2600)), ":A F\r\n");
    EXPECT_NEAR(z_tenths(m, milliseconds(4000)), 1520, count_nm / 100) << "2000 nm above the focus plane";
    EXPECT_NEAR(focus_error(m, milliseconds(4000)), 0, count_nm);
    EXPECT_EQ(send(m, "EX Y?", milliseconds(4000)), ":A 20 \r\n");
    EXPECT_EQ(send(m, "EXTRA X?", milliseconds(4000)), "F    2400    0 \r\n");
}

TEST(model_autofocus, a_focus_scan_moves_z_to_the_focus_plane_and_halt_ends_it) {
    ms2000_model m(config_for("crisp"));
    EXPECT_EQ(send(m, "AF X?", sim_time{0}), ":A 0 \r\n");
    EXPECT_EQ(send(m, "AF", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "AF X?", milliseconds(1)), ":A 1 \r\n");
    EXPECT_EQ(send(m, "/", milliseconds(1)), "B\r\n");
    EXPECT_GT(run_to_completion(m), milliseconds(10)) << "a scan takes the time of a Z move";
    EXPECT_EQ(send(m, "AF X?", milliseconds(60000)), ":A 0 \r\n");
    EXPECT_NEAR(z_tenths(m, milliseconds(60000)), 1500, count_nm / 100);

    send(m, "M Z=0", milliseconds(60000));
    send(m, "AF", milliseconds(120000));
    send(m, "\\", milliseconds(120010));
    EXPECT_EQ(send(m, "AF X?", milliseconds(120011)), ":A 0 \r\n");
    EXPECT_EQ(send(m, "/", milliseconds(120011)), "N\r\n");
}

TEST(model_crisp, every_command_needs_the_module) {
    ms2000_model m(config_for("plain"));
    EXPECT_EQ(send(m, "LK X?", sim_time{0}), ":N-1\r\n");
    EXPECT_EQ(send(m, "AF", sim_time{0}), ":N-1\r\n");
}

}  // namespace
}  // namespace gw::devices::sim
