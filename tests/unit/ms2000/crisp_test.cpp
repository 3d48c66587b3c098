#include "devices/ms2000/crisp.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "devices/ms2000/reply_check.hpp"

namespace gw::devices::ms2000 {
namespace {

struct state_case {
    const char* line;
    bool answer;  // accepted as the answer to LK X?
    std::optional<char> state;
};

class crisp_state_reply : public ::testing::TestWithParam<state_case> {};

TEST_P(crisp_state_reply, reads_the_state_letter) {
    const auto& c = GetParam();
    const auto r = accept_reply(crisp_state_query(), c.line);
    ASSERT_EQ(r.has_value(), c.answer) << c.line;
    if (r) {
        EXPECT_EQ(crisp_state_of(*r), c.state) << c.line;
    }
}

INSTANTIATE_TEST_SUITE_P(
    table, crisp_state_reply,
    ::testing::Values(state_case{":A F", true, 'F'}, state_case{":A R", true, 'R'},
                      state_case{":A I ", true, 'I'}, state_case{":A f", true, 'f'},
                      state_case{":A 3", true, '3'}, state_case{":A X=F", true, std::nullopt},
                      state_case{":A FR", true, std::nullopt}, state_case{":A", false, std::nullopt},
                      state_case{":A F R", false, std::nullopt}, state_case{":N-1", true, std::nullopt},
                      state_case{"F", false, std::nullopt}, state_case{":A \x7f", false, std::nullopt}));

struct reading_case {
    const char* command;
    const char* line;
    bool answer;
    std::optional<double> value;
};

class crisp_reading_reply : public ::testing::TestWithParam<reading_case> {};

TEST_P(crisp_reading_reply, reads_one_number_in_either_form) {
    const auto& c = GetParam();
    const auto r = accept_reply(raw_command(c.command).value(), c.line);
    ASSERT_EQ(r.has_value(), c.answer) << c.command << " / " << c.line;
    if (r) {
        EXPECT_EQ(single_reading(*r), c.value) << c.command << " / " << c.line;
    }
}

INSTANTIATE_TEST_SUITE_P(table, crisp_reading_reply,
                         ::testing::Values(reading_case{"LK Y?", ":A -1234 ", true, -1234},
                                           reading_case{"LK Y?", ":A 0", true, 0},
                                           reading_case{"LK T?", ":A 2400 ", true, 2400},
                                           reading_case{"LK Z?", ":A Z=20 ", true, 20},
                                           reading_case{"LK Z?", ":A 20.5", true, 20.5},
                                           reading_case{"LK Z?", ":A Y=20", false, {}},
                                           reading_case{"LK Y?", ":A abc", true, std::nullopt},
                                           reading_case{"LK Y?", ":A 1 2", false, std::nullopt},
                                           reading_case{"EX Y?", ":A 20.5 ", true, 20.5},
                                           reading_case{"EX Y?", ":A", true, std::nullopt},
                                           reading_case{"AF X?", ":A 1 ", true, 1},
                                           reading_case{"LK Y?", ":A inf", true, std::nullopt},
                                           reading_case{"LK Y?", ":N-1", true, std::nullopt}));

TEST(crisp_commands, wire_forms) {
    EXPECT_EQ(crisp_state_query().wire, "LK X?\r");
    EXPECT_EQ(crisp_lock().wire, "LK F=83\r");
    EXPECT_EQ(crisp_unlock().wire, "LK F=85\r");
    EXPECT_EQ(crisp_off().wire, "LK F=79\r");
    EXPECT_EQ(crisp_set_offset(-20.5).value().wire, "LK Z=-20.5\r");
    EXPECT_FALSE(crisp_set_offset(40000).has_value());
    EXPECT_FALSE(crisp_set_offset(std::nan("")).has_value());
    EXPECT_EQ(autofocus_start().wire, "AF\r");
    EXPECT_EQ(autofocus_query().wire, "AF X?\r");
    EXPECT_TRUE(only_reads(crisp_sum_query()));
    EXPECT_FALSE(only_reads(crisp_lock()));
}

TEST(crisp_commands, the_snr_command_follows_the_firmware_version) {
    EXPECT_EQ(crisp_snr_query("9.53")->wire, "EX Y?\r");
    EXPECT_EQ(crisp_snr_query("9.54")->wire, "EX Y?\r");
    EXPECT_EQ(crisp_snr_query("10.1")->wire, "EX Y?\r");
    EXPECT_EQ(crisp_snr_query("9.52")->wire, "EXTRA Y?\r");
    EXPECT_EQ(crisp_snr_query("9.50")->wire, "EXTRA Y?\r");
    EXPECT_EQ(crisp_snr_query("9.2p")->wire, "EXTRA Y?\r");  // letter revisions are older
    EXPECT_EQ(crisp_snr_query("9.5")->wire, "EXTRA Y?\r");
    EXPECT_FALSE(crisp_snr_query("").has_value());
    EXPECT_FALSE(crisp_snr_query("v9").has_value());
}

TEST(crisp_states, names_of_the_letters_mm_stage_maps) {
    EXPECT_EQ(crisp_state_name('F'), "locked");
    EXPECT_EQ(crisp_state_name('K'), "trying_to_lock");
    EXPECT_EQ(crisp_state_name('R'), "ready");
    EXPECT_EQ(crisp_state_name('I'), "idle");
    EXPECT_EQ(crisp_state_name('E'), "error");
    EXPECT_EQ(crisp_state_name('3'), "calibrating");
    EXPECT_EQ(crisp_state_name('c'), "focus_curve");
    EXPECT_EQ(crisp_state_name('Q'), "unknown");
    EXPECT_TRUE(crisp_locking_or_locked('F'));
    EXPECT_FALSE(crisp_locking_or_locked('R'));
}

}  // namespace
}  // namespace gw::devices::ms2000
