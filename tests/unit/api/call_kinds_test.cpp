// The call descriptors: one per kind of call, read for its role, its lease rule and its audit.
#include "api/calls/call_kinds.hpp"

#include <set>
#include <string>

#include <gtest/gtest.h>

#include "api/calls/calls.hpp"
#include "api/calls/operation_requests.hpp"

namespace gw::api {
namespace {

TEST(call_kinds, every_operation_has_one_descriptor_and_halt_never_waits_for_a_lease) {
    std::set<std::string_view> names;
    for (const auto& d : operation_descriptors())
        EXPECT_TRUE(names.insert(d.name).second) << d.name << " twice";
    EXPECT_EQ(names.size(), operation_names().size());
    for (const auto name : operation_names()) {
        ASSERT_NE(operation_descriptor(name), nullptr) << name;
        EXPECT_EQ(operation_descriptor(name)->name, name);
        EXPECT_EQ(needs_lease(name), name != "halt") << name;
        EXPECT_TRUE(operation_descriptor(name)->audited) << name;  // every operation changes something
    }
    EXPECT_EQ(operation_descriptor("halt")->role, role_need::halt);
    EXPECT_EQ(operation_descriptor("command")->role, role_need::admin);
    EXPECT_EQ(operation_descriptor("launch"), nullptr);
    EXPECT_FALSE(is_operation("launch"));
    EXPECT_TRUE(needs_lease("launch"));  // not an operation: nothing is let through for it
}

TEST(call_kinds, a_call_is_described_by_what_it_does) {
    EXPECT_EQ(descriptor_of(operation_call{"s1", "zero", {}}).name, "zero");
    EXPECT_EQ(descriptor_of(operation_call{"s1", "launch", {}}).name, "");
    EXPECT_EQ(descriptor_of(job_submit_call{}).name, "job.submit");
    EXPECT_EQ(descriptor_of(job_submit_call{{}, true, std::nullopt}).name, "job.plan");
    EXPECT_FALSE(
        descriptor_of(job_submit_call{{}, true, std::nullopt}).audited);  // a dry run changes nothing
    EXPECT_EQ(descriptor_of(job_action_call{"j-1", job_command::resume}).name, "job.resume");
    EXPECT_EQ(descriptor_of(job_action_call{"j-1", job_command::next}).lease, lease_rule::job);
    EXPECT_EQ(descriptor_of(lease_release_call{"s1", false}).name, "lease.release");
    EXPECT_EQ(descriptor_of(lease_release_call{"s1", true}).name, "lease.break");
    EXPECT_FALSE(descriptor_of(lease_renew_call{"s1", {}}).audited);
    EXPECT_FALSE(descriptor_of(job_get_call{"j-1"}).audited);
    EXPECT_FALSE(descriptor_of(gcode_check_call{"g-1", {}}).audited);
    EXPECT_EQ(descriptor_of(halt_all_call{}).lease, lease_rule::none);
}

TEST(call_kinds, the_halt_role_stands_for_auth_halt_role) {
    EXPECT_EQ(role_needed(call_kinds::halt_all, gw::role::operator_), gw::role::operator_);
    EXPECT_EQ(role_needed(call_kinds::halt_all, gw::role::viewer), gw::role::viewer);
    EXPECT_EQ(role_needed(call_kinds::lease_break, gw::role::viewer), gw::role::admin);
    EXPECT_EQ(role_needed(call_kinds::job_get, gw::role::admin), gw::role::viewer);
}

}  // namespace
}  // namespace gw::api
