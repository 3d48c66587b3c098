#include "gateway/jobs/manager/restore_ledger.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw::jobs {
namespace {

using commands = std::vector<std::string>;

TEST(restore_ledger, merge_keeps_the_older_commands_first_under_the_newer_job) {
    const owed_restore older{"j-1", false, {"RM Y=0", "TTL X=0"}};
    const owed_restore newer{"j-2", true, {"TTL X=0", "SCAN F=0"}};
    const auto both = merge(older, newer);
    EXPECT_EQ(both.job_id, "j-2");
    EXPECT_TRUE(both.ttl_low);
    // Sent newest first, "TTL X=0" (changed by both runs) is sent once, at the older run's place.
    EXPECT_EQ(both.restore, (commands{"RM Y=0", "TTL X=0", "SCAN F=0"}));
}

TEST(restore_ledger, a_first_debt_is_kept_as_it_is) {
    restore_ledger ledger;
    auto added = ledger.add("sim1", {"j-1", true, {"RM Y=0"}});
    EXPECT_FALSE(added.merged);
    EXPECT_FALSE(added.superseded_job);
    EXPECT_TRUE(ledger.owes("sim1"));
    EXPECT_FALSE(ledger.owes("sim2"));
    EXPECT_EQ(ledger.controllers_owed(), (commands{"sim1"}));
    auto owed = ledger.take("sim1");
    EXPECT_EQ(owed.job_id, "j-1");
    EXPECT_EQ(owed.restore, (commands{"RM Y=0"}));
    EXPECT_FALSE(ledger.owes("sim1"));
    EXPECT_TRUE(ledger.take("sim1").empty());
}

TEST(restore_ledger, a_second_debt_merges_and_names_the_job_it_supersedes) {
    restore_ledger ledger;
    ledger.add("sim1", {"j-1", false, {"A"}});
    auto added = ledger.add("sim1", {"j-2", false, {"B"}});
    EXPECT_TRUE(added.merged);
    EXPECT_EQ(added.superseded_job, "j-1");
    EXPECT_EQ(added.now.job_id, "j-2");
    EXPECT_EQ(added.now.restore, (commands{"A", "B"}));
}

TEST(restore_ledger, an_undelivered_older_debt_goes_before_one_added_meanwhile) {
    restore_ledger ledger;
    ledger.add("sim1", {"j-2", false, {"B"}});                                 // added while j-1's was sent
    auto added = ledger.add("sim1", {"j-1", true, {"A"}}, /*is_older=*/true);  // j-1's, undelivered
    EXPECT_EQ(added.now.job_id, "j-2");
    EXPECT_TRUE(added.now.ttl_low);
    EXPECT_EQ(added.now.restore, (commands{"A", "B"}));
    EXPECT_EQ(added.superseded_job, "j-1");
}

TEST(restore_ledger, the_same_jobs_debt_twice_supersedes_nothing) {
    restore_ledger ledger;
    ledger.add("sim1", {"j-1", false, {"A"}});
    auto added = ledger.add("sim1", {"j-1", false, {"A", "B"}});
    EXPECT_TRUE(added.merged);
    EXPECT_FALSE(added.superseded_job);
    EXPECT_EQ(added.now.restore, (commands{"A", "B"}));
}

TEST(restore_ledger, sending_is_tracked_per_controller) {
    restore_ledger ledger;
    ledger.start_sending("sim1");
    EXPECT_TRUE(ledger.sending("sim1"));
    EXPECT_FALSE(ledger.sending("sim2"));
    ledger.done_sending("sim1");
    EXPECT_FALSE(ledger.sending("sim1"));
}

}  // namespace
}  // namespace gw::jobs
