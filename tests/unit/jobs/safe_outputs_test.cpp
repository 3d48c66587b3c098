// Which interrupted jobs get their TTL output switched off after a restart.
#include "gateway/jobs/kinds/safe_outputs.hpp"

#include <gtest/gtest.h>

namespace gw::jobs {
namespace {

using json = nlohmann::json;

TEST(safe_outputs, gcode_and_pulsing_arrays_may_have_left_the_output_high) {
    EXPECT_TRUE(may_leave_ttl_output_high(job_type::gcode, json{{"program", "G01 X1 F60\n"}}));
    EXPECT_TRUE(may_leave_ttl_output_high(job_type::array, json{{"ttl_pulse", true}}));
    EXPECT_FALSE(may_leave_ttl_output_high(job_type::array, json{{"ttl_pulse", false}}));
    EXPECT_FALSE(may_leave_ttl_output_high(job_type::array, json::object()));
    EXPECT_FALSE(may_leave_ttl_output_high(job_type::array, json{{"ttl_pulse", "yes"}}));  // not a bool
    EXPECT_FALSE(may_leave_ttl_output_high(job_type::array, json::array()));
    // Their restore commands switch TTL input modes (TTL X=), not the output.
    EXPECT_FALSE(may_leave_ttl_output_high(job_type::scan, json::object()));
    EXPECT_FALSE(may_leave_ttl_output_high(job_type::ring_buffer, json::object()));
    EXPECT_FALSE(may_leave_ttl_output_high(job_type::planar_correction, json::object()));
}

TEST(safe_outputs, the_recovery_has_its_own_request_id) {
    EXPECT_EQ(safe_output_request_id("j-1"), "recovery-j-1");
    EXPECT_NE(safe_output_request_id("j-1"), "job-j-1");
}

}  // namespace
}  // namespace gw::jobs
