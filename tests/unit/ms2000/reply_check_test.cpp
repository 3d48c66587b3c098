// reply_form inference by the command builders, and reply_fits: which replies can answer which command.
#include "devices/ms2000/reply_check.hpp"

#include <string>

#include <gtest/gtest.h>

#include "devices/ms2000/command.hpp"

namespace gw::devices::ms2000 {
namespace {

struct fit_case {
    std::string name;
    std::string command;  // a raw line, as an expert would type it
    reply_form::kind form;
    std::string line;  // the reply line (no CR LF)
    bool fits;
};

class reply_fits_test : public ::testing::TestWithParam<fit_case> {};

TEST_P(reply_fits_test, tells_an_answer_from_another_commands_reply) {
    const fit_case& c = GetParam();
    const auto cmd = raw_command(c.command);
    ASSERT_TRUE(cmd) << c.command;
    EXPECT_EQ(cmd->form.what, c.form) << c.command;
    const auto parsed = parse_reply(cmd->expect, c.line);
    if (!parsed) {
        EXPECT_FALSE(c.fits) << "the shape alone refuses \"" << c.line << "\"";
        return;
    }
    EXPECT_EQ(reply_fits(cmd->form, *parsed), c.fits) << c.command << " <- \"" << c.line << "\"";
}

using form = reply_form::kind;

INSTANTIATE_TEST_SUITE_P(
    table, reply_fits_test,
    ::testing::Values(
        // WHERE: one number per axis asked for, nothing else.
        fit_case{"where_one", "W X", form::numbers, ":A 12344.9", true},
        fit_case{"where_three", "W X Y Z", form::numbers, ":A 1234.5 432.1 0 ", true},
        fit_case{"where_lower_case", "w x y", form::numbers, ":A 1 2", true},
        fit_case{"where_too_few", "W X Y Z", form::numbers, ":A 12344.9", false},
        fit_case{"where_too_many", "W X", form::numbers, ":A 1 2", false},
        fit_case{"where_bare_ack", "W X", form::numbers, ":A", false},
        fit_case{"where_axes_form", "W X", form::numbers, ":A X=1", false},
        fit_case{"where_version", "W X", form::numbers, ":A Version: USB-9.52", false},
        fit_case{"where_text", "W X", form::numbers, ":A abc", false},
        fit_case{"where_error", "W Q", form::numbers, ":N-2", true},
        // VERSION: the version line only.
        fit_case{"version", "V", form::version, ":A Version: USB-9.52 ", true},
        fit_case{"version_tiger_style", "V", form::version, ":A v9.54", true},
        fit_case{"version_gets_position", "V", form::version, ":A 555.1", false},
        fit_case{"version_gets_ack", "V", form::version, ":A", false},
        // Motion: a bare ack.
        fit_case{"move_ack", "M X=100 Y=2", form::bare_ack, ":A", true},
        fit_case{"move_ack_space", "MOVE X=1", form::bare_ack, ":A ", true},
        fit_case{"move_gets_position", "M X=1", form::bare_ack, ":A 12344.9", false},
        fit_case{"move_gets_axes", "R X=1", form::bare_ack, ":A X=1", false},
        fit_case{"move_refused", "M X=1", form::bare_ack, ":N-4", true},
        fit_case{"halt_halted", "\\", form::bare_ack, ":N-21", true},
        fit_case{"halt_ack", "HALT", form::bare_ack, ":A", true},
        fit_case{"zero", "Z", form::bare_ack, ":A", true},
        fit_case{"here_bare_axis", "H X", form::bare_ack, ":A", true},
        fit_case{"home", "! X Y", form::bare_ack, ":A", true},
        // Parameter queries: every axis asked for, named (section 2.6's shapes).
        fit_case{"speed", "S X? Y?", form::axis_values, ":A X=5.500000 Y=5.500000 ", true},
        fit_case{"speed_missing_axis", "S X? Y?", form::axis_values, ":A X=5.5", false},
        fit_case{"speed_positional", "S X?", form::axis_values, ":A 5.5", false},
        fit_case{"accel_colon_form", "AC X? Y? Z?", form::axis_values, ":X=50 Y=50 Z=50 A", true},
        fit_case{"led_value_first", "LED X?", form::axis_values, "X=10 :A", true},
        fit_case{"cnts_gets_ack", "CNTS X?", form::axis_values, ":A", false},
        // TTL, RS and LK may answer positionally.
        fit_case{"ttl_named", "TTL X? Y?", form::axis_values, ":A X=0 Y=1", true},
        fit_case{"ttl_positional", "TTL X? Y?", form::axis_values, ":A 0 1", true},
        fit_case{"ttl_positional_short", "TTL X? Y?", form::axis_values, ":A 0", false},
        fit_case{"rs_adjacent", "RS X? Y?", form::axis_values, ":A NB", true},
        fit_case{"rs_one", "RS X?", form::axis_values, ":A B", true},
        fit_case{"rs_adjacent_short", "RS X? Y? Z?", form::axis_values, ":A NB", false},
        fit_case{"lk", "LK X?", form::axis_values, ":A F", true},
        fit_case{"overshoot_as_info_names_it", "O X? Y?", form::axis_values, ":A X=0 Y=0", true},
        fit_case{"kv_gets_another_axis", "KV X?", form::axis_values, ":A Y=15", false},
        fit_case{"joystick_input", "J Z?", form::axis_values, ":A Z=22", true},
        // BUILD X: the multi-line text, not a one-line reply of another command.
        fit_case{"build_x", "BU X", form::build_text, "STD_XYZ\rMotor Axes: X Y Z\rAxis Addr: 1 2 3", true},
        fit_case{"build_x_gets_ack", "BU X", form::build_text, ":A 12 34", false},
        fit_case{"build_x_absent", "BU X", form::build_text, ":N-1", true},
        // Verbs whose reply content is not known: the shape alone.
        fit_case{"array", "ARRAY X=3 Y=2", form::any, ":A", true},
        fit_case{"rm_query", "RM X?", form::any, ":A 3", true},
        fit_case{"speed_set", "S X=1", form::any, ":A", true},
        fit_case{"ttl_set", "TTL X=7", form::any, ":A", true}),
    [](const auto& info) { return info.param.name; });

TEST(reply_form, typed_builders_carry_the_form_of_their_reply) {
    EXPECT_EQ(where("XYZ").form.what, reply_form::kind::numbers);
    EXPECT_EQ(where("XYZ").form.axes, "XYZ");
    EXPECT_EQ(version().form.what, reply_form::kind::version);
    EXPECT_EQ(build_x().form.what, reply_form::kind::build_text);
    EXPECT_EQ(halt().form.what, reply_form::kind::bare_ack);
    EXPECT_EQ(zero().form.what, reply_form::kind::bare_ack);
    EXPECT_EQ(home("XY").form.what, reply_form::kind::bare_ack);
    EXPECT_EQ(move({{'X', 1.0}}).value().form.what, reply_form::kind::bare_ack);
    EXPECT_EQ(query("CNTS", "XY").form.what, reply_form::kind::axis_values);
    EXPECT_EQ(query("CNTS", "XY").form.axes, "XY");
    EXPECT_FALSE(query("CNTS", "XY").form.positional);
    EXPECT_TRUE(query("RS", "X").form.positional);
    EXPECT_EQ(status().form.what, reply_form::kind::any);  // "/": the status shape says it all
}

// RDSBYTE (only from a shared port's program): a colon and one raw byte per axis, any byte value.
TEST(accept_reply, rdsbyte_takes_raw_bytes_one_per_axis) {
    const auto one = verbatim_command("RB X");
    const auto two = verbatim_command("RB X Y");
    ASSERT_TRUE(one && two);
    EXPECT_TRUE(accept_reply(*one, ":\n"));
    EXPECT_TRUE(accept_reply(*one, std::string(":\x8a", 2)));  // 138: a lower limit
    EXPECT_TRUE(accept_reply(*one, ": "));                     // a byte that is a space is kept
    EXPECT_TRUE(accept_reply(*two, std::string(":\n\0", 3)));
    EXPECT_FALSE(accept_reply(*one, std::string(":\n\n", 3)));  // one byte too many
    EXPECT_FALSE(accept_reply(*two, ":\n"));                    // one too few
    EXPECT_FALSE(accept_reply(*one, ":"));
    EXPECT_FALSE(accept_reply(*one, "A\n"));
    const auto refused = accept_reply(*one, ":N-2");
    ASSERT_TRUE(refused);
    EXPECT_EQ(refused->what, reply::kind::error);
    EXPECT_EQ(refused->error_code, -2);
    EXPECT_EQ(accept_reply(*two, std::string(":\n\x0b", 3))->raw, std::string(":\n\x0b", 3));
    // Any other command still takes only text.
    EXPECT_FALSE(accept_reply(*verbatim_command("RS X"), std::string(":A \x0a", 4)));
}

TEST(reply_text, only_printable_ascii_and_the_cr_between_lines) {
    EXPECT_TRUE(is_reply_text(":A 1234.5 0 "));
    EXPECT_TRUE(is_reply_text("STD_XYZ\rMotor Axes: X Y Z"));
    EXPECT_TRUE(is_reply_text(""));
    EXPECT_FALSE(is_reply_text(std::string(":A 12\xC3", 6)));
    EXPECT_FALSE(is_reply_text(std::string(":A \xFF", 4)));
    EXPECT_FALSE(is_reply_text(std::string(":A\0", 3)));
    EXPECT_FALSE(is_reply_text(":A\t1"));
    EXPECT_FALSE(is_reply_text(":A\x7F"));
}

}  // namespace
}  // namespace gw::devices::ms2000
