#include "gateway/jobs/manager/job_lanes.hpp"

#include <set>
#include <string>

#include <gtest/gtest.h>

namespace gw::jobs {
namespace {

const auto every_job = [](const std::string&) { return true; };

TEST(job_lanes, jobs_take_their_controller_in_submission_order_one_at_a_time) {
    job_lanes lanes;
    lanes.enqueue("sim1", "j-1");
    lanes.enqueue("sim1", "j-2");
    EXPECT_EQ(lanes.queued("sim1"), 2u);
    EXPECT_EQ(lanes.take_next("sim1", every_job), "j-1");
    EXPECT_EQ(lanes.holder("sim1"), "j-1");
    EXPECT_EQ(lanes.take_next("sim1", every_job), std::nullopt) << "sim1 is held";
    lanes.release("sim1", "j-2");  // not the holder: nothing changes
    EXPECT_EQ(lanes.holder("sim1"), "j-1");
    lanes.release("sim1", "j-1");
    EXPECT_EQ(lanes.holder("sim1"), "");
    EXPECT_EQ(lanes.take_next("sim1", every_job), "j-2");
    lanes.release("sim1", "j-2");
    EXPECT_EQ(lanes.take_next("sim1", every_job), std::nullopt) << "nothing is queued";
}

TEST(job_lanes, controllers_are_independent) {
    job_lanes lanes;
    lanes.enqueue("sim1", "j-1");
    lanes.enqueue("sim2", "j-2");
    EXPECT_EQ(lanes.take_next("sim1", every_job), "j-1");
    EXPECT_EQ(lanes.take_next("sim2", every_job), "j-2");
    EXPECT_EQ(lanes.controllers(), (std::vector<std::string>{"sim1", "sim2"}));
}

TEST(job_lanes, jobs_that_are_no_longer_queued_are_passed_over_and_dropped) {
    job_lanes lanes;
    for (const auto* id : {"j-1", "j-2", "j-3"})
        lanes.enqueue("sim1", id);
    const std::set<std::string> cancelled{"j-1", "j-2"};
    auto still_queued = [&](const std::string& id) { return !cancelled.contains(id); };
    EXPECT_EQ(lanes.take_next("sim1", still_queued), "j-3");
    EXPECT_EQ(lanes.queued("sim1"), 0u);
}

TEST(job_lanes, a_job_that_kept_its_controller_goes_first_when_it_resumes) {
    job_lanes lanes;
    lanes.enqueue("sim1", "j-1");
    ASSERT_EQ(lanes.take_next("sim1", every_job), "j-1");
    lanes.enqueue("sim1", "j-2");
    // j-1 paused by a disconnect, resumed: it gives up the hold and queues in front of j-2.
    lanes.release("sim1", "j-1");
    lanes.enqueue("sim1", "j-1", true);
    EXPECT_EQ(lanes.queue("sim1"), (std::deque<std::string>{"j-1", "j-2"}));
    EXPECT_EQ(lanes.take_next("sim1", every_job), "j-1");
}

TEST(job_lanes, a_removed_job_leaves_the_queue) {
    job_lanes lanes;
    lanes.enqueue("sim1", "j-1");
    lanes.enqueue("sim1", "j-2");
    lanes.remove("sim1", "j-1");
    lanes.remove("sim9", "j-1");  // no such lane: nothing
    EXPECT_EQ(lanes.queue("sim1"), (std::deque<std::string>{"j-2"}));
}

TEST(job_lanes, busy_while_held_planned_for_or_queued) {
    job_lanes lanes;
    EXPECT_FALSE(lanes.busy("sim1"));
    EXPECT_TRUE(lanes.queue("sim1").empty());
    lanes.enqueue("sim1", "j-1");
    EXPECT_TRUE(lanes.busy("sim1")) << "a job is queued";
    ASSERT_EQ(lanes.take_next("sim1", every_job), "j-1");
    EXPECT_TRUE(lanes.busy("sim1")) << "held";
    lanes.set_planning("sim1", true);
    lanes.release("sim1", "j-1");
    EXPECT_TRUE(lanes.busy("sim1")) << "being planned for";
    lanes.enqueue("sim1", "j-2");
    EXPECT_EQ(lanes.take_next("sim1", every_job), std::nullopt) << "no job starts while one is planned";
    lanes.set_planning("sim1", false);
    EXPECT_EQ(lanes.take_next("sim1", every_job), "j-2");
    lanes.release("sim1", "j-2");
    EXPECT_FALSE(lanes.busy("sim1"));
}

}  // namespace
}  // namespace gw::jobs
