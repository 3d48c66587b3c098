#include "gateway/gcode/gcode_options.hpp"

#include <gtest/gtest.h>

#include "gateway/gcode/gcode_analog.hpp"

namespace gw::gcode {
namespace {

TEST(options, defaults_are_valid_and_documented_values) {
    const gcode_options o;
    EXPECT_FALSE(validate(o).has_value());
    EXPECT_DOUBLE_EQ(o.arc_tolerance_mm, 0.001);
    EXPECT_EQ(o.decimal_point, decimal_point_reading::calculator);
    EXPECT_EQ(o.z, z_mode::axis);
    EXPECT_DOUBLE_EQ(o.rapid_mm_s, 5.5);
    EXPECT_DOUBLE_EQ(o.ramp_ms, 20);
    EXPECT_DOUBLE_EQ(o.settle_ms, 14);
}

TEST(options, set_option_reads_text) {
    gcode_options o;
    EXPECT_FALSE(set_option(o, "xyz_scale", "0.25"));
    EXPECT_FALSE(set_option(o, "decimal_point", "least_increment"));
    EXPECT_FALSE(set_option(o, "z_mode", "analog"));
    EXPECT_FALSE(set_option(o, "analog_low_um", "-20"));
    EXPECT_FALSE(set_option(o, "analog_high_um", "+80"));
    EXPECT_FALSE(set_option(o, "analog_range", "error"));
    EXPECT_DOUBLE_EQ(o.xyz_scale, 0.25);
    EXPECT_EQ(o.decimal_point, decimal_point_reading::least_increment);
    EXPECT_EQ(o.z, z_mode::analog);
    EXPECT_DOUBLE_EQ(*o.analog_high_um, 80);
    EXPECT_EQ(o.analog_range, analog_range_policy::error);
    EXPECT_FALSE(validate(o).has_value());

    EXPECT_TRUE(set_option(o, "xyz_scale", "abc"));
    EXPECT_TRUE(set_option(o, "xyz_scale", "1.5x"));
    EXPECT_TRUE(set_option(o, "xyz_scale", "nan"));
    EXPECT_TRUE(set_option(o, "nope", "1"));
    EXPECT_TRUE(set_option(o, "z_mode", "piezo"));
    EXPECT_DOUBLE_EQ(o.xyz_scale, 0.25);  // unchanged by the failures
}

TEST(options, the_serial_link_of_the_estimate) {
    gcode_options o;
    EXPECT_EQ(o.host.baud, 115200u);  // `gcode plan` has no controller: the gateway's usual link
    EXPECT_DOUBLE_EQ(o.host.arrival_poll_ms, 20);
    EXPECT_FALSE(set_option(o, "baud", "9600"));
    EXPECT_FALSE(set_option(o, "arrival_poll_ms", "50"));
    EXPECT_EQ(o.host.baud, 9600u);
    EXPECT_DOUBLE_EQ(o.host.arrival_poll_ms, 50);
    EXPECT_TRUE(set_option(o, "baud", "0"));
    EXPECT_TRUE(set_option(o, "baud", "9600.5"));
    EXPECT_TRUE(set_option(o, "baud", "fast"));
    EXPECT_EQ(o.host.baud, 9600u);
    o.host.arrival_poll_ms = -1;
    EXPECT_TRUE(validate(o).has_value());
}

TEST(options, validate_rejects) {
    auto bad = [](auto change) {
        gcode_options o;
        change(o);
        return validate(o).has_value();
    };
    EXPECT_TRUE(bad([](gcode_options& o) { o.speed_scale = -1; }));
    EXPECT_TRUE(bad([](gcode_options& o) { o.arc_tolerance_mm = 0; }));
    EXPECT_TRUE(bad([](gcode_options& o) { o.max_feed_mm_s = 0; }));
    EXPECT_TRUE(bad([](gcode_options& o) { o.analog_low_um = 1; }));  // without a high limit
    EXPECT_TRUE(bad([](gcode_options& o) {
        o.analog_low_um = 10;
        o.analog_high_um = 10;
    }));
    EXPECT_TRUE(bad([](gcode_options& o) { o.max_line_chars = 0; }));
}

// #52 both voltage rules as the vendor document states them
TEST(analog, standard_rule_rises_custom_rule_falls_52) {
    const analog_mapping standard = analog_mapping_for(gcode_options{});
    EXPECT_FALSE(standard.falling);
    EXPECT_DOUBLE_EQ(analog_volts(standard, -50), 0);
    EXPECT_DOUBLE_EQ(analog_volts(standard, 0), 5);
    EXPECT_DOUBLE_EQ(analog_volts(standard, 50), 10);
    gcode_options o;
    o.analog_low_um = -50;
    o.analog_high_um = 50;
    const analog_mapping custom = analog_mapping_for(o);
    EXPECT_TRUE(custom.falling);
    EXPECT_DOUBLE_EQ(analog_volts(custom, -50), 10);
    EXPECT_DOUBLE_EQ(analog_volts(custom, 0), 5);
    EXPECT_DOUBLE_EQ(analog_volts(custom, 50), 0);
    EXPECT_DOUBLE_EQ(analog_volts(custom, 25), 2.5);
}

}  // namespace
}  // namespace gw::gcode
