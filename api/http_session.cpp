#include "api/http_session.hpp"

#include <spdlog/logger.h>

#include "api/auth.hpp"
#include "api/gcode_requests.hpp"
#include "api/listener.hpp"
#include "api/request_id.hpp"
#include "gateway/metrics.hpp"
#if GW_API_HAS_WEBSOCKET
#include "api/websocket_session.hpp"
#endif

namespace gw::api {

namespace {

constexpr std::string_view websocket_path = "/api/v1/ws";

bool is_http_parse_error(const beast::error_code& ec) {
    return ec.category() == beast::error_code(http::error::body_limit).category();
}

}  // namespace

http_session::http_session(net::ip::tcp::socket&& socket, std::shared_ptr<api_context> ctx,
                           std::weak_ptr<listener> owner, std::shared_ptr<connection_permit> permit)
    : stream_(std::move(socket)),
      ctx_(std::move(ctx)),
      owner_(std::move(owner)),
      permit_(std::move(permit)),
      reject_(!permit_) {
    ctx_->metrics->increment("gw_http_connections", {}, 1);
}

http_session::~http_session() {
    ctx_->metrics->increment("gw_http_connections", {}, -1);
    if (auto l = owner_.lock(); l && id_ != 0) l->remove(id_);
}

void http_session::run() {
    // Onto the session's strand before the first operation (the socket was accepted on its strand).
    net::dispatch(stream_.get_executor(),
                  beast::bind_front_handler(&http_session::on_run, shared_from_this()));
}

void http_session::close() {
    net::post(stream_.get_executor(), [self = shared_from_this()] {
        beast::error_code ignored;
        self->stream_.socket().shutdown(net::ip::tcp::socket::shutdown_both, ignored);
        self->stream_.close();
    });
}

void http_session::on_run() {
    if (reject_) {
        request_id_ = make_request_id();
        method_ = "-";
        started_ = std::chrono::steady_clock::now();
        auto p = make_problem(http_error::too_many_connections,
                              "the gateway has " + std::to_string(ctx_->limits.max_connections) +
                                  " connections open; try again later");
        return do_write(problem_response(std::move(p), 11, false, "/", request_id_), "unmatched", true);
    }
    do_read();
}

void http_session::do_read() {
    // A fresh parser per request, each with the configured limits.
    parser_.emplace();
    parser_->header_limit(
        static_cast<std::uint32_t>(std::min<std::size_t>(ctx_->limits.max_header_bytes, UINT32_MAX)));
    // The header first: the body limit depends on the route (G-code programs may be bigger). Beast checks
    // Content-Length against the limit while it reads the header, so that read gets the largest limit
    // of any route; on_header narrows it to the route's.
    body_limit_ = ctx_->limits.max_body_bytes;
    parser_->body_limit(std::max<std::uint64_t>(body_limit_, max_gcode_body_bytes(*ctx_)));
    stream_.expires_after(ctx_->limits.read_timeout);
    http::async_read_header(stream_, buffer_, *parser_,
                            beast::bind_front_handler(&http_session::on_header, shared_from_this()));
}

void http_session::on_header(beast::error_code ec, std::size_t bytes) {
    if (ec) return on_read(ec, bytes);
    const auto& header = parser_->get();
    body_limit_ =
        gcode_body_limit(*ctx_, header.method(), header.target()).value_or(ctx_->limits.max_body_bytes);
    if (auto length = parser_->content_length(); length && *length > body_limit_)
        return on_read(http::error::body_limit, bytes);
    parser_->body_limit(body_limit_);  // chunked bodies are counted as they come
    // "Expect: 100-continue" (curl sends it for bodies over 1 MiB): say go on rather than make the client
    // wait a second. Over the limit, the 413 goes out when the body read stops.
    if (beast::iequals(header[http::field::expect], "100-continue") && !parser_->is_done()) {
        auto go_on =
            std::make_shared<http::response<http::empty_body>>(http::status::continue_, header.version());
        return http::async_write(stream_, *go_on,
                                 [self = shared_from_this(), go_on](beast::error_code wec, std::size_t) {
                                     if (wec) return self->fail(wec, "write 100-continue");
                                     self->do_read_body();
                                 });
    }
    do_read_body();
}

void http_session::do_read_body() {
    http::async_read(stream_, buffer_, *parser_,
                     beast::bind_front_handler(&http_session::on_read, shared_from_this()));
}

void http_session::on_read(beast::error_code ec, std::size_t) {
    if (ec == http::error::end_of_stream) return do_close();
    started_ = std::chrono::steady_clock::now();
    if (ec == http::error::body_limit || ec == http::error::header_limit || (ec && is_http_parse_error(ec))) {
        // A client mistake: answer it, then close (the rest of the stream cannot be trusted).
        const auto& header = parser_->get();
        auto it = header.find("X-Request-Id");
        request_id_ = request_id_for(it == header.end() ? std::string_view{} : std::string_view(it->value()));
        method_ = std::string(header.method_string());
        problem p = ec == http::error::body_limit
                        ? make_problem(http_error::payload_too_large,
                                       "the body is larger than " + std::to_string(body_limit_) + " bytes")
                    : ec == http::error::header_limit
                        ? make_problem(http_error::header_too_large,
                                       "the headers are larger than " +
                                           std::to_string(ctx_->limits.max_header_bytes) + " bytes")
                        : make_problem(http_error::bad_request, "unparseable HTTP request: " + ec.message());
        std::string target = header.target().empty() ? "/" : std::string(header.target());
        return do_write(problem_response(std::move(p), header.version() ? header.version() : 11, false,
                                         target, request_id_),
                        "unmatched", true);
    }
    if (ec) return fail(ec, "read");

    stream_.expires_never();  // an operation may legitimately take long (move with wait)
    auto& req = parser_->get();
    auto it = req.find("X-Request-Id");
    request_id_ = request_id_for(it == req.end() ? std::string_view{} : std::string_view(it->value()));
    method_ = std::string(req.method_string());

    if (websocket::is_upgrade(req)) {
        if (target_path(req.target()) != websocket_path) {
            return do_write(
                problem_response(make_problem(http_error::not_found, "WebSocket upgrades go to /api/v1/ws"),
                                 req, request_id_),
                "unmatched", !req.keep_alive());
        }
        problem p;
        std::optional<auth_identity> who;
        auto query_token = access_token_parameter(req.target());
        if (query_token && req.find(http::field::authorization) == req.end()) {
            // Browsers cannot set Authorization on a WebSocket: the token may come in the query.
            who = authenticate_token(ctx_->auth, *query_token, p);
            req.target(redact_access_token(req.target()));  // from here on the target may be logged
        } else {
            who = identify(*ctx_, req, p);
        }
        if (!who) return do_write(problem_response(std::move(p), req, request_id_), "/api/v1/ws", true);
#if GW_API_HAS_WEBSOCKET
        ctx_->metrics->increment("gw_http_requests_total",
                                 {{"route", "/api/v1/ws"}, {"method", method_}, {"status", "101"}});
        return start_websocket_session(std::move(stream_), parser_->release(), ctx_, std::move(*who),
                                       std::move(permit_));
#else
        return do_write(problem_response(make_problem(http_error::not_implemented,
                                                      "WebSocket sessions are not available in this build"),
                                         req, request_id_),
                        "/api/v1/ws", true);
#endif
    }

    handle_request(ctx_, parser_->release(), request_id_, stream_.get_executor(),
                   beast::bind_front_handler(&http_session::on_handled, shared_from_this()));
}

void http_session::on_handled(routed_response r) {
    const bool close_after = !r.response.keep_alive();
    do_write(std::move(r.response), std::move(r.route), close_after);
}

void http_session::do_write(string_response res, std::string route, bool close_after) {
    if (close_after) res.keep_alive(false);
    const auto status = res.result_int();
    auto elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    ctx_->metrics->increment("gw_http_requests_total",
                             {{"route", route}, {"method", method_}, {"status", std::to_string(status)}});
    ctx_->metrics->observe("gw_http_request_duration_seconds", {{"route", route}}, elapsed);
    if (status >= 500)
        ctx_->log->warn("{} {} -> {} [{}]", method_, route, status, request_id_);
    else
        ctx_->log->debug("{} {} -> {} [{}] {:.1f} ms", method_, route, status, request_id_, elapsed * 1e3);

    // A write must not hang forever on a client that stopped reading.
    stream_.expires_after(ctx_->limits.read_timeout);
    auto msg = std::make_shared<string_response>(std::move(res));
    response_ = msg;
    http::async_write(stream_, *msg,
                      beast::bind_front_handler(&http_session::on_write, shared_from_this(), close_after));
}

void http_session::on_write(bool close_after, beast::error_code ec, std::size_t) {
    response_.reset();
    if (ec) return fail(ec, "write");
    if (close_after) return do_linger();
    do_read();
}

// Closing a socket with unread input sends RST, which can destroy the response we just sent (a 413
// while the client is still sending its body). So: half-close, then read and discard what is left,
// bounded in bytes and time, then close.
void http_session::do_linger() {
    beast::error_code ignored;
    stream_.socket().shutdown(net::ip::tcp::socket::shutdown_send, ignored);
    stream_.expires_after(std::chrono::seconds(2));
    buffer_.clear();
    stream_.async_read_some(buffer_.prepare(16 * 1024),
                            beast::bind_front_handler(&http_session::on_linger, shared_from_this()));
}

void http_session::on_linger(beast::error_code ec, std::size_t bytes) {
    lingered_ += bytes;
    if (ec || lingered_ > 4 * 1024 * 1024) {
        stream_.close();
        return;
    }
    stream_.async_read_some(buffer_.prepare(16 * 1024),
                            beast::bind_front_handler(&http_session::on_linger, shared_from_this()));
}

void http_session::do_close() {
    beast::error_code ignored;
    stream_.socket().shutdown(net::ip::tcp::socket::shutdown_send, ignored);
    stream_.close();
}

void http_session::fail(beast::error_code ec, const char* what) {
    // Expected ends of a connection are not worth a log line.
    if (ec == net::error::operation_aborted || ec == beast::error::timeout ||
        ec == net::error::connection_reset || ec == net::error::eof || ec == net::error::broken_pipe ||
        ec == net::error::bad_descriptor)
        return do_close();
    ctx_->log->debug("http session {}: {}", what, ec.message());
    do_close();
}

}  // namespace gw::api
