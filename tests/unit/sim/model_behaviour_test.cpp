// Motion and module behaviour of the pure model, stepped in simulated time.
#include <gtest/gtest.h>

#include "devices/ms2000/report_frame.hpp"
#include "tests/unit/sim/model_test_util.hpp"

namespace gw::devices::sim {
namespace {

using namespace test;
using std::chrono::milliseconds;

TEST(model_motion, halt_during_a_move_answers_n21_and_stops) {
    ms2000_model m(config_for("plain"));
    send(m, "M X=100000", sim_time{0});
    EXPECT_EQ(send(m, "\\", milliseconds(500)), ":N-21\r\n");
    EXPECT_EQ(send(m, "/", milliseconds(501)), "N\r\n");
    const double stopped = m.position_units('X', milliseconds(501));
    EXPECT_GT(stopped, 1000);
    EXPECT_LT(stopped, 100000);
    EXPECT_DOUBLE_EQ(m.position_units('X', milliseconds(5000)), stopped);
    EXPECT_EQ(send(m, "HALT", milliseconds(600)), ":A\r\n");
}

TEST(model_faults, refuse_next_answers_the_code_once_and_does_not_run_the_command) {
    ms2000_model m(config_for("plain"));
    m.refuse_next("M", -4);  // the abbreviation names the verb: MOVE
    EXPECT_EQ(send(m, "W X", sim_time{0}), ":A 0.0 \r\n") << "another verb is not refused";
    EXPECT_EQ(send(m, "MOVE X=1000", sim_time{0}), ":N-4\r\n");
    EXPECT_DOUBLE_EQ(m.position_units('X', milliseconds(2000)), 0) << "the refused move ran";
    EXPECT_EQ(send(m, "M X=1000", milliseconds(2000)), ":A\r\n") << "only the next one is refused";
    const auto done = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', done), 1000, 0.5);
}

TEST(model_motion, movrel_is_relative_to_the_target) {
    ms2000_model m(config_for("plain"));
    send(m, "M X=100000", sim_time{0});
    send(m, "R X=-50000", milliseconds(100));  // the stage is still near 0; the target is 10 mm
    const auto done = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', done), 50000, 0.5);
}

TEST(model_motion, soft_limits_clamp_and_log_errors) {
    ms2000_model m(config_for("plain"));
    EXPECT_EQ(send(m, "SU X=1", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "M X=20000", sim_time{0}), ":A\r\n");
    const auto done = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', done), 10000, 0.5);
    EXPECT_EQ(send(m, "RS X-", done), ":A U\r\n");
    EXPECT_EQ(send(m, "DU Y", done), ":A 34 \r\n");
    EXPECT_EQ(send(m, "DU X", done), ":A\r\n");
    EXPECT_EQ(send(m, "DU Y", done), ":A \r\n");
}

TEST(model_motion, vector_moves_at_constant_velocity_until_halt_which_answers_a) {
    ms2000_model m(config_for("plain"));
    EXPECT_EQ(send(m, "VE X=2", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "VE X?", sim_time{0}), ":A X=2 \r\n");
    EXPECT_EQ(send(m, "/", milliseconds(1000)), "B\r\n");
    EXPECT_EQ(send(m, "RS X+", milliseconds(1000)), ":A S\r\n");
    EXPECT_NEAR(m.position_units('X', milliseconds(1000)), 20000, 1);  // 2 mm/s for 1 s
    EXPECT_NEAR(m.position_units('X', milliseconds(3000)), 60000, 1);
    // HALT stops SPIN/VECTOR without :N-21 (doc §3.2)
    EXPECT_EQ(send(m, "\\", milliseconds(3000)), ":A\r\n");
    EXPECT_EQ(send(m, "/", milliseconds(3001)), "N\r\n");
    EXPECT_NEAR(m.position_units('X', milliseconds(9000)), 60000, 1);
    EXPECT_EQ(send(m, "DU Y", milliseconds(9000)), ":A \r\n");
    // VE X=0 stops too; a negative velocity runs the other way
    send(m, "VE X=-1", milliseconds(9000));
    send(m, "VE X=0", milliseconds(10000));
    EXPECT_NEAR(m.position_units('X', milliseconds(20000)), 50000, 1);
}

TEST(model_motion, spinning_to_each_soft_limit_finds_the_travel) {
    // How programs home a stage: spin one way until it stops, then the other way.
    ms2000_model m(config_for("plain"));
    EXPECT_EQ(send(m, "@ X=127", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "/", milliseconds(100)), "B\r\n");
    const auto up = run_to_completion(m) + milliseconds(1);
    EXPECT_EQ(send(m, "/", up), "N\r\n");
    const double upper = m.position_units('X', up);
    EXPECT_NEAR(upper, 110 * 10000, 0.5);
    EXPECT_EQ(send(m, "RS X-", up), ":A U\r\n");
    EXPECT_EQ(send(m, "DU Y", up), ":A 34 \r\n");  // logged when it got there
    EXPECT_EQ(send(m, "@ X=-64", up), ":A\r\n");   // half speed down
    // A WHERE while it runs moves at half the maximum speed
    const auto screw = lead_screw_for('B').value();
    EXPECT_NEAR(m.position_units('X', up + milliseconds(1000)), upper - screw.max_speed_mm_s / 2 * 10000, 1);
    const auto down = run_to_completion(m) + milliseconds(1);
    EXPECT_NEAR(upper - m.position_units('X', down), 220 * 10000, 0.5);
    EXPECT_EQ(send(m, "RS X-", down), ":A L\r\n");
    EXPECT_EQ(send(m, "DU Y", down), ":A 34 35 \r\n");
    // At the limit already: nothing moves, and it is logged again
    EXPECT_EQ(send(m, "@ X=-10", down), ":A\r\n");
    EXPECT_EQ(send(m, "/", down), "N\r\n");
    EXPECT_EQ(send(m, "DU Y", down), ":A 34 35 35 \r\n");
    // "@ X" without a value stops a spin
    send(m, "@ X=10", down);
    send(m, "@ X", down + milliseconds(100));
    EXPECT_EQ(send(m, "/", down + milliseconds(101)), "N\r\n");
}

TEST(model_motion, limit_switches_end_the_travel_when_the_soft_limits_are_wider) {
    ms2000_model m(config_for("plain"));  // switches at +-125 mm
    EXPECT_EQ(send(m, "SU X=1000", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "M X=2000000", sim_time{0}), ":A\r\n");  // 200 mm
    auto done = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', done), 125 * 10000, 0.5);
    EXPECT_EQ(send(m, "RS X-", done), ":A U\r\n");
    EXPECT_EQ(send(m, "RS X", done), ":A 74 \r\n");  // enabled, joystick, upper limit (bit 6)
    EXPECT_EQ(send(m, "DU Y", done), ":A 34 \r\n");
    // A spin down with a soft limit beyond the switch too
    EXPECT_EQ(send(m, "SL X=-1000", done), ":A\r\n");
    send(m, "VE X=-6", done);
    done = run_to_completion(m) + milliseconds(1);
    EXPECT_NEAR(m.position_units('X', done), -125 * 10000, 0.5);
    EXPECT_EQ(send(m, "RS X-", done), ":A L\r\n");
    EXPECT_EQ(send(m, "DU Y", done), ":A 34 35 \r\n");
}

TEST(model_motion, backlash_runs_a_move_down_past_its_target_and_back) {
    ms2000_model plain(config_for("plain"));
    ms2000_model with(config_for("plain"));
    EXPECT_EQ(send(with, "B X=0.5", sim_time{0}), ":A\r\n");
    send(plain, "M X=-90000", sim_time{0});
    send(with, "M X=-90000", sim_time{0});
    const auto plain_done = run_to_completion(plain);
    const auto with_done = run_to_completion(with);
    EXPECT_GT(with_done, plain_done + milliseconds(150));  // 2 x 0.5 mm more at 5.5 mm/s, and ramps
    double lowest = 0;
    for (auto t = sim_time{0}; t <= with_done; t += sim_time{100})
        lowest = std::min(lowest, with.position_units('X', t));
    EXPECT_NEAR(lowest, -95000, 1);  // 0.5 mm past the target
    EXPECT_NEAR(with.position_units('X', with_done), -90000, 0.5);
    // A move up approaches directly
    send(with, "M X=0", with_done);
    send(plain, "M X=0", plain_done);
    EXPECT_EQ(run_to_completion(with) - with_done, run_to_completion(plain) - plain_done);
}

TEST(model_motion, speed_is_clamped_to_the_lead_screw_maximum) {
    ms2000_model m(config_for("plain", 'C'));
    EXPECT_EQ(send(m, "S X=100000000", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "S X?", sim_time{0}), ":A X=13.500000 \r\n");
}

TEST(model_motion, here_zero_and_negative_unit_multiplier) {
    ms2000_model m(config_for("plain"));
    EXPECT_EQ(send(m, "H X=1234.5 Y", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "W X Y", sim_time{0}), ":A 1234.5 0.0 \r\n");
    EXPECT_EQ(send(m, "Z", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "W X", sim_time{0}), ":A 0.0 \r\n");
    EXPECT_EQ(send(m, "UM X=-10000", sim_time{0}), ":A\r\n");
    send(m, "M X=10000", sim_time{0});
    const auto done = run_to_completion(m);
    EXPECT_NEAR(m.position_mm('X', done), -1.0, 1e-4);  // negative UM flips the axis
    EXPECT_EQ(send(m, "W X", done), ":A 10000.1 \r\n");
}

TEST(model_motion, home_runs_past_the_soft_limit_to_the_upper_switch_and_is_busy) {
    ms2000_model m(config_for("plain", 'D'));  // switches at +-125 mm
    EXPECT_EQ(send(m, "SU X=5", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "HM X?", sim_time{0}), ":A X=1000.000 \r\n");  // the default: far beyond travel
    EXPECT_EQ(send(m, "! X", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "/", milliseconds(10)), "B\r\n");
    EXPECT_EQ(send(m, "RS X+", milliseconds(10)), ":A B\r\n");  // a commanded move
    const auto done = run_to_completion(m);
    EXPECT_NEAR(m.position_mm('X', done), 125, 1e-4) << "HOME ends at the switch, not at SU";
    EXPECT_EQ(send(m, "RS X-", done), ":A U\r\n");
    EXPECT_EQ(send(m, "RS X", done), ":A 74 \r\n");  // bit 6: the upper switch is closed
    EXPECT_EQ(send(m, "DU Y", done), ":A \r\n") << "reaching the switch is HOME's purpose, not an error";
    // Y was not named: it stayed.
    EXPECT_NEAR(m.position_mm('Y', done), 0, 1e-9);
}

TEST(model_motion, home_stops_at_a_home_position_set_within_travel_or_at_the_lower_switch) {
    ms2000_model m(config_for("plain", 'D'));
    send(m, "M X=30000", sim_time{0});
    auto t = run_to_completion(m);
    EXPECT_EQ(send(m, "HM X+", t), ":A\r\n");  // here (3 mm) becomes home
    EXPECT_EQ(send(m, "HM X?", t), ":A X=3.000 \r\n");
    send(m, "M X=-20000", t);
    t = run_to_completion(m);
    send(m, "!", t);  // every axis; Y's home is the default, beyond the upper switch
    t = run_to_completion(m);
    EXPECT_NEAR(m.position_mm('X', t), 3, 1e-4);
    EXPECT_NEAR(m.position_mm('Y', t), 125, 1e-4);
    EXPECT_EQ(send(m, "HM X=-1000", t), ":A\r\n");  // home beyond the lower end
    send(m, "! X", t);
    t = run_to_completion(m);
    EXPECT_NEAR(m.position_mm('X', t), -125, 1e-4);
    EXPECT_EQ(send(m, "RS X-", t), ":A L\r\n");
    EXPECT_EQ(send(m, "HM X-", t), ":A\r\n");  // back to the default
    EXPECT_EQ(send(m, "HM X?", t), ":A X=1000.000 \r\n");
}

TEST(model_motion, halt_stops_a_home_run_like_any_commanded_move) {
    ms2000_model m(config_for("plain", 'D'));
    send(m, "! X", sim_time{0});
    EXPECT_EQ(send(m, "\\", milliseconds(500)), ":N-21\r\n");
    const double stopped = m.position_mm('X', milliseconds(501));
    EXPECT_GT(stopped, 0.1);
    EXPECT_LT(stopped, 125);
    EXPECT_EQ(send(m, "/", milliseconds(501)), "N\r\n");
}

TEST(model_motion, the_approach_leg_stops_at_the_limit_a_move_ends_on) {
    // Backlash 0.5 mm: a move down to 0.2 mm above the lower soft limit runs only those 0.2 mm past
    // its target; a move down to the limit itself runs no leg at all.
    ms2000_model m(config_for("plain"));
    EXPECT_EQ(send(m, "B X=0.5", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "SL X=-10", sim_time{0}), ":A\r\n");
    send(m, "M X=-98000", sim_time{0});
    auto t = run_to_completion(m);
    double lowest = 0;
    for (auto at = sim_time{0}; at <= t; at += sim_time{100})
        lowest = std::min(lowest, m.position_mm('X', at));
    EXPECT_NEAR(lowest, -10, 1e-3) << "the leg ran past the soft limit";
    EXPECT_NEAR(m.position_mm('X', t), -9.8, 1e-4);
    EXPECT_EQ(send(m, "DU Y", t), ":A \r\n");

    send(m, "M X=0", t);
    const auto up = run_to_completion(m);
    ms2000_model plain(config_for("plain"));  // the same move with no backlash at all
    send(plain, "SL X=-10", sim_time{0});
    send(plain, "M X=-100000", sim_time{0});
    const auto plain_done = run_to_completion(plain);
    send(m, "M X=-100000", up);
    const auto down = run_to_completion(m);
    EXPECT_EQ(down - up, plain_done) << "a move that ends on the limit has no leg";
    for (auto at = up; at <= down; at += sim_time{100})
        ASSERT_GE(m.position_mm('X', at), -10 - 1e-9);
}

TEST(model_ring_buffer, load_step_and_overflow) {
    ms2000_model m(config_for("full"));
    EXPECT_EQ(send(m, "RM X=0", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "LD X=1000 Y=2000", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "LD X=3000 Y=4000", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "RM X?", sim_time{0}), ":A X=2 \r\n");
    EXPECT_EQ(send(m, "RM Y?", sim_time{0}), ":A Y=3 \r\n");
    EXPECT_EQ(send(m, "LD X?", sim_time{0}), ":A X=1000 \r\n");
    EXPECT_EQ(send(m, "RM", sim_time{0}), ":A\r\n");  // like a pulse: first position
    auto t = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', t), 1000, 0.5);
    EXPECT_NEAR(m.position_units('Y', t), 2000, 0.5);
    send(m, "RM", t);
    t = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', t), 3000, 0.5);
    send(m, "RM", t);  // wraps to the first
    t = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', t), 1000, 0.5);
    for (int i = 2; i < 50; ++i)
        ASSERT_EQ(send(m, "LD X=" + std::to_string(i), t), ":A\r\n");
    EXPECT_EQ(send(m, "LD X=99", t), ":N-5\r\n");  // 50 slots, full
}

TEST(model_ring_buffer, ttl_mode_1_steps_on_pulses_on_a_build_without_ttl_report) {
    ms2000_model m(config_for("planar"));
    send(m, "LD X=5000", sim_time{0});
    send(m, "LD X=-5000", sim_time{0});
    send(m, "RM Y=1", sim_time{0});
    send(m, "TTL X=1", sim_time{0});
    EXPECT_FALSE(m.ttl_pulse(sim_time{0}));
    auto t = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', t), 5000, 0.5);
    m.ttl_pulse(t);
    t = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', t), -5000, 0.5);
}

TEST(model_ring_buffer, autoplay_once_waits_rt_z_between_positions) {
    ms2000_model m(config_for("full"));
    send(m, "LD X=1000", sim_time{0});
    send(m, "LD X=2000", sim_time{0});
    send(m, "LD X=3000", sim_time{0});
    send(m, "RT Z=500", sim_time{0});
    send(m, "RM F=2", sim_time{0});
    send(m, "RM", sim_time{0});
    EXPECT_EQ(send(m, "RM F?", sim_time{1}), ":A F=130 \r\n");  // MSB set while autoplaying
    const auto t = run_to_completion(m);
    EXPECT_NEAR(m.position_units('X', t), 3000, 0.5);
    EXPECT_GT(t, milliseconds(1000));  // two dwells of 500 ms
    EXPECT_EQ(send(m, "RM F?", t), ":A F=2 \r\n");
}

TEST(model_array, aij_and_ttl_stepping_with_graceful_end) {
    ms2000_model m(config_for("full"));
    // The full preset has TTL_REPORT_INT, which disables other TTL input functions; use "planar".
    ms2000_model p(config_for("planar"));
    EXPECT_EQ(send(p, "ARRAY X=3 Y=2 Z=1 F=-1", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(p, "AIJ X=3 Y=2", sim_time{0}), ":A\r\n");
    auto t = run_to_completion(p);
    EXPECT_NEAR(p.position_mm('X', t), 2, 1e-4);
    EXPECT_NEAR(p.position_mm('Y', t), -1, 1e-4);
    EXPECT_EQ(send(p, "AIJ X=4 Y=1", t), ":N-4\r\n");
    send(p, "TTL X=7", t);
    EXPECT_EQ(send(p, "RM X=0", t), ":A\r\n");  // to (1,1), stepping stops after the last well
    t = run_to_completion(p);
    EXPECT_EQ(p.array_state(), 'A');
    std::vector<std::pair<double, double>> visited{{p.position_mm('X', t), p.position_mm('Y', t)}};
    for (int i = 0; i < 7; ++i) {
        p.ttl_pulse(t);
        t = run_to_completion(p);
        visited.emplace_back(p.position_mm('X', t), p.position_mm('Y', t));
    }
    EXPECT_EQ(p.array_state(), 'C');
    // Serpentine: (0,0) (1,0) (2,0) (2,-1) (1,-1) (0,-1), then the extra pulses are ignored.
    const std::vector<std::pair<double, double>> expected{{0, 0},  {1, 0},  {2, 0},  {2, -1},
                                                          {1, -1}, {0, -1}, {0, -1}, {0, -1}};
    ASSERT_EQ(visited.size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
        EXPECT_NEAR(visited[i].first, expected[i].first, 1e-4) << i;
        EXPECT_NEAR(visited[i].second, expected[i].second, 1e-4) << i;
    }
    (void)m;
}

TEST(model_array, self_scan_goes_through_states) {
    ms2000_model m(config_for("full"));
    send(m, "ARRAY X=2 Y=1 Z=1 F=-1", sim_time{0});
    send(m, "RT Z=100", sim_time{0});
    send(m, "M X=5000", sim_time{0});
    EXPECT_EQ(send(m, "ARRAY", milliseconds(1)), ":A\r\n");
    EXPECT_EQ(m.array_state(), 'M');
    EXPECT_EQ(send(m, "/", milliseconds(2)), "B\r\n");
    run_to_completion(m);
    EXPECT_EQ(m.array_state(), 'C');
}

TEST(model_scan, raster_scan_runs_every_line) {
    ms2000_model m(config_for("full", 'D'));
    EXPECT_EQ(send(m, "SCANR X=0 Y=1 Z=24", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "SCANR F?", sim_time{0}), ":A F=472 \r\n");  // 11349.4 counts/mm x 1 mm / 24
    EXPECT_EQ(send(m, "SCANV X=0 Y=0.5 Z=3", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "SCAN F=0", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "SCAN", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "SCAN X?", sim_time{1}), ":A X=S \r\n");
    const auto t = run_to_completion(m);
    EXPECT_EQ(send(m, "SCAN X?", t), ":A X=P \r\n");
    EXPECT_NEAR(m.position_mm('X', t), 1, 1e-4);
    EXPECT_NEAR(m.position_mm('Y', t), 0.5, 1e-4);
    // 3 lines of 1 mm at 20 mm/s plus retraces: well over 3 x 50 ms.
    EXPECT_GT(t, milliseconds(150));
}

TEST(model_ttl_report, frame_timing_and_overrun) {
    ms2000_model m(config_for("full"));
    EXPECT_FALSE(m.ttl_pulse(sim_time{0}));  // TTL X=0: interrupt disabled
    send(m, "H X=10000 Y=-10000 Z=0", sim_time{0});
    send(m, "TTL X=1", sim_time{0});
    const auto frame = m.ttl_pulse(milliseconds(10));
    ASSERT_TRUE(frame);
    // td 5 us + 2 x ta 12 us + ts 200 us after the edge, inside the seed's ranges.
    const auto delay = frame->at - milliseconds(10);
    EXPECT_GE(delay.count(), 3 + 22 + 110);
    EXPECT_LE(delay.count(), 10 + 26 + 500);
    ms2000::report_decoder decoder(ms2000::report_format::binary, 3);
    std::vector<ms2000::report_frame> frames;
    decoder.feed(std::span(reinterpret_cast<const std::uint8_t*>(frame->bytes.data()), frame->bytes.size()),
                 frames);
    ASSERT_EQ(frames.size(), 1u);
    EXPECT_EQ(frames[0].axes[0].count, 45398);
    EXPECT_EQ(frames[0].axes[1].count, -45398);
    // 16 bytes at 115200 baud = 1.39 ms on the wire: a pulse 1 ms later overruns (error 87).
    EXPECT_FALSE(m.ttl_pulse(milliseconds(11)));
    EXPECT_EQ(m.error_buffer(), std::vector<int>{87});
    EXPECT_TRUE(m.ttl_pulse(milliseconds(12)));
}

TEST(model_saveset, second_phase_after_the_flash_write) {
    ms2000_model m(config_for("plain"));
    EXPECT_EQ(send(m, "SS Z", sim_time{0}), ":");
    EXPECT_TRUE(m.take_output(milliseconds(100)).empty());
    const auto out = m.take_output(milliseconds(400));
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].bytes, "A\r\n");
    EXPECT_EQ(out[0].at, milliseconds(300));
}

TEST(model_planar, three_points_define_the_correction) {
    ms2000_model m(config_for("planar"));
    // Plane z = 0.01 x: points (0,0,0), (100000,0,1000), (0,100000,0) in tenths of a micron.
    send(m, "CCB Z=1", sim_time{0});
    send(m, "H X=100000 Z=1000", sim_time{0});
    send(m, "CCB Z=2", sim_time{0});
    send(m, "H X=0 Y=100000 Z=0", sim_time{0});
    send(m, "CCB Z=3", sim_time{0});
    EXPECT_EQ(send(m, "CCB Z=8", sim_time{0}), ":A G \r\n");
    EXPECT_EQ(send(m, "CCB Z=4", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "CCB Z=8", sim_time{0}), ":A Z \r\n");
    send(m, "H X=50000 Y=0 Z=0", sim_time{0});
    EXPECT_EQ(send(m, "CCB Z=6", sim_time{0}), ":A Z=500 \r\n");
    EXPECT_EQ(send(m, "CCB Z=7", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "CCB Z=8", sim_time{0}), ":A 1 \r\n");
}

}  // namespace
}  // namespace gw::devices::sim

namespace gw::devices::sim {
namespace {

TEST(model_motion, wider_finish_error_settles_sooner) {
    ms2000_model tight(test::config_for("plain", 'A'));
    ms2000_model loose(test::config_for("plain", 'A'));
    EXPECT_EQ(test::send(loose, "PC X=0.000055", sim_time{0}), ":A\r\n");  // 10 encoder counts
    test::send(tight, "M X=2000", sim_time{0});
    test::send(loose, "M X=2000", sim_time{0});
    EXPECT_LT(test::run_to_completion(loose) + std::chrono::milliseconds(30), test::run_to_completion(tight));
}

TEST(model_ring_buffer, repeating_autoplay_wraps_until_halt) {
    ms2000_model m(test::config_for("full"));
    test::send(m, "LD X=1000", sim_time{0});
    test::send(m, "LD X=2000", sim_time{0});
    test::send(m, "RM F=3", sim_time{0});
    test::send(m, "RT Z=100", sim_time{0});  // a dwell at each position, so arrivals are visible
    test::send(m, "RM", sim_time{0});
    sim_time t{0};
    std::vector<double> seen;
    for (int guard = 0; guard < 1000 && seen.size() < 5; ++guard) {
        const auto next = m.next_event();
        ASSERT_TRUE(next);
        m.take_output(*next);
        t = *next;
        if (!m.busy(t)) seen.push_back(m.position_units('X', t));
    }
    EXPECT_EQ(test::send(m, "\\", t), ":N-21\r\n");  // autoplay counts as a running move
    EXPECT_FALSE(m.next_event());
    bool saw_first = false, saw_second = false;
    for (const double x : seen) {
        saw_first |= std::abs(x - 1000) < 1;
        saw_second |= std::abs(x - 2000) < 1;
    }
    EXPECT_TRUE(saw_first && saw_second);
}

TEST(model_ttl_report, ascii_frames_when_configured) {
    auto config = test::config_for("full");
    config.report_format = ms2000::report_format::ascii;
    ms2000_model m(config);
    test::send(m, "H X=10000", sim_time{0});
    test::send(m, "TTL X=1", sim_time{0});
    const auto frame = m.ttl_pulse(sim_time{0});
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->bytes, "X=45398 Y=0 Z=0\r\n");
}

}  // namespace
}  // namespace gw::devices::sim
