// http.trusted_proxies: which peers are reverse proxies, and the client a request comes from when
// one forwards it (X-Forwarded-For, read from the right).
#include "gateway/config/trusted_proxies.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw {
namespace {

namespace ip = boost::asio::ip;

TEST(trusted_proxies, addresses_and_networks_of_both_families) {
    auto p = trusted_proxies::parse({"127.0.0.1", "10.0.0.0/8", "fd00::/8", "::1"});
    ASSERT_TRUE(p) << p.error();
    struct row {
        const char* address;
        bool trusted;
    };
    const row rows[] = {
        {"127.0.0.1", true},
        {"127.0.0.2", false},
        {"10.1.2.3", true},
        {"11.0.0.1", false},
        {"fd12::5", true},
        {"fe80::1", false},
        {"::1", true},
        {"::ffff:10.9.9.9", true},  // an IPv4 peer of a dual-stack listener
        {"::ffff:8.8.8.8", false},
    };
    for (const auto& r : rows)
        EXPECT_EQ(p->contains(ip::make_address(r.address)), r.trusted) << r.address;
    EXPECT_TRUE(trusted_proxies::parse({})->empty());
}

TEST(trusted_proxies, refuses_what_is_neither_an_address_nor_a_network) {
    for (const std::string bad : {"localhost", "10.0.0.0/33", "10.0.0", "", "fd00::/129", "1.2.3.4/8/8"}) {
        auto p = trusted_proxies::parse({bad});
        ASSERT_FALSE(p) << bad;
        EXPECT_NE(p.error().find("must be an address"), std::string::npos) << p.error();
    }
}

TEST(trusted_proxies, the_client_is_the_rightmost_untrusted_forwarded_address) {
    auto p = *trusted_proxies::parse({"127.0.0.1", "10.0.0.0/8"});
    const auto proxy = ip::make_address("127.0.0.1");
    struct row {
        const char* peer;
        const char* forwarded_for;
        const char* client;
    };
    const row rows[] = {
        // From a trusted proxy: the address it appended.
        {"127.0.0.1", "192.0.2.7", "192.0.2.7"},
        // A chain of trusted proxies: skipped from the right.
        {"127.0.0.1", "192.0.2.7, 10.0.0.4", "192.0.2.7"},
        // What the client wrote itself (left of the proxy's entry) is not believed.
        {"127.0.0.1", "6.6.6.6, 192.0.2.7", "192.0.2.7"},
        {"127.0.0.1", " 2001:db8::1 ", "2001:db8::1"},
        // No header, or nothing readable at its right end: the proxy itself.
        {"127.0.0.1", "", "127.0.0.1"},
        {"127.0.0.1", "unknown", "127.0.0.1"},
        {"127.0.0.1", "192.0.2.7, 10.0.0.4, garbage", "127.0.0.1"},
        // Every hop trusted: the leftmost one.
        {"127.0.0.1", "10.0.0.9, 10.0.0.4", "10.0.0.9"},
        // Not from a proxy: the header is anyone's to write, so it is ignored.
        {"192.0.2.50", "1.2.3.4", "192.0.2.50"},
        {"::ffff:192.0.2.50", "", "192.0.2.50"},
    };
    for (const auto& r : rows)
        EXPECT_EQ(p.client_address(ip::make_address(r.peer), r.forwarded_for), r.client)
            << r.peer << " / " << r.forwarded_for;
    EXPECT_EQ(trusted_proxies{}.client_address(proxy, "192.0.2.7"), "127.0.0.1");  // none configured
}

}  // namespace
}  // namespace gw
