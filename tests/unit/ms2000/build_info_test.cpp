#include "devices/ms2000/build_info.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/line_framer.hpp"
#include "devices/ms2000/reply.hpp"

namespace gw::devices::ms2000 {
namespace {

// The example of the ASI manual (seed 000), with the framer's CR LF removed.
constexpr std::string_view seed_example =
    "STD_XYZ_SEQ\rMotor Axes: X Y Z\rCMDs: XYZFTR\rBootLdr V:1\rHdwr REV.E\rLL COMMANDS\rRING BUFFER\r"
    "SEARCH INDEX\rARRAY MODULE\rINO_INT\rDAC OUT\rSEQUENCER\rPLANAR CORRECTION";

void expect_equal(const build_info& a, const build_info& b) {
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.motor_axes, b.motor_axes);
    EXPECT_EQ(a.command_axes, b.command_axes);
    EXPECT_EQ(a.bootloader, b.bootloader);
    EXPECT_EQ(a.hardware_revision, b.hardware_revision);
    EXPECT_EQ(a.module_lines, b.module_lines);
    EXPECT_EQ(a.modules, b.modules);
    EXPECT_EQ(a.ring_buffer_size, b.ring_buffer_size);
}

TEST(parse_build_x, reads_the_manual_example) {
    const auto b = parse_build_x(seed_example);
    ASSERT_TRUE(b.has_value());
    EXPECT_EQ(b->name, "STD_XYZ_SEQ");
    EXPECT_EQ(b->motor_axes, "XYZ");
    EXPECT_EQ(b->command_axes, "XYZFTR");
    EXPECT_EQ(b->bootloader, "1");
    EXPECT_EQ(b->hardware_revision, "E");
    EXPECT_EQ(b->module_lines,
              (std::vector<std::string>{"LL COMMANDS", "RING BUFFER", "SEARCH INDEX", "ARRAY MODULE",
                                        "INO_INT", "DAC OUT", "SEQUENCER", "PLANAR CORRECTION"}));
    for (module m : {module::ll_commands, module::ring_buffer, module::search_index, module::array,
                     module::in0_int, module::dac_out, module::sequencer, module::planar_correction}) {
        EXPECT_TRUE(b->has(m)) << module_id(m);
    }
    for (module m : {module::scan, module::ttl_report, module::crisp, module::tracer, module::led_dimmer}) {
        EXPECT_FALSE(b->has(m)) << module_id(m);
    }
    EXPECT_EQ(b->modules.count(), 8u);
    EXPECT_EQ(b->ring_buffer_size, 50);
}

struct module_case {
    std::string line;
    module m;
};

class module_line_test : public ::testing::TestWithParam<module_case> {};

TEST_P(module_line_test, is_recognised) {
    const auto b = parse_build_x("STD_XY\r" + GetParam().line);
    ASSERT_TRUE(b.has_value());
    EXPECT_TRUE(b->has(GetParam().m)) << GetParam().line;
    EXPECT_EQ(b->modules.count(), 1u) << GetParam().line;
    EXPECT_EQ(b->module_lines, std::vector<std::string>{GetParam().line});
}

INSTANTIATE_TEST_SUITE_P(
    table, module_line_test,
    ::testing::Values(
        module_case{"ARRAY MODULE", module::array}, module_case{"RING BUFFER", module::ring_buffer},
        module_case{"RING BUFFER 250", module::ring_buffer}, module_case{"SCAN MODULE", module::scan},
        module_case{"SCAN_MODULE", module::scan}, module_case{"TTL_REPORT_INT", module::ttl_report},
        module_case{"TTL REPORT", module::ttl_report}, module_case{"TTL_REPORT", module::ttl_report},
        module_case{"SERIAL OUT", module::serial_out}, module_case{"BINARY_OUTPUT", module::binary_output},
        module_case{"PLANAR CORRECTION", module::planar_correction}, module_case{"DAC OUT", module::dac_out},
        module_case{"DAC_OUT", module::dac_out}, module_case{"LED DIMMER", module::led_dimmer},
        module_case{"DLED", module::led_dimmer}, module_case{"AUTOFOCUS", module::autofocus},
        module_case{"AFOCUS", module::autofocus}, module_case{"CRISP", module::crisp},
        module_case{"SEQUENCER", module::sequencer}, module_case{"TRACER", module::tracer},
        module_case{"MULTIAXIS MOVES", module::multiaxis_moves},
        module_case{"SEARCH INDEX", module::search_index}, module_case{"IN0_INT", module::in0_int},
        module_case{"INO_INT", module::in0_int}, module_case{"ENC_INT", module::enc_int},
        module_case{"ENC_INT_2", module::enc_int}, module_case{"LL COMMANDS", module::ll_commands}));

TEST(parse_build_x, ring_buffer_size) {
    EXPECT_EQ(parse_build_x("STD\rRING BUFFER 50")->ring_buffer_size, 50);
    EXPECT_EQ(parse_build_x("STD\rRING BUFFER 250")->ring_buffer_size, 250);
    EXPECT_EQ(parse_build_x("STD\rRING BUFFER")->ring_buffer_size, 50);
    EXPECT_EQ(parse_build_x("STD\rRING BUFFER x")->ring_buffer_size, 50);
    EXPECT_EQ(parse_build_x("STD\rARRAY MODULE")->ring_buffer_size, 0);
    EXPECT_FALSE(parse_build_x("STD\rRING BUFFERS")->has(module::ring_buffer));
}

TEST(parse_build_x, tracer_from_the_name_suffix) {
    const auto b = parse_build_x("WK_XYZ_TRACER\rMotor Axes: X Y");
    ASSERT_TRUE(b.has_value());
    EXPECT_TRUE(b->has(module::tracer));
    EXPECT_TRUE(b->module_lines.empty());
    EXPECT_EQ(b->motor_axes, "XY");
    EXPECT_FALSE(parse_build_x("_TRACER")->has(module::tracer));  // the suffix alone is not a name with it
}

TEST(parse_build_x, unknown_lines_are_kept) {
    const auto b = parse_build_x("STD_XYZ\rAxis Types: x x z\rPEDALS\rTTL_OUT_REPORT");
    ASSERT_TRUE(b.has_value());
    EXPECT_EQ(b->module_lines, (std::vector<std::string>{"Axis Types: x x z", "PEDALS", "TTL_OUT_REPORT"}));
    EXPECT_TRUE(b->modules.none());
}

TEST(parse_build_x, tolerates_line_ends_spaces_and_an_ack_prefix) {
    const auto b = parse_build_x(":A STD_XY \r\nMotor Axes: X Y \r\r\nCRISP \r\n");
    ASSERT_TRUE(b.has_value());
    EXPECT_EQ(b->name, "STD_XY");
    EXPECT_EQ(b->motor_axes, "XY");
    EXPECT_EQ(b->module_lines, std::vector<std::string>{"CRISP"});
    EXPECT_TRUE(b->has(module::crisp));
}

TEST(parse_build_x, refuses_text_without_a_name) {
    for (const std::string text : {"", "\r\r", "   ", ":N-1", ":A", ":A  "}) {
        const auto b = parse_build_x(text);
        ASSERT_FALSE(b.has_value()) << text;
        EXPECT_EQ(b.error(), make_error_code(error::unrecognized_reply));
    }
}

TEST(format_build_x, writes_the_manual_layout) {
    const auto b = parse_build_x(seed_example);
    ASSERT_TRUE(b.has_value());
    EXPECT_EQ(format_build_x(*b), seed_example);
}

TEST(format_build_x, round_trips) {
    const std::vector<std::string> texts{
        std::string(seed_example),
        "STD_XY\rMotor Axes: X Y\rRING BUFFER 250\rTTL_REPORT_INT\rSERIAL OUT\rBINARY_OUTPUT",
        "WK_XYZ_TRACER\rCMDs: XYZF\rLED DIMMER\rAxis Types: x x z",
        "BARE",
    };
    for (const std::string& text : texts) {
        const auto b = parse_build_x(text);
        ASSERT_TRUE(b.has_value()) << text;
        const std::string formatted = format_build_x(*b);
        EXPECT_EQ(formatted.find('\n'), std::string::npos);
        EXPECT_NE(formatted.back(), '\r');
        const auto again = parse_build_x(formatted);
        ASSERT_TRUE(again.has_value()) << formatted;
        expect_equal(*b, *again);
    }
}

TEST(format_build_x, prints_modules_set_only_in_the_bitset) {
    build_info b;
    b.name = "SIM_XYZ";
    b.motor_axes = "XYZ";
    b.command_axes = "XYZFTR";
    b.bootloader = "1";
    b.hardware_revision = "E";
    b.modules.set(static_cast<std::size_t>(module::ring_buffer));
    b.modules.set(static_cast<std::size_t>(module::ttl_report));
    b.modules.set(static_cast<std::size_t>(module::tracer));
    b.ring_buffer_size = 250;
    const std::string text = format_build_x(b);
    EXPECT_EQ(
        text,
        "SIM_XYZ\rMotor Axes: X Y Z\rCMDs: XYZFTR\rBootLdr V:1\rHdwr REV.E\rRING BUFFER 250\rTTL_REPORT_INT\r"
        "TRACER");
    const auto again = parse_build_x(text);
    ASSERT_TRUE(again.has_value());
    EXPECT_EQ(again->modules, b.modules);
    EXPECT_EQ(again->ring_buffer_size, 250);
}

// What the simulator sends and the driver reads: format, CR LF, framer, parse_reply, parse_build_x.
TEST(format_build_x, survives_the_wire) {
    const auto b = parse_build_x(seed_example);
    ASSERT_TRUE(b.has_value());
    line_framer framer;
    std::vector<std::string> lines;
    const std::string wire = format_build_x(*b) + "\r\n";
    for (char c : wire)
        framer.feed(std::string_view(&c, 1), lines);
    ASSERT_EQ(lines.size(), 1u);
    const auto r = parse_reply(reply_shape::multiline, lines[0]);
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->what, reply::kind::text);
    EXPECT_EQ(r->lines.size(), 13u);
    const auto again = parse_build_x(r->raw);
    ASSERT_TRUE(again.has_value());
    expect_equal(*b, *again);
}

TEST(module, ids_and_lines) {
    for (std::size_t i = 0; i < static_cast<std::size_t>(module::count_); ++i) {
        const auto m = static_cast<module>(i);
        EXPECT_FALSE(module_id(m).empty());
        EXPECT_FALSE(module_line(m).empty());
        EXPECT_EQ(module_from_id(module_id(m)), m);
        const auto b = parse_build_x("N\r" + std::string(module_line(m)));
        ASSERT_TRUE(b.has_value());
        EXPECT_TRUE(b->has(m)) << module_line(m);
    }
    EXPECT_EQ(module_id(module::ring_buffer), "ring_buffer");
    EXPECT_EQ(module_line(module::ring_buffer), "RING BUFFER");
    EXPECT_EQ(module_from_id("nope"), std::nullopt);
    EXPECT_EQ(module_from_id("RING_BUFFER"), std::nullopt);
}

}  // namespace
}  // namespace gw::devices::ms2000
