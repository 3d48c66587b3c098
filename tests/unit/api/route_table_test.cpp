#include "api/http/route_table.hpp"

#include <optional>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "api/common/path_segments.hpp"
#include "gateway/controllers/controller_registry.hpp"

namespace gw::api {
namespace {

using nlohmann::json;

TEST(path_segments, keeps_empty_segments_so_doubled_slashes_never_match) {
    using v = std::vector<std::string_view>;
    EXPECT_EQ(path_segments("/api/v1/jobs/j-1"), (v{"api", "v1", "jobs", "j-1"}));
    EXPECT_EQ(path_segments("/a//b"), (v{"a", "", "b"}));
    EXPECT_EQ(path_segments("/a/"), (v{"a", ""}));
    EXPECT_EQ(path_segments("/"), v{});
    EXPECT_EQ(path_segments(""), v{});
}

// A table over a context with two tokens; each handler records what it was given and answers 200.
class route_table_test : public ::testing::Test {
  protected:
    route_table_test() : registry_(io_.get_executor(), registry_options{}), ctx_(make_context()) {}

    std::shared_ptr<api_context> make_context() {
        auto c = std::make_shared<api_context>(
            api_context{io_.get_executor(), registry_, nullptr, nullptr, {}, {}, nullptr, nullptr, nullptr});
        c->auth.tokens = {{"ada", hash_token("viewer-token"), gw::role::viewer},
                          {"bob", hash_token("operator-token"), gw::role::operator_}};
        return c;
    }

    route_table table() {
        auto record = [this](request_context& c) {
            handled.push_back(c.route);
            params = c.params;
            who = c.who ? c.who->name : "";
            c.reply_json(http::status::ok, json::object());
        };
        return route_table({
            {http::verb::get, "/api/v1/health", std::nullopt, record},
            {http::verb::get, "/api/v1/things/{id}", gw::role::viewer, record},
            {http::verb::delete_, "/api/v1/things/{id}", gw::role::operator_, record},
            {http::verb::post, "/api/v1/things/{id}/parts/{part}", gw::role::viewer, record},
        });
    }

    // Dispatches one request; the response and the route it was counted under.
    routed_response call(http::verb method, const std::string& target, const std::string& token = "") {
        string_request req{method, target, 11};
        if (!token.empty()) req.set(http::field::authorization, "Bearer " + token);
        std::optional<routed_response> out;
        request_context c{ctx_, std::move(req), "rid-1", io_.get_executor(),
                          [&out](routed_response r) { out = std::move(r); }};
        table().dispatch(c);
        EXPECT_TRUE(out.has_value());
        return out ? std::move(*out) : routed_response{};
    }

    static json body(const routed_response& r) { return json::parse(r.response.body()); }

    boost::asio::io_context io_;
    controller_registry registry_;
    std::shared_ptr<api_context> ctx_;
    std::vector<std::string> handled;
    std::vector<std::string> params;
    std::string who;
};

TEST_F(route_table_test, a_public_route_needs_no_token) {
    auto r = call(http::verb::get, "/api/v1/health");
    EXPECT_EQ(r.response.result_int(), 200);
    EXPECT_EQ(r.route, "/api/v1/health");
    EXPECT_EQ(who, "");
    EXPECT_EQ(r.response["X-Request-Id"], "rid-1");
    EXPECT_EQ(r.response[http::field::cache_control], "no-store");
}

TEST_F(route_table_test, parameters_come_in_order_and_the_route_is_the_template) {
    auto r = call(http::verb::post, "/api/v1/things/t7/parts/p2?x=1", "viewer-token");
    EXPECT_EQ(r.response.result_int(), 200);
    EXPECT_EQ(r.route, "/api/v1/things/{id}/parts/{part}");
    EXPECT_EQ(params, (std::vector<std::string>{"t7", "p2"}));
    EXPECT_EQ(who, "ada");
}

TEST_F(route_table_test, no_template_matches_404_unmatched) {
    for (const char* target : {"/api/v1/thing", "/api/v1/things/", "/api/v1/things//parts/p",
                               "/api/v1/things/t/x", "/elsewhere"}) {
        auto r = call(http::verb::get, target, "viewer-token");
        EXPECT_EQ(r.response.result_int(), 404) << target;
        EXPECT_EQ(r.route, "unmatched") << target;
        EXPECT_EQ(body(r)["type"], std::string(problem_type_base) + "not-found") << target;
    }
    EXPECT_TRUE(handled.empty());
}

TEST_F(route_table_test, a_template_without_this_method_405_with_allow) {
    auto r = call(http::verb::put, "/api/v1/things/t7", "operator-token");
    EXPECT_EQ(r.response.result_int(), 405);
    EXPECT_EQ(r.response[http::field::allow], "GET, DELETE");
    EXPECT_EQ(r.route, "/api/v1/things/{id}");
    EXPECT_TRUE(handled.empty());
}

TEST_F(route_table_test, the_role_is_checked_before_the_handler_runs) {
    EXPECT_EQ(call(http::verb::get, "/api/v1/things/t7").response.result_int(), 401);
    EXPECT_EQ(call(http::verb::get, "/api/v1/things/t7", "wrong").response.result_int(), 401);
    auto forbidden = call(http::verb::delete_, "/api/v1/things/t7", "viewer-token");
    EXPECT_EQ(forbidden.response.result_int(), 403);
    EXPECT_EQ(forbidden.route, "/api/v1/things/{id}");
    EXPECT_TRUE(handled.empty());
    EXPECT_EQ(call(http::verb::delete_, "/api/v1/things/t7", "operator-token").response.result_int(), 200);
    EXPECT_EQ(who, "bob");
    EXPECT_EQ(handled, std::vector<std::string>{"/api/v1/things/{id}"});
}

}  // namespace
}  // namespace gw::api
