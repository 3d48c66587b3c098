#include "api/calls.hpp"

#include <optional>

#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>

#include "gateway/controllers/controller_registry.hpp"

namespace gw::api {
namespace {

// Calls on a context without controllers and without a job manager: what the dispatch itself decides.
class calls_test : public ::testing::Test {
  protected:
    calls_test()
        : registry_(io_.get_executor(), registry_options{}),
          ctx_{io_.get_executor(), registry_, nullptr, nullptr, {}, {}, nullptr, nullptr, nullptr} {}

    // The outcome of `c` for a caller with `role`; checks that it is never delivered inline.
    api_outcome dispatch(gw::role role, call c) {
        std::optional<api_outcome> out;
        dispatch_call(ctx_, caller{"ada", role, "rid-7", std::nullopt}, std::move(c),
                      [&out](api_outcome o) { out = std::move(o); });
        EXPECT_FALSE(out.has_value()) << "answered inline";
        io_.run();
        io_.restart();
        EXPECT_TRUE(out.has_value());
        return out ? std::move(*out) : api_outcome{};
    }

    boost::asio::io_context io_;
    controller_registry registry_;
    api_context ctx_;
};

TEST_F(calls_test, each_call_needs_its_role) {
    EXPECT_EQ(role_for(operation_call{"s1", "move", {}}), gw::role::operator_);
    EXPECT_EQ(role_for(operation_call{"s1", "command", {}}), gw::role::admin);
    EXPECT_EQ(role_for(job_submit_call{}), gw::role::operator_);
    EXPECT_EQ(role_for(job_action_call{"j-1", job_command::pause}), gw::role::operator_);
    EXPECT_EQ(role_for(job_get_call{"j-1"}), gw::role::viewer);
    EXPECT_EQ(role_for(lease_get_call{"s1"}), gw::role::viewer);
    EXPECT_EQ(role_for(lease_take_call{"s1", {}}), gw::role::operator_);
    EXPECT_EQ(role_for(lease_renew_call{"s1", {}}), gw::role::operator_);
    EXPECT_EQ(role_for(lease_release_call{"s1", false}), gw::role::operator_);
    EXPECT_EQ(role_for(lease_release_call{"s1", true}), gw::role::admin);
}

TEST_F(calls_test, a_role_too_low_is_403_whatever_the_transport) {
    for (auto [role, c] : {std::pair<gw::role, call>{gw::role::viewer, operation_call{"s1", "move", {}}},
                           {gw::role::operator_, operation_call{"s1", "command", {{"command", "V"}}}},
                           {gw::role::viewer, job_submit_call{}},
                           {gw::role::viewer, job_action_call{"j-1", job_command::cancel}},
                           {gw::role::viewer, lease_take_call{"s1", {}}},
                           {gw::role::operator_, lease_release_call{"s1", true}}}) {
        auto out = dispatch(role, c);
        ASSERT_TRUE(out.error);
        EXPECT_EQ(out.error->status, 403);
        EXPECT_EQ(out.error->request_id, "rid-7");
    }
}

TEST_F(calls_test, an_allowed_call_reaches_its_resource) {
    // No controllers: the operation is refused by the registry (404), not by the dispatch.
    auto op = dispatch(gw::role::operator_, operation_call{"s1", "halt", {}});
    ASSERT_TRUE(op.error);
    EXPECT_EQ(op.error->status, 404);
    // No job manager: the job calls answer what the job routes answer without one (503).
    auto get = dispatch(gw::role::viewer, job_get_call{"j-1"});
    ASSERT_TRUE(get.error);
    EXPECT_EQ(get.error->status, 503);
}

}  // namespace
}  // namespace gw::api
