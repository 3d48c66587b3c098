#include "api/calls/operation_requests.hpp"

#include <optional>

#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>

#include "api/calls/calls.hpp"
#include "gateway/controllers/controller_registry.hpp"

namespace gw::api {
namespace {

using nlohmann::json;

// A registry without controllers: bodies are judged before the registry is asked, so a valid body
// ends as unknown_controller (404) and an invalid one as invalid_value (422) naming the field.
class operation_requests_test : public ::testing::Test {
  protected:
    operation_requests_test()
        : registry_(io_.get_executor(), registry_options{}),
          ctx_{io_.get_executor(), registry_, nullptr, nullptr, {}, {}, nullptr, nullptr, nullptr} {}

    api_outcome run(std::string_view op, const json& body, gw::role role = gw::role::admin) {
        std::optional<api_outcome> out;
        // Through dispatch_call, as every transport: it checks the role, run_operation the rest.
        dispatch_call(ctx_, caller{"ada", role, "rid-1", {}}, operation_call{"stage1", std::string(op), body},
                      [&](api_outcome o) { out = std::move(o); });
        EXPECT_FALSE(out) << "the handler must not run inline";
        io_.restart();
        io_.run();
        EXPECT_TRUE(out);
        return out ? std::move(*out) : api_outcome{};
    }

    boost::asio::io_context io_;
    controller_registry registry_;
    api_context ctx_;
};

struct body_case {
    const char* op;
    const char* body;
    unsigned status;    // 404: the body was accepted (no such controller); else the problem status
    const char* field;  // for 422
};

TEST_F(operation_requests_test, bodies_are_parsed_strictly) {
    const body_case cases[] = {
        {"move", R"({"axes":{"X":1000.5,"y":-2}})", 404, ""},
        {"move", R"({"axes":{"X":1},"mode":"relative","wait":true,"timeout_ms":5000})", 404, ""},
        {"move", R"({})", 422, "axes"},
        {"move", R"({"axes":{}})", 422, "axes"},
        {"move", R"({"axes":{"X":"1"}})", 422, "axes.X"},
        {"move", R"({"axes":{"XY":1}})", 422, "axes.XY"},
        {"move", R"({"axes":{"X":1,"x":2}})", 422, "axes.x"},
        {"move", R"({"axes":{"X":1},"speed":2})", 422, "speed"},
        {"move", R"({"axes":{"X":1},"mode":"sideways"})", 422, "mode"},
        {"move", R"({"axes":{"X":1},"wait":"yes"})", 422, "wait"},
        {"move", R"({"axes":{"X":1},"timeout_ms":0})", 422, "timeout_ms"},
        {"move", R"({"axes":{"X":1},"timeout_ms":1.5})", 422, "timeout_ms"},
        {"move", R"([1,2])", 422, ""},
        {"halt", R"(null)", 404, ""},
        {"halt", R"({})", 404, ""},
        {"halt", R"({"now":true})", 422, "now"},
        {"zero", R"({"all":1})", 422, "all"},
        {"home", R"({})", 404, ""},
        {"home", R"({"axes":["X","Z"]})", 404, ""},
        {"home", R"({"axes":[]})", 422, "axes"},
        {"home", R"({"axes":["X","X"]})", 422, "axes[1]"},
        {"home", R"({"axes":[1]})", 422, "axes[0]"},
        {"here", R"({"axes":{"X":0}})", 404, ""},
        {"here", R"({"axes":[0]})", 422, "axes"},
        {"speed", R"({"axes":{"X":2.5}})", 404, ""},
        {"speed", R"({"axes":{"X":true}})", 422, "axes.X"},
        {"ttl", R"({"in0_mode":1,"out0_mode":2})", 404, ""},
        {"ttl", R"({"output_high":true})", 404, ""},
        {"ttl", R"({})", 422, ""},
        {"ttl", R"({"in0_mode":-1})", 422, "in0_mode"},
        {"ttl", R"({"in0_mode":"1"})", 422, "in0_mode"},
        {"dac", R"({"volts":2.5})", 404, ""},
        {"dac", R"({})", 422, "volts"},
        {"dac", R"({"volts":null})", 422, "volts"},
        {"led", R"({"percent":50,"channel":"y"})", 404, ""},
        {"led", R"({"percent":50,"channel":"XY"})", 422, "channel"},
        {"command", R"({"command":"W X Y"})", 404, ""},
        {"command", R"({"command":5})", 422, "command"},
        {"command", R"({})", 422, "command"},
    };
    for (const auto& c : cases) {
        auto out = run(c.op, json::parse(c.body));
        ASSERT_TRUE(out.error) << c.op << " " << c.body;
        EXPECT_EQ(out.error->status, c.status) << c.op << " " << c.body << ": " << out.error->detail;
        EXPECT_EQ(out.error->request_id, "rid-1");
        if (c.status == 422) {
            EXPECT_EQ(out.error->field, c.field) << c.op << " " << c.body;
        }
    }
}

TEST_F(operation_requests_test, roles_are_checked_before_the_body) {
    auto out = run("move", json{{"axes", {{"X", 1}}}}, gw::role::viewer);
    ASSERT_TRUE(out.error);
    EXPECT_EQ(out.error->status, 403u);
    out = run("command", json{{"command", "W X"}}, gw::role::operator_);
    ASSERT_TRUE(out.error);
    EXPECT_EQ(out.error->status, 403u);
    out = run("halt", json::object(), gw::role::operator_);
    ASSERT_TRUE(out.error);
    EXPECT_EQ(out.error->status, 404u);  // allowed, and then: no such controller
}

TEST_F(operation_requests_test, halt_takes_the_configured_role_viewer_by_default) {
    auto out = run("halt", json::object(), gw::role::viewer);
    ASSERT_TRUE(out.error);
    EXPECT_EQ(out.error->status, 404u);  // a viewer may stop a stage: allowed, then no such controller
    ctx_.auth.halt_role = gw::role::operator_;
    out = run("halt", json::object(), gw::role::viewer);
    ASSERT_TRUE(out.error);
    EXPECT_EQ(out.error->status, 403u);
    EXPECT_NE(out.error->detail.find("operator"), std::string::npos) << out.error->detail;
}

TEST_F(operation_requests_test, unknown_operation_is_not_found) {
    auto out = run("fly", json::object());
    ASSERT_TRUE(out.error);
    EXPECT_EQ(out.error->status, 404u);
    EXPECT_FALSE(is_operation("fly"));
    EXPECT_TRUE(is_operation("led"));
    EXPECT_EQ(operation_names().size(), 12u);
    EXPECT_TRUE(is_operation("crisp") && is_operation("autofocus"));
}

}  // namespace
}  // namespace gw::api
