// Unsolicited serial position reports (RT M+, TTL X=5), the Z-stack (ZS, TTL X=4) and RESET.
#include <gtest/gtest.h>

#include "devices/ms2000/reply.hpp"
#include "tests/unit/sim/model_test_util.hpp"

namespace gw::devices::sim {
namespace {

using namespace test;
using std::chrono::milliseconds;

TEST(model_position_reports, rt_m_plus_reports_every_interval_until_rt_m_minus) {
    ms2000_model m(config_for("plain"));
    send(m, "H X=1234.5 Y=-10", sim_time{0});
    EXPECT_EQ(send(m, "RT X=100", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "RT M+", sim_time{0}), ":A\r\n");
    const auto out = m.take_output(milliseconds(250));
    ASSERT_EQ(out.size(), 3u);  // at 0, 100 and 200 ms
    EXPECT_EQ(out[0].bytes, "T:     0 1234.5  -10.0\r\n");
    EXPECT_EQ(out[2].bytes, "T:   200 1234.5  -10.0\r\n");
    EXPECT_EQ(out[1].at, milliseconds(100));
    // The driver's parser reads them.
    const auto parsed = ms2000::parse_position_report(out[1].bytes.substr(0, out[1].bytes.size() - 2));
    ASSERT_TRUE(parsed);
    EXPECT_DOUBLE_EQ(parsed->milliseconds, 100);
    ASSERT_EQ(parsed->positions.size(), 2u);
    EXPECT_DOUBLE_EQ(parsed->positions[0], 1234.5);
    EXPECT_EQ(send(m, "RT M-", milliseconds(250)), ":A\r\n");
    EXPECT_TRUE(m.take_output(milliseconds(1000)).empty());
    EXPECT_FALSE(m.next_event());
}

TEST(model_position_reports, ttl_mode_5_toggles_reports) {
    ms2000_model m(config_for("planar"));
    send(m, "TTL X=5", sim_time{0});
    m.ttl_pulse(milliseconds(10));
    EXPECT_EQ(m.take_output(milliseconds(10)).size(), 1u);
    m.ttl_pulse(milliseconds(20));
    EXPECT_TRUE(m.take_output(milliseconds(5000)).empty());
}

TEST(model_zstack, sawtooth_steps_and_returns) {
    ms2000_model m(config_for("planar"));
    EXPECT_EQ(send(m, "ZS X=10 Y=3 Z=0", sim_time{0}), ":A\r\n");
    send(m, "TTL X=4", sim_time{0});
    sim_time t{0};
    std::vector<double> z;
    for (int i = 0; i < 5; ++i) {
        m.ttl_pulse(t);
        t = std::max(run_to_completion(m), t) + milliseconds(1);
        z.push_back(m.position_units('Z', t));
    }
    // First pulse: start at 0; then 10, 20, back to 0, 10 (targets quantised to encoder counts).
    const std::vector<double> expected{0, 10, 20, 0, 10};
    for (std::size_t i = 0; i < z.size(); ++i)
        EXPECT_NEAR(z[i], expected[i], 0.2) << i;
    EXPECT_EQ(send(m, "ZS T?", t), ":A T=1 \r\n");
}

TEST(model_reset, returns_to_power_up_state) {
    ms2000_model m(config_for("plain"));
    send(m, "H X=500", sim_time{0});
    send(m, "S X=1", sim_time{0});
    EXPECT_EQ(send(m, "~", sim_time{0}), ":A\r\n");
    EXPECT_EQ(send(m, "W X", sim_time{0}), ":A 0.0 \r\n");
    EXPECT_EQ(send(m, "S X?", sim_time{0}), ":A X=5.500000 \r\n");
}

}  // namespace
}  // namespace gw::devices::sim
