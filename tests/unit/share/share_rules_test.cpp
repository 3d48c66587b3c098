#include "devices/share/share_rules.hpp"

#include <gtest/gtest.h>

namespace gw::devices::share {
namespace {

using ms2000::command_effect;

TEST(share_rules, each_role_sends_what_it_may) {
    struct row {
        command_effect effect;
        bool viewer, operator_, admin;
    };
    const row rows[] = {
        {command_effect::reads, true, true, true},         {command_effect::halts, true, true, true},
        {command_effect::acts, false, true, true},         {command_effect::writes_flash, false, false, true},
        {command_effect::breaks_link, false, false, true}, {command_effect::unknown, false, false, true},
    };
    for (const auto& r : rows) {
        EXPECT_EQ(role_allows(share_role::viewer, r.effect), r.viewer) << ms2000::to_string(r.effect);
        EXPECT_EQ(role_allows(share_role::operator_, r.effect), r.operator_) << ms2000::to_string(r.effect);
        EXPECT_EQ(role_allows(share_role::admin, r.effect), r.admin) << ms2000::to_string(r.effect);
    }
}

TEST(share_rules, reads_and_halt_never_wait_for_control) {
    EXPECT_FALSE(needs_control(command_effect::reads));
    EXPECT_FALSE(needs_control(command_effect::halts));
    EXPECT_TRUE(needs_control(command_effect::acts));
    EXPECT_TRUE(needs_control(command_effect::writes_flash));
    EXPECT_TRUE(needs_control(command_effect::unknown));
}

TEST(share_rules, refusals_are_error_replies_outside_the_firmware_codes) {
    EXPECT_EQ(refusal_reply(refusal_code::held_elsewhere), ":N-90\r\n");
    EXPECT_EQ(refusal_reply(refusal_code::role), ":N-91\r\n");
    EXPECT_EQ(refusal_reply(refusal_code::unreadable), ":N-92\r\n");
    EXPECT_EQ(refusal_reply(refusal_code::busy), ":N-93\r\n");
}

}  // namespace
}  // namespace gw::devices::share
