// Reading a restore command back as the settings it puts back (job_context::settings_before takes a
// setting's value from a registered restore command before it asks the controller).
#include "gateway/jobs/job_commands.hpp"

#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

namespace gw::jobs {
namespace {

using values = std::map<char, double>;

TEST(job_commands, a_restore_command_reads_back_as_the_values_it_sets) {
    EXPECT_EQ(values_set("TTL X=0", "TTL"), (values{{'X', 0}}));
    EXPECT_EQ(values_set("TTL X=7", "TTL"), (values{{'X', 7}}));
    EXPECT_EQ(values_set("SPEED X=5.5", "SPEED"), (values{{'X', 5.5}}));
    EXPECT_EQ(values_set("SPEED X=4.91935 Y=2.459675", "SPEED"), (values{{'X', 4.91935}, {'Y', 2.459675}}));
    EXPECT_EQ(values_set("SPEED X=-0.5", "SPEED"), (values{{'X', -0.5}}));
    // What a command builder makes reads back as what it was given.
    EXPECT_EQ(values_set(command_text("SPEED", {set_arg('X', 1.234567, 6)}), "SPEED"),
              (values{{'X', 1.234567}}));
}

TEST(job_commands, another_verbs_line_or_a_non_setting_argument_sets_nothing) {
    EXPECT_TRUE(values_set("TTL Y=0", "SPEED").empty());
    EXPECT_TRUE(values_set("TTLX X=1", "TTL").empty());  // another verb with the same start
    EXPECT_TRUE(values_set("TTL", "TTL").empty());
    EXPECT_TRUE(values_set("TTL X?", "TTL").empty());
    EXPECT_TRUE(values_set("SPEED X= Y=abc", "SPEED").empty());
    EXPECT_EQ(values_set("SPEED X Y=2 Z=1x", "SPEED"), (values{{'Y', 2}}));
}

TEST(job_commands, query_text_asks_for_each_letter) {
    EXPECT_EQ(query_text("TTL", "X"), "TTL X?");
    EXPECT_EQ(query_text("SPEED", "XY"), "SPEED X? Y?");
}

// What a run sends is a typed command: its wire bytes and the reply it must get, not text parsed back.
TEST(job_commands, a_run_sends_typed_commands_that_read_as_their_line) {
    const auto speed = typed_command("SPEED", {set_arg('X', 1.5, 6)});
    EXPECT_EQ(speed.wire, "SPEED X=1.5\r");
    EXPECT_EQ(text_of(speed), "SPEED X=1.5");
    EXPECT_EQ(text_of(typed_command("SCAN")), "SCAN");
    EXPECT_EQ(text_of(typed_command("SCAN", {bare_arg('P')})), "SCAN P");
    EXPECT_EQ(text_of(ttl_in0(7)), "TTL X=7");
    // The restore list holds these lines: the recovery service looks for "TTL Y=0" by its text.
    EXPECT_EQ(text_of(ttl_output(false)), "TTL Y=0");
    EXPECT_EQ(text_of(ttl_output(true)), "TTL Y=1");
    EXPECT_EQ(ttl_output(true).verb, "TTL");
}

TEST(job_commands, a_command_the_builder_refuses_is_never_sent_as_a_bare_verb) {
    // command_text, for previews, falls back to the verb; a run's command throws instead.
    EXPECT_THROW(typed_command("SPEED", {set_arg('X', std::nan(""))}), std::invalid_argument);
    EXPECT_THROW(typed_command("SPEED X", {}), std::invalid_argument);  // not a verb
}

}  // namespace
}  // namespace gw::jobs
