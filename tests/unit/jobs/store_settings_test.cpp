#include <gtest/gtest.h>

#include "gateway/config/config.hpp"
#include "gateway/jobs/manager/job_manager.hpp"

namespace gw::jobs {
namespace {

TEST(store_settings, job_manager_settings_come_from_storage_and_jobs) {
    auto c = parse_config(R"({"storage": {"path": "/var/lib/asi", "max_size_mb": 8},
                              "jobs": {"restart_queued": true, "max_queued_per_controller": 3}})");
    ASSERT_TRUE(c) << c.error();
    auto s = make_job_manager_settings(*c);
    EXPECT_EQ(s.storage_path, "/var/lib/asi");
    EXPECT_EQ(s.storage_max_size_mb, 8u);
    EXPECT_TRUE(s.restart_queued);
    EXPECT_EQ(s.max_queued_per_controller, 3u);
}

TEST(store_settings, defaults_match_the_manager_defaults) {
    auto s = make_job_manager_settings(default_config());
    job_manager_settings d;
    EXPECT_EQ(s.storage_path, "");  // resolved by main (gateway/storage/storage_path.hpp)
    EXPECT_EQ(s.storage_max_size_mb, d.storage_max_size_mb);
    EXPECT_EQ(s.restart_queued, d.restart_queued);
    EXPECT_EQ(s.max_queued_per_controller, d.max_queued_per_controller);
    EXPECT_EQ(s.idle_timeout, d.idle_timeout);
}

}  // namespace
}  // namespace gw::jobs
