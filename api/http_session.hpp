#pragma once
// One HTTP connection: reads requests with header/body limits and a read timeout, hands each to the
// router, writes the response, keeps the connection alive when asked to, and passes WebSocket
// upgrades of /api/v1/ws to start_websocket_session. One request at a time (no pipelining).
// All I/O runs on the session's own strand (the socket's executor); owned by its pending
// operations (shared_from_this), tracked weakly by the listener for stop().

#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "api/api_context.hpp"
#include "api/connection_permit.hpp"
#include "api/net.hpp"
#include "api/router.hpp"

namespace gw::api {

class listener;

class http_session : public std::enable_shared_from_this<http_session> {
  public:
    // Without a `permit` the connection limit was reached: answer 503 and close. The permit moves
    // into the WebSocket session at an upgrade.
    http_session(net::ip::tcp::socket&& socket, std::shared_ptr<api_context> ctx,
                 std::weak_ptr<listener> owner, std::shared_ptr<connection_permit> permit);
    ~http_session();

    void run();
    void set_id(std::uint64_t id) { id_ = id; }
    // Closes the socket (from any thread); pending operations end with operation_aborted.
    void close();

  private:
    void on_run();
    void do_read();
    void on_header(beast::error_code ec, std::size_t bytes);
    void do_read_body();
    void on_read(beast::error_code ec, std::size_t bytes);
    void on_handled(routed_response r);
    void do_write(string_response res, std::string route, bool close_after);
    void on_write(bool close_after, beast::error_code ec, std::size_t bytes);
    void do_close();
    void do_linger();
    void on_linger(beast::error_code ec, std::size_t bytes);
    void fail(beast::error_code ec, const char* what);

    beast::tcp_stream stream_;
    beast::flat_buffer buffer_;
    std::shared_ptr<api_context> ctx_;
    std::weak_ptr<listener> owner_;
    std::shared_ptr<connection_permit> permit_;
    bool reject_;
    std::uint64_t id_ = 0;  // in the listener's table; 0 = not tracked
    std::optional<http::request_parser<http::string_body>> parser_;
    std::uint64_t body_limit_ = 0;  // of the request being read (its route's)
    std::shared_ptr<void> response_;
    std::size_t lingered_ = 0;  // bytes discarded after the response, before closing  // the message being
                                // written (kept alive during async_write)
    std::string request_id_;
    std::string method_;
    std::chrono::steady_clock::time_point started_;
};

}  // namespace gw::api
