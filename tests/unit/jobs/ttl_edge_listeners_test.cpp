#include "gateway/jobs/manager/ttl_edge_listeners.hpp"

#include <gtest/gtest.h>

namespace gw::jobs {
namespace {

TEST(ttl_edge_listeners, only_a_controller_with_a_run_is_listened_to) {
    ttl_edge_listeners listeners;
    EXPECT_FALSE(listeners.listening("sim1")) << "no run at all";
    listeners.add("sim1");
    EXPECT_TRUE(listeners.listening("sim1"));
    EXPECT_FALSE(listeners.listening("sim2")) << "another controller's frames stay on its strand";
    EXPECT_FALSE(listeners.listening("sim")) << "a prefix is another controller";
    listeners.remove("sim1");
    EXPECT_FALSE(listeners.listening("sim1"));
}

TEST(ttl_edge_listeners, overlapping_runs_on_one_controller_do_not_unregister_each_other) {
    ttl_edge_listeners listeners;
    listeners.add("sim1");
    listeners.add("sim1");  // registered twice: each remove takes back one
    listeners.remove("sim1");
    EXPECT_TRUE(listeners.listening("sim1"));
    listeners.remove("sim1");
    EXPECT_FALSE(listeners.listening("sim1"));
}

TEST(ttl_edge_listeners, removing_what_was_never_added_changes_nothing) {
    ttl_edge_listeners listeners;
    listeners.remove("sim1");
    listeners.add("sim2");
    listeners.remove("sim1");
    EXPECT_TRUE(listeners.listening("sim2"));
    listeners.remove("sim2");
    listeners.remove("sim2");
    EXPECT_FALSE(listeners.listening("sim2"));
    listeners.add("sim2");
    EXPECT_TRUE(listeners.listening("sim2")) << "the count did not go below zero";
}

}  // namespace
}  // namespace gw::jobs
