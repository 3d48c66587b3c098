// Reading a restore command back as the settings it puts back (job_context::settings_before takes a
// setting's value from a registered restore command before it asks the controller).
#include "gateway/jobs/job_commands.hpp"

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

}  // namespace
}  // namespace gw::jobs
