#include "api/http/server.hpp"

#include <chrono>
#include <memory>
#include <stdexcept>
#include <sys/socket.h>
#include <sys/time.h>
#include <thread>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/common/metrics.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/version.hpp"

namespace gw::api {
namespace {

using tcp = net::ip::tcp;

// The real server object on a real loopback socket, without controllers; a Beast client.
class server_test : public ::testing::Test {
  protected:
    server_test() : registry_(io_.get_executor(), registry_options{}) {}
    ~server_test() override {
        if (server_) server_->stop();
        work_.reset();
        if (hub_) hub_->stop();
        io_.stop();
        if (thread_.joinable()) thread_.join();
    }

    void start(gateway_config config) {
        config.http.port = 0;
        hub_ = event_hub::create(io_.get_executor());
        server_ = std::make_unique<server>(io_.get_executor(), config, registry_, hub_,
                                           std::make_shared<metrics>());
        server_->start();
        thread_ = std::thread([this] { io_.run(); });
    }

    tcp::socket connect() {
        tcp::socket s(client_io_);
        s.connect(server_->local_endpoint());
        return s;
    }

    // A connection from another loopback address (Linux routes all of 127/8 to lo).
    tcp::socket connect_from(const char* address) {
        tcp::socket s(client_io_);
        s.open(tcp::v4());
        s.bind(tcp::endpoint(net::ip::make_address(address), 0));
        s.connect(server_->local_endpoint());
        return s;
    }

    // A blocking read that waits this long at most (a test that fails must not hang).
    static void limit_reads(tcp::socket& s, std::chrono::seconds within) {
        timeval tv{static_cast<time_t>(within.count()), 0};
        ::setsockopt(s.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    }

    // Reads until the server closes: true when it did within `within` (false: still open).
    static bool closed_within(tcp::socket& s, std::chrono::milliseconds within) {
        s.non_blocking(true);
        const auto deadline = std::chrono::steady_clock::now() + within;
        char buf[4096];
        while (std::chrono::steady_clock::now() < deadline) {
            beast::error_code ec;
            s.read_some(net::buffer(buf), ec);
            if (ec && ec != net::error::would_block) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        return false;
    }

    static http::response<http::string_body> get(tcp::socket& s, const std::string& target) {
        http::request<http::string_body> req{http::verb::get, target, 11};
        req.set(http::field::host, "127.0.0.1");
        http::write(s, req);
        beast::flat_buffer buffer;
        http::response<http::string_body> res;
        http::read(s, buffer, res);
        return res;
    }

    net::io_context io_;
    net::executor_work_guard<net::io_context::executor_type> work_{io_.get_executor()};
    controller_registry registry_;
    std::shared_ptr<event_hub> hub_;
    std::unique_ptr<server> server_;
    std::thread thread_;
    net::io_context client_io_;
};

TEST_F(server_test, answers_on_a_free_port_and_keeps_the_connection_alive) {
    start(gateway_config{});
    ASSERT_NE(server_->local_endpoint().port(), 0);
    auto s = connect();
    for (int i = 0; i < 3; ++i) {
        auto res = get(s, "/api/v1/health");
        EXPECT_EQ(res.result(), http::status::ok);
        // MQTT is off: no link to tell of.
        EXPECT_EQ(nlohmann::json::parse(res.body()),
                  nlohmann::json({{"status", "ok"}, {"version", gw::version}, {"mqtt", nullptr}}));
        EXPECT_TRUE(res.keep_alive());
        EXPECT_FALSE(res["X-Request-Id"].empty());
    }
    auto ready = get(s, "/api/v1/ready");
    EXPECT_EQ(ready.result(), http::status::ok);  // no controllers: trivially ready
}

TEST_F(server_test, stop_closes_idle_connections) {
    start(gateway_config{});
    auto s = connect();
    EXPECT_EQ(get(s, "/api/v1/health").result(), http::status::ok);
    server_->stop();
    // The server closes its end: the next read sees EOF (or a reset), never a hang.
    char byte;
    beast::error_code ec;
    s.read_some(net::buffer(&byte, 1), ec);
    EXPECT_TRUE(ec == net::error::eof || ec == net::error::connection_reset) << ec.message();
}

TEST_F(server_test, one_connection_over_the_limit_gets_503) {
    gateway_config config;
    config.http.limits.max_connections = 2;
    start(config);
    auto a = connect();
    auto b = connect();
    EXPECT_EQ(get(a, "/api/v1/health").result(), http::status::ok);  // both are sessions by now
    EXPECT_EQ(get(b, "/api/v1/health").result(), http::status::ok);
    // Over the limit, the connection gets a HALT reserve slot: its request is answered 503 unless it
    // is a HALT (api_halt checks that one).
    auto c = connect();
    auto res = get(c, "/api/v1/health");
    EXPECT_EQ(res.result(), http::status::service_unavailable);
    EXPECT_EQ(res[http::field::content_type], "application/problem+json");
    EXPECT_EQ(nlohmann::json::parse(res.body())["type"],
              "https://asi-gateway.dev/problems/too-many-connections");
    EXPECT_FALSE(res.keep_alive());
}

TEST_F(server_test, websocket_connections_count_toward_the_limit) {
    gateway_config config;
    config.http.limits.max_connections = 2;
    start(config);
    auto open_ws = [this] {
        auto ws = std::make_unique<websocket::stream<tcp::socket>>(connect());
        ws->handshake("127.0.0.1", "/api/v1/ws");
        return ws;
    };
    auto a = open_ws();
    auto b = open_ws();
    // Both are upgraded: their HTTP sessions are gone, their slots are not.
    auto c = connect();
    auto res = get(c, "/api/v1/health");
    EXPECT_EQ(res.result(), http::status::service_unavailable);
    EXPECT_EQ(nlohmann::json::parse(res.body())["type"],
              "https://asi-gateway.dev/problems/too-many-connections");

    // Closing one frees its slot once the server has finished it: poll, with a generous deadline.
    a->close(websocket::close_code::normal);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    http::status status = http::status::service_unavailable;
    while (std::chrono::steady_clock::now() < deadline) {
        auto d = connect();
        status = get(d, "/api/v1/health").result();
        if (status == http::status::ok) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    EXPECT_EQ(status, http::status::ok);
    EXPECT_TRUE(b->is_open());
}

TEST_F(server_test, a_header_that_does_not_end_is_closed_by_the_header_deadline) {
    gateway_config config;
    config.http.limits.header_timeout = std::chrono::milliseconds(300);
    start(config);
    auto slow = connect();
    net::write(slow, net::buffer(std::string_view("GET /api/v1/health HTTP/1.1\r\nHost: x\r\n")));
    auto idle = connect();
    EXPECT_EQ(get(idle, "/api/v1/health").result(), http::status::ok);
    // The read timeout (30 s) would be far away; the header deadline is not.
    EXPECT_TRUE(closed_within(slow, std::chrono::seconds(20)));
    // A keep-alive connection between requests is not waiting for a header: it stays.
    EXPECT_EQ(get(idle, "/api/v1/health").result(), http::status::ok);
}

TEST_F(server_test, a_new_client_sheds_a_connection_that_only_waits_for_its_header) {
    gateway_config config;
    config.http.limits.max_connections = 2;
    start(config);
    auto a = connect_from("127.0.0.2");
    auto b = connect_from("127.0.0.3");
    net::write(a, net::buffer(std::string_view("GET /api/v1/health HTTP/1.1\r\n")));  // and no more
    net::write(b, net::buffer(std::string_view("GET /api/v1/health HTTP/1.1\r\n")));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // both accepted by now
    auto c = connect();
    EXPECT_EQ(get(c, "/api/v1/health").result(), http::status::ok);
    // The one shed was waiting longest: a.
    EXPECT_TRUE(closed_within(a, std::chrono::seconds(20)));
    EXPECT_FALSE(closed_within(b, std::chrono::milliseconds(100)));
}

TEST_F(server_test, a_body_that_trickles_is_shed_once_patience_is_over) {
    gateway_config config;
    config.http.limits.max_connections = 2;
    config.http.limits.header_timeout = std::chrono::milliseconds(300);  // also the patience
    start(config);
    // Admitted from its header (a loopback Host, a JSON body): only its body is slow.
    const std::string_view head =
        "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
        "Content-Length: 100\r\n\r\n{";
    auto a = connect_from("127.0.0.2");
    auto b = connect_from("127.0.0.3");
    net::write(a, net::buffer(head));
    net::write(b, net::buffer(head));
    std::this_thread::sleep_for(std::chrono::milliseconds(600));
    auto c = connect();
    limit_reads(c, std::chrono::seconds(20));
    EXPECT_EQ(get(c, "/api/v1/health").result(), http::status::ok);
    EXPECT_TRUE(closed_within(a, std::chrono::seconds(20)));  // the longer reader
}

TEST_F(server_test, one_address_cannot_take_every_slot) {
    gateway_config config;
    config.http.limits.max_connections = 8;  // an address may hold 7 of them
    start(config);
    std::vector<tcp::socket> held;
    for (int i = 0; i < 7; ++i) {
        held.push_back(connect_from("127.0.0.2"));
        EXPECT_EQ(get(held.back(), "/api/v1/health").result(), http::status::ok);  // served, then idle
    }
    auto over = connect_from("127.0.0.2");
    limit_reads(over, std::chrono::seconds(20));
    auto res = get(over, "/api/v1/health");
    EXPECT_EQ(res.result(), http::status::service_unavailable);
    EXPECT_EQ(nlohmann::json::parse(res.body())["type"],
              "https://asi-gateway.dev/problems/too-many-connections");
    EXPECT_EQ(res[http::field::retry_after], "1");
    auto other = connect();
    EXPECT_EQ(get(other, "/api/v1/health").result(), http::status::ok);
}

TEST_F(server_test, refuses_a_public_address_without_tokens) {
    gateway_config config;
    config.http.listen_address = "0.0.0.0";
    hub_ = event_hub::create(io_.get_executor());
    server srv(io_.get_executor(), config, registry_, hub_, std::make_shared<metrics>());
    EXPECT_THROW(srv.start(), std::runtime_error);
    config.auth.tokens = {{"t", hash_token("a-token-of-enough-length"), role::viewer}};
    config.http.port = 0;
    server with_tokens(io_.get_executor(), config, registry_, hub_, std::make_shared<metrics>());
    EXPECT_NO_THROW(with_tokens.start());
    with_tokens.stop();
}

}  // namespace
}  // namespace gw::api
