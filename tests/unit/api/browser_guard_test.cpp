#include "api/http/browser_guard.hpp"

#include <gtest/gtest.h>

namespace gw::api {
namespace {

struct guard_case {
    http::verb method;
    const char* target;
    const char* host;
    const char* origin;  // nullptr: none
    bool upgrade;
    bool without_tokens;
    unsigned refused;  // 0: allowed, else the status
};

http::request_header<> request(const guard_case& c) {
    http::request_header<> r;
    r.method(c.method);
    r.target(c.target);
    if (c.host) r.set(http::field::host, c.host);
    if (c.origin) r.set(http::field::origin, c.origin);
    return r;
}

TEST(browser_guard, refuses_other_origins_and_foreign_hosts_but_never_a_halt) {
    using v = http::verb;
    const browser_rules rules{{"https://lab.example:8443"}, {"gateway.lab.example"}, true};
    const guard_case cases[] = {
        // Scripts send no Origin: only the Host is judged (no tokens).
        {v::post, "/api/v1/controllers/sim1/move", "127.0.0.1:8080", nullptr, false, true, 0},
        {v::post, "/api/v1/controllers/sim1/move", "localhost:8080", nullptr, false, true, 0},
        {v::post, "/api/v1/controllers/sim1/move", "[::1]:8080", nullptr, false, true, 0},
        {v::get, "/api/v1/controllers", "GATEWAY.lab.example", nullptr, false, true, 0},
        {v::get, "/api/v1/controllers", "evil.example:8080", nullptr, false, true, 421},
        {v::get, "/", "evil.example", nullptr, false, true, 421},
        {v::get, "/api/v1/controllers", "", nullptr, false, true, 421},
        {v::get, "/api/v1/controllers", "evil.example:8080", nullptr, false, false, 0},  // tokens: any Host
        // The page's own origin, an allowed one, another one.
        {v::post, "/api/v1/jobs", "127.0.0.1:8080", "http://127.0.0.1:8080", false, true, 0},
        {v::post, "/api/v1/jobs", "127.0.0.1:8080", "https://lab.example:8443", false, true, 0},
        {v::post, "/api/v1/jobs", "127.0.0.1:8080", "http://evil.example", false, true, 403},
        {v::post, "/api/v1/jobs", "127.0.0.1:8080", "http://127.0.0.1:9999", false, true, 403},
        {v::post, "/api/v1/jobs", "127.0.0.1:8080", "null", false, true, 403},
        {v::delete_, "/api/v1/controllers/sim1/lease", "127.0.0.1:8080", "http://evil.example", false, true,
         403},
        // Reading is no change; an upgrade is judged like one.
        {v::get, "/api/v1/controllers", "127.0.0.1:8080", "http://evil.example", false, true, 0},
        {v::get, "/api/v1/ws", "127.0.0.1:8080", "http://evil.example", true, true, 403},
        {v::get, "/api/v1/ws", "127.0.0.1:8080", "http://127.0.0.1:8080", true, true, 0},
        // A HALT is safe whoever asks, and wherever from.
        {v::post, "/api/v1/controllers/sim1/halt", "evil.example", "http://evil.example", false, true, 0},
        {v::post, "/api/v1/halt", "127.0.0.1:8080", "http://evil.example", false, true, 0},
    };
    for (const auto& c : cases) {
        const auto refused = browser_refusal(
            request(c), browser_rules{rules.allowed_origins, rules.allowed_hosts, c.without_tokens},
            c.upgrade);
        EXPECT_EQ(refused ? refused->status : 0u, c.refused)
            << c.target << " Host " << c.host << " Origin " << (c.origin ? c.origin : "-");
    }
}

TEST(browser_guard, host_names) {
    EXPECT_EQ(host_name_of("127.0.0.1:8080"), "127.0.0.1");
    EXPECT_EQ(host_name_of("[::1]:8080"), "::1");
    EXPECT_EQ(host_name_of("LocalHost"), "localhost");
    EXPECT_EQ(host_name_of("[::1"), "");
    EXPECT_TRUE(is_loopback_host("localhost"));
    EXPECT_TRUE(is_loopback_host("127.0.0.2"));
    EXPECT_TRUE(is_loopback_host("::1"));
    EXPECT_FALSE(is_loopback_host("localhost.evil.example"));
    EXPECT_FALSE(is_loopback_host("10.0.0.1"));
    EXPECT_FALSE(is_loopback_host(""));
}

}  // namespace
}  // namespace gw::api
