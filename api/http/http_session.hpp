#pragma once
// One HTTP connection: reads a request's header within http.limits.header_timeout_ms, decides from
// the header alone whether to take its body (size, the memory budget for bodies, and for G-code
// programs auth, query and the planner's capacity), answers "100 Continue" only then, reads the body
// within read_timeout_ms, hands the request to the router, writes the response, keeps the connection
// alive when asked to, and passes WebSocket upgrades of /api/v1/ws to start_websocket_session. A
// G-code program body is streamed to the store's temporary file in chunks (written on the worker's
// upload thread), never held whole in memory. A streamed response body (a download) is written as
// chunks, one piece at a time. One request at a time (no pipelining).
// The session reports its phase to the connection table through its permit (waiting for a header,
// idle, reading a body, serving), so a waiting or slow connection can be shed for a newcomer.
// With http.tls, a TLS handshake comes first, within the header timeout.
// All I/O runs on the session's own strand (the socket's executor); owned by its pending
// operations (shared_from_this), tracked weakly by the connection table for shedding and stop().

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/steady_timer.hpp>

#include "api/common/api_context.hpp"
#include "api/common/body_budget.hpp"
#include "api/common/connection_permit.hpp"
#include "api/common/http_stream.hpp"
#include "api/common/net.hpp"
#include "api/http/router.hpp"
#include "gateway/common/metrics.hpp"

namespace gw::api {

class gcode_program_intake;

class http_session : public std::enable_shared_from_this<http_session>, public tracked_connection {
  public:
    // Without a `permit` the connection limits were reached: answer 503 (`refusal` says why) and
    // close. The permit moves into the WebSocket session at an upgrade.
    http_session(session_socket&& socket, std::shared_ptr<api_context> ctx,
                 std::shared_ptr<connection_permit> permit, std::shared_ptr<body_budget> bodies,
                 std::string refusal = {});
    ~http_session() override;

    void run();
    // Closes the socket (from any thread); pending operations end with operation_aborted.
    void close() override;
    // Closes the socket unless a request is being served by then (from any thread).
    void shed() override;

  private:
    void on_run();
    void on_handshake(beast::error_code ec);
    void do_read();
    void on_first_bytes(beast::error_code ec, std::size_t bytes);
    void do_read_header();
    void on_header(beast::error_code ec, std::size_t bytes);
    // Sends "100 Continue" if the client waits for it, then `next`.
    template <typename Next>
    void continue_then(Next next);
    void do_read_body();
    void on_read(beast::error_code ec, std::size_t bytes);
    void start_upload(std::shared_ptr<gcode_program_intake> intake, std::uint64_t limit);
    void do_read_chunk();
    void on_chunk(beast::error_code ec, std::size_t bytes);
    void on_chunk_written(std::optional<string_response> error, bool last);
    void drop_upload();
    // A client mistake found while reading (limits, unparseable): answered, then the connection closes.
    bool answer_read_error(beast::error_code ec, const http::request_header<>& header);
    void refuse(problem p, const http::request_header<>& header, const std::string& route);
    // A HALT (one controller, or all), served from its header alone: before any body limit, upload or
    // body budget, and on a HALT reserve slot. A body it carries is not read: the connection closes.
    void serve_halt(const http::request_header<>& header, bool body_follows);
    void on_handled(routed_response r);
    void count_answer(unsigned status, const std::string& route);
    void do_write(string_response res, const std::string& route, bool close_after);
    struct outgoing_stream;
    void do_write_stream(string_response head, std::shared_ptr<streamed_body> body, const std::string& route,
                         bool close_after);
    void next_piece(const std::shared_ptr<outgoing_stream>& out, bool close_after);
    void on_piece(const std::shared_ptr<outgoing_stream>& out, bool close_after,
                  std::optional<std::string> piece, bool last);
    void end_stream(const std::shared_ptr<outgoing_stream>& out, bool close_after);
    void on_write(bool close_after, beast::error_code ec, std::size_t bytes);
    void do_close();
    void do_linger();
    void on_linger(beast::error_code ec, std::size_t bytes);
    void fail(beast::error_code ec, const char* what);
    void set_phase(connection_phase phase);

    http_stream stream_;  // plain or TLS (http.tls)
    beast::flat_buffer buffer_;
    std::shared_ptr<api_context> ctx_;
    std::shared_ptr<connection_permit> permit_;
    std::shared_ptr<body_budget> bodies_;
    std::string refusal_;  // not empty: the limits refused this connection (a HALT reserve slot)
    net::ip::address peer_address_;
    std::string client_address_;  // the request's client (the peer, or whom a trusted proxy names), for the
                                  // audit trail
    std::optional<boost::asio::steady_timer> reserve_timer_;  // a reserve slot's wait for its request
    bool reserve_expired_ = false;
    bool first_request_ = true;
    connection_phase phase_ = connection_phase::awaiting_header;  // serving: never shed
    std::optional<http::request_parser<http::empty_body>> header_parser_;
    std::optional<http::request_parser<http::string_body>> parser_;
    std::optional<http::request_parser<http::buffer_body>> upload_parser_;
    std::shared_ptr<gcode_program_intake> intake_;  // the G-code program being streamed in
    std::vector<char> chunk_;                       // its body's bytes on their way to the file
    body_budget::reservation body_memory_;          // this request's share of max_buffered_body_mb
    std::uint64_t body_limit_ = 0;                  // of the request being read (its route's)
    std::shared_ptr<void> response_;                // the message being written (alive during async_write)
    std::size_t lingered_ = 0;                      // bytes discarded after the response, before closing
    std::string request_id_;
    std::string method_;
    std::chrono::steady_clock::time_point started_;

    // The request metrics of the last route, method and status answered: a client that repeats its
    // request on a kept-alive connection (a poll) updates them without a lookup.
    struct request_series {
        std::string route, method;
        unsigned status = 0;
        metrics::handle requests, duration;
    };
    request_series last_series_;
};

}  // namespace gw::api
