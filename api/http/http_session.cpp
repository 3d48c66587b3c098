#include "api/http/http_session.hpp"

#include <spdlog/logger.h>

#include "api/calls/halt_requests.hpp"
#include "api/common/auth.hpp"
#include "api/common/auth_failure_log.hpp"
#include "api/common/gcode_worker.hpp"
#include "api/common/request_id.hpp"
#include "api/http/browser_guard.hpp"
#include "api/http/gcode_requests.hpp"
#include "api/http/tls_server_context.hpp"
#include "api/ws/websocket_protocol.hpp"
#include "api/ws/websocket_session.hpp"
#include "gateway/common/metrics.hpp"

namespace gw::api {

namespace {

// A connection on a HALT reserve slot (the limits refused it) sends its request at once or is answered
// 503: a HALT comes right after the connection, and a silent one must not keep the slot.
constexpr std::chrono::milliseconds reserve_header_timeout{1000};

// A streamed G-code body passes through this much memory at a time.
constexpr std::size_t upload_chunk_bytes = std::size_t{64} * 1024;

bool is_http_parse_error(const beast::error_code& ec) {
    return ec.category() == beast::error_code(http::error::body_limit).category();
}

std::string request_id_of(const http::request_header<>& header) {
    auto it = header.find("X-Request-Id");
    return request_id_for(it == header.end() ? std::string_view{} : std::string_view(it->value()));
}

// The method's metric label from a closed set: an invented method would add a series per spelling.
std::string method_label(http::verb method) {
    switch (method) {
        case http::verb::get:
        case http::verb::head:
        case http::verb::post:
        case http::verb::put:
        case http::verb::delete_:
        case http::verb::patch:
        case http::verb::options:
            return std::string(http::to_string(method));
        default:
            return "other";
    }
}

}  // namespace

http_session::http_session(session_socket&& socket, std::shared_ptr<api_context> ctx,
                           std::shared_ptr<connection_permit> permit, std::shared_ptr<body_budget> bodies,
                           std::string refusal)
    : stream_(std::move(socket), ctx->tls ? ctx->tls->current() : nullptr),
      ctx_(std::move(ctx)),
      permit_(std::move(permit)),
      bodies_(std::move(bodies)),
      refusal_(std::move(refusal)) {
    beast::error_code ec;
    const auto peer = stream_.socket().remote_endpoint(ec);
    if (!ec) {
        peer_address_ = peer.address();
        client_address_ = peer_address_.to_string();
    }
    ctx_->metrics->increment("gw_http_connections", {}, 1);
}

http_session::~http_session() {
    drop_upload();
    ctx_->metrics->increment("gw_http_connections", {}, -1);
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

void http_session::shed() {
    net::post(stream_.get_executor(), [self = shared_from_this()] {
        // Its request is being handled by now: it stays (the limit is over by one until it ends).
        if (self->phase_ == connection_phase::serving) return;
        self->ctx_->metrics->increment("gw_http_connections_shed_total", {});
        self->ctx_->log->debug("shedding a connection that waits or reads slowly, to make room");
        beast::error_code ignored;
        self->stream_.socket().shutdown(net::ip::tcp::socket::shutdown_both, ignored);
        self->stream_.close();
    });
}

void http_session::set_phase(connection_phase phase) {
    phase_ = phase;
    if (permit_) permit_->set_phase(phase);
}

void http_session::on_run() {
    if (!stream_.is_tls()) return on_handshake({});
    // A client that does not finish its handshake in time is one that waits for its header.
    stream_.expires_after(ctx_->limits.header_timeout);
    stream_.async_handshake(beast::bind_front_handler(&http_session::on_handshake, shared_from_this()));
}

void http_session::on_handshake(beast::error_code ec) {
    if (ec) {
        ctx_->metrics->increment("gw_http_tls_handshake_failures_total", {});
        return fail(ec, "TLS handshake");
    }
    if (!permit_) {
        request_id_ = make_request_id();
        method_ = "-";
        started_ = std::chrono::steady_clock::now();
        auto p = make_problem(http_error::too_many_connections, refusal_);
        return do_write(problem_response(std::move(p), 11, false, "/", request_id_), "unmatched", true);
    }
    if (!refusal_.empty()) {
        // A HALT reserve slot: a request that has not come within reserve_header_timeout is not a HALT.
        reserve_timer_.emplace(stream_.get_executor(), reserve_header_timeout);
        reserve_timer_->async_wait([self = shared_from_this()](beast::error_code ec) {
            if (ec || self->phase_ != connection_phase::awaiting_header) return;
            self->reserve_expired_ = true;
            beast::error_code ignored;
            self->stream_.socket().cancel(ignored);
        });
    }
    do_read();
}

void http_session::do_read() {
    // A fresh parser per request, each with the configured limits.
    header_parser_.emplace();
    body_limit_ = ctx_->limits.max_body_bytes;
    parser_.reset();
    upload_parser_.reset();
    header_parser_->header_limit(
        static_cast<std::uint32_t>(std::min<std::size_t>(ctx_->limits.max_header_bytes, UINT32_MAX)));
    // Beast checks Content-Length against the body limit while it reads the header, so that read gets
    // the largest limit of any route; on_header narrows it to the route's.
    header_parser_->body_limit(
        std::max<std::uint64_t>(ctx_->limits.max_body_bytes, max_gcode_body_bytes(*ctx_)));
    if (first_request_ || buffer_.size() > 0) {
        set_phase(connection_phase::awaiting_header);
        return do_read_header();
    }
    // Keep-alive: idle up to the read timeout; the header deadline starts with the next request's
    // first bytes.
    set_phase(connection_phase::idle);
    stream_.expires_after(ctx_->limits.read_timeout);
    stream_.async_read_some(buffer_.prepare(4096),
                            beast::bind_front_handler(&http_session::on_first_bytes, shared_from_this()));
}

void http_session::on_first_bytes(beast::error_code ec, std::size_t bytes) {
    if (ec) return fail(ec, "read");
    buffer_.commit(bytes);
    set_phase(connection_phase::awaiting_header);
    do_read_header();
}

void http_session::do_read_header() {
    // A header already read (with the first bytes of a keep-alive request) is parsed at once: Beast's
    // read would parse the same bytes and then complete through the io_context's queue.
    if (buffer_.size() > 0) {
        beast::error_code ec;
        const auto used = header_parser_->put(buffer_.data(), ec);  // the whole header or need_more
        buffer_.consume(used);
        if (ec != http::error::need_more) return on_header(ec, used);
    }
    stream_.expires_after(ctx_->limits.header_timeout);
    http::async_read_header(stream_, buffer_, *header_parser_,
                            beast::bind_front_handler(&http_session::on_header, shared_from_this()));
}

void http_session::on_header(beast::error_code ec, std::size_t) {
    first_request_ = false;
    if (ec == http::error::end_of_stream) return do_close();
    started_ = std::chrono::steady_clock::now();
    const auto& header = header_parser_->get();
    if (reserve_timer_) reserve_timer_->cancel();
    if (ec) {
        if (reserve_expired_ && ec == net::error::operation_aborted)  // a reserve slot's silent client
            return refuse(make_problem(http_error::too_many_connections, refusal_), header, "unmatched");
        if (answer_read_error(ec, header)) return;
        return fail(ec, "read header");
    }
    set_phase(connection_phase::serving);
    request_id_ = request_id_of(header);
    method_ = method_label(header.method());
    // Behind a trusted reverse proxy, each request names its own client.
    if (!ctx_->proxies.empty())
        client_address_ = ctx_->proxies.client_address(peer_address_, header["X-Forwarded-For"]);
    stream_.expires_after(ctx_->limits.read_timeout);  // the body's deadline
    const bool has_body = !header_parser_->is_done();

    // The emergency stop first: nothing below (limits, uploads, the body budget) may stand in its way.
    if (header.method() == http::verb::post && is_halt_target(target_path(header.target())))
        return serve_halt(header, has_body);
    if (!refusal_.empty())  // a HALT reserve slot: the limits refused this connection for anything else
        return refuse(make_problem(http_error::too_many_connections, refusal_), header, "unmatched");

    body_limit_ =
        gcode_body_limit(*ctx_, header.method(), header.target()).value_or(ctx_->limits.max_body_bytes);
    const auto length = header_parser_->content_length();
    if (length && *length > body_limit_) {
        answer_read_error(http::error::body_limit, header);
        return;
    }
    // What the header decides (route, caller, browser rules, media type) is answered before the body
    // costs anything; the connection closes without reading it. A program upload too.
    if (has_body) {
        if (auto refused = refusal_from_header(*ctx_, header, request_id_, client_address_))
            return do_write(std::move(refused->response), refused->route, true);
    }
    // A G-code program (a route_body::program route): its query and a planner slot decided from the
    // header, the body streamed to the store.
    auto program = admit_gcode_program(ctx_, header, request_id_, client_address_);
    if (program.refusal) {
        auto& r = *program.refusal;
        return do_write(std::move(r.response), r.route, true);
    }
    // Any other body is held in memory: it must fit in the budget of all bodies (a chunked one may
    // grow to the route's limit).
    const std::uint64_t in_memory = program.intake ? upload_chunk_bytes
                                    : has_body     ? length.value_or(body_limit_)
                                                   : 0;
    if (in_memory > 0) {
        auto reserved = bodies_->try_reserve(in_memory);
        if (!reserved)
            return refuse(make_problem(http_error::body_budget_exhausted,
                                       "request bodies held in memory would exceed " +
                                           std::to_string(bodies_->capacity() / (std::size_t{1024} * 1024)) +
                                           " MiB (http.limits.max_buffered_body_mb); try again shortly"),
                          header, program.intake ? program.intake->route() : std::string("unmatched"));
        body_memory_ = std::move(*reserved);
    }
    if (program.intake) return start_upload(std::move(program.intake), body_limit_);
    parser_.emplace(std::move(*header_parser_));
    header_parser_.reset();
    parser_->body_limit(body_limit_);  // chunked bodies are counted as they come
    continue_then([this] { do_read_body(); });
}

template <typename Next>
void http_session::continue_then(Next next) {
    // "Expect: 100-continue" (curl sends it for bodies over 1 MiB): the request was accepted from its
    // header, so say go on rather than make the client wait a second.
    const http::request_header<>& header =
        parser_ ? static_cast<const http::request_header<>&>(parser_->get())
                : static_cast<const http::request_header<>&>(upload_parser_->get());
    const bool done = parser_ ? parser_->is_done() : upload_parser_->is_done();
    if (!beast::iequals(header[http::field::expect], "100-continue") || done) return next();
    auto go_on =
        std::make_shared<http::response<http::empty_body>>(http::status::continue_, header.version());
    http::async_write(stream_, *go_on,
                      [self = shared_from_this(), go_on, next](beast::error_code ec, std::size_t) mutable {
                          if (ec) return self->fail(ec, "write 100-continue");
                          next();
                      });
}

void http_session::do_read_body() {
    // Likewise a body that is already in the buffer, or none at all.
    if (!parser_->is_done() && buffer_.size() > 0) {
        beast::error_code ec;
        parser_->eager(true);
        const auto used = parser_->put(buffer_.data(), ec);
        buffer_.consume(used);
        if (ec && ec != http::error::need_more) return on_read(ec, used);
    }
    if (parser_->is_done()) return on_read({}, 0);
    set_phase(connection_phase::reading_body);
    http::async_read(stream_, buffer_, *parser_,
                     beast::bind_front_handler(&http_session::on_read, shared_from_this()));
}

bool http_session::answer_read_error(beast::error_code ec, const http::request_header<>& header) {
    if (ec != http::error::body_limit && ec != http::error::header_limit && !is_http_parse_error(ec))
        return false;
    // A client mistake: answer it, then close (the rest of the stream cannot be trusted).
    request_id_ = request_id_of(header);
    method_ = method_label(header.method());
    problem p = ec == http::error::body_limit
                    ? make_problem(http_error::payload_too_large,
                                   "the body is larger than " + std::to_string(body_limit_) + " bytes")
                : ec == http::error::header_limit
                    ? make_problem(http_error::header_too_large,
                                   "the headers are larger than " +
                                       std::to_string(ctx_->limits.max_header_bytes) + " bytes")
                    : make_problem(http_error::bad_request, "unparseable HTTP request: " + ec.message());
    refuse(std::move(p), header, "unmatched");
    return true;
}

void http_session::refuse(problem p, const http::request_header<>& header, const std::string& route) {
    drop_upload();
    body_memory_.reset();
    std::string target = header.target().empty() ? "/" : std::string(header.target());
    do_write(
        problem_response(std::move(p), header.version() ? header.version() : 11, false, target, request_id_),
        route, true);
}

void http_session::on_read(beast::error_code ec, std::size_t) {
    if (ec) {
        if (answer_read_error(ec, parser_->get())) return;
        return fail(ec, "read");
    }

    set_phase(connection_phase::serving);
    stream_.expires_never();  // an operation may legitimately take long (move with wait)
    auto& req = parser_->get();

    if (websocket::is_upgrade(req)) {
        if (target_path(req.target()) != websocket_path) {
            return do_write(
                problem_response(make_problem(http_error::not_found, "WebSocket upgrades go to /api/v1/ws"),
                                 req, request_id_),
                "unmatched", !req.keep_alive());
        }
        auto options = parse_websocket_options(req.target());
        if (!options) {
            auto p = make_problem(options.error());
            p.instance = std::string(websocket_path);
            return do_write(problem_response(std::move(p), req, request_id_), "/api/v1/ws", true);
        }
        if (auto refused = browser_refusal(req, ctx_->browser, true))
            return do_write(problem_response(std::move(*refused), req, request_id_), "/api/v1/ws", true);
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
        ctx_->metrics->increment("gw_http_requests_total",
                                 {{"route", "/api/v1/ws"}, {"method", method_}, {"status", "101"}});
        body_memory_.reset();
        return start_websocket_session(std::move(stream_), parser_->release(), ctx_, std::move(*who),
                                       std::move(permit_), options->batch_window);
    }

    handle_request(ctx_, parser_->release(), request_id_, stream_.get_executor(),
                   beast::bind_front_handler(&http_session::on_handled, shared_from_this()), client_address_);
}

void http_session::start_upload(std::shared_ptr<gcode_program_intake> intake, std::uint64_t limit) {
    intake_ = std::move(intake);
    upload_parser_.emplace(std::move(*header_parser_));
    header_parser_.reset();
    upload_parser_->body_limit(limit);
    chunk_.resize(upload_chunk_bytes);
    if (!upload_parser_->is_done()) set_phase(connection_phase::reading_body);
    continue_then([this] { do_read_chunk(); });
}

void http_session::do_read_chunk() {
    auto& body = upload_parser_->get().body();
    body.data = chunk_.data();
    body.size = chunk_.size();
    http::async_read(stream_, buffer_, *upload_parser_,
                     beast::bind_front_handler(&http_session::on_chunk, shared_from_this()));
}

void http_session::on_chunk(beast::error_code ec, std::size_t) {
    if (ec == http::error::need_buffer) ec = {};  // the chunk is full
    if (ec) {
        drop_upload();
        if (answer_read_error(ec, upload_parser_->get())) return;
        return fail(ec, "read body");
    }
    const std::size_t got = chunk_.size() - upload_parser_->get().body().size;
    const bool last = upload_parser_->is_done();
    if (got == 0) {
        if (last) return on_chunk_written(std::nullopt, true);
        return do_read_chunk();
    }
    // File writes may block: on the upload thread; the next read once this chunk is on disk.
    ctx_->gcode_thread->post_io(
        [self = shared_from_this(), intake = intake_, executor = stream_.get_executor(), got, last]() {
            auto error = intake->append(std::string_view(self->chunk_.data(), got));
            net::post(executor, [self, error = std::move(error), last]() mutable {
                self->on_chunk_written(std::move(error), last);
            });
        });
}

void http_session::on_chunk_written(std::optional<string_response> error, bool last) {
    if (!stream_.socket().is_open()) return drop_upload();  // closed meanwhile (stop)
    if (error) {
        drop_upload();
        body_memory_.reset();
        return do_write(std::move(*error), "unmatched", true);
    }
    if (!last) return do_read_chunk();
    set_phase(connection_phase::serving);
    stream_.expires_never();  // planning may take a while
    body_memory_.reset();
    chunk_ = {};
    gcode_program_intake::finish(std::move(intake_), stream_.get_executor(),
                                 beast::bind_front_handler(&http_session::on_handled, shared_from_this()));
}

void http_session::drop_upload() {
    // Its temporary file is removed on the upload thread: deleting tens of megabytes can take a while.
    if (intake_) ctx_->gcode_thread->post_io([intake = std::move(intake_)] {});
    intake_.reset();
}

void http_session::serve_halt(const http::request_header<>& header, bool body_follows) {
    string_request req(header);
    if (body_follows || !refusal_.empty())
        req.keep_alive(false);  // its body stays unread; a reserve slot goes
    header_parser_.reset();
    stream_.expires_never();
    handle_request(ctx_, std::move(req), request_id_, stream_.get_executor(),
                   beast::bind_front_handler(&http_session::on_handled, shared_from_this()), client_address_);
}

void http_session::on_handled(routed_response r) {
    body_memory_.reset();
    const bool close_after = !r.response.keep_alive();
    if (r.stream) return do_write_stream(std::move(r.response), std::move(r.stream), r.route, close_after);
    do_write(std::move(r.response), r.route, close_after);
}

void http_session::count_answer(unsigned status, const std::string& route) {
    auto elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    auto& series = last_series_;
    if (series.status != status || series.route != route || series.method != method_) {
        series = {
            route, method_, status,
            ctx_->metrics->find("gw_http_requests_total",
                                {{"route", route}, {"method", method_}, {"status", std::to_string(status)}}),
            ctx_->metrics->find("gw_http_request_duration_seconds", {{"route", route}})};
    }
    ctx_->metrics->increment(series.requests);
    ctx_->metrics->observe(series.duration, elapsed);
    // A refused connection is counted (gw_http_connections_refused_total), not logged: a flood of them
    // must not flood the log.
    if (status >= 500 && refusal_.empty())
        ctx_->log->warn("{} {} -> {} [{}]", method_, route, status, request_id_);
    else if (status == 401)
        log_failed_authentication(ctx_->log, client_address_, method_, route);
    else
        ctx_->log->debug("{} {} -> {} [{}] {:.1f} ms", method_, route, status, request_id_, elapsed * 1e3);
}

void http_session::do_write(string_response res, const std::string& route, bool close_after) {
    if (close_after) res.keep_alive(false);
    count_answer(res.result_int(), route);
    // A write must not hang forever on a client that stopped reading.
    stream_.expires_after(ctx_->limits.read_timeout);
    auto msg = std::make_shared<string_response>(std::move(res));
    response_ = msg;
    http::async_write(stream_, *msg,
                      beast::bind_front_handler(&http_session::on_write, shared_from_this(), close_after));
}

// A streamed body: the header (chunked), then one piece at a time, each written before the next is asked
// for; the last chunk only once the body says it is complete. HTTP/1.0 has no chunks: its body ends
// when the connection closes.
struct http_session::outgoing_stream {
    explicit outgoing_stream(string_response head, std::shared_ptr<streamed_body> b)
        : message(std::move(head.base())), body(std::move(b)), chunked(message.version() >= 11) {
        if (chunked)
            message.chunked(true);
        else
            message.keep_alive(false);
    }
    http::response<http::empty_body> message;
    http::response_serializer<http::empty_body> serializer{message};
    std::shared_ptr<streamed_body> body;
    std::string piece;  // the chunk being written
    bool chunked;
};

void http_session::do_write_stream(string_response head, std::shared_ptr<streamed_body> body,
                                   const std::string& route, bool close_after) {
    if (close_after) head.keep_alive(false);
    count_answer(head.result_int(), route);
    auto out = std::make_shared<outgoing_stream>(std::move(head), std::move(body));
    close_after = close_after || !out->chunked;
    response_ = out;
    stream_.expires_after(ctx_->limits.read_timeout);
    http::async_write_header(
        stream_, out->serializer,
        [self = shared_from_this(), out, close_after](beast::error_code ec, std::size_t) {
            if (ec) return self->fail(ec, "write");
            self->next_piece(out, close_after);
        });
}

void http_session::next_piece(const std::shared_ptr<outgoing_stream>& out, bool close_after) {
    stream_.expires_never();  // the body may take its time; each write has its own timeout
    out->body->next(
        [self = shared_from_this(), out, close_after](std::optional<std::string> piece, bool last) {
            auto ex = self->stream_.get_executor();
            net::post(ex, [self, out, close_after, piece = std::move(piece), last]() mutable {
                self->on_piece(out, close_after, std::move(piece), last);
            });
        });
}

void http_session::on_piece(const std::shared_ptr<outgoing_stream>& out, bool close_after,
                            std::optional<std::string> piece, bool last) {
    if (!stream_.socket().is_open()) return;  // closed meanwhile (stop)
    if (!piece) {
        // Too late for a status: the client sees the body end without its last chunk.
        ctx_->log->warn("{} [{}]: the streamed body failed; the connection closes", method_, request_id_);
        response_.reset();
        return do_close();
    }
    out->piece = std::move(*piece);
    auto written = [self = shared_from_this(), out, close_after, last](beast::error_code ec, std::size_t) {
        if (ec) return self->fail(ec, "write");
        if (!last) return self->next_piece(out, close_after);
        self->end_stream(out, close_after);
    };
    stream_.expires_after(ctx_->limits.read_timeout);
    if (out->piece.empty())
        written({}, 0);
    else if (out->chunked)
        net::async_write(stream_, http::make_chunk(net::buffer(out->piece)), std::move(written));
    else
        net::async_write(stream_, net::buffer(out->piece), std::move(written));
}

void http_session::end_stream(const std::shared_ptr<outgoing_stream>& out, bool close_after) {
    if (!out->chunked) return on_write(true, {}, 0);
    stream_.expires_after(ctx_->limits.read_timeout);
    net::async_write(stream_, http::make_chunk_last(),
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
    set_phase(connection_phase::closing);
    beast::error_code ignored;
    stream_.socket().shutdown(net::ip::tcp::socket::shutdown_send, ignored);
    stream_.expires_after(std::chrono::seconds(2));
    buffer_.clear();
    stream_.async_read_some(buffer_.prepare(std::size_t{16} * 1024),
                            beast::bind_front_handler(&http_session::on_linger, shared_from_this()));
}

void http_session::on_linger(beast::error_code ec, std::size_t bytes) {
    lingered_ += bytes;
    if (ec || lingered_ > std::size_t{4} * 1024 * 1024) {
        stream_.close();
        return;
    }
    stream_.async_read_some(buffer_.prepare(std::size_t{16} * 1024),
                            beast::bind_front_handler(&http_session::on_linger, shared_from_this()));
}

void http_session::do_close() {
    beast::error_code ignored;
    stream_.socket().shutdown(net::ip::tcp::socket::shutdown_send, ignored);
    stream_.close();
}

void http_session::fail(beast::error_code ec, const char* what) {
    drop_upload();
    // Expected ends of a connection are not worth a log line.
    if (ec == net::error::operation_aborted || ec == beast::error::timeout ||
        ec == net::error::connection_reset || ec == net::error::eof || ec == net::error::broken_pipe ||
        ec == net::error::bad_descriptor || ec == http::error::end_of_stream ||
        ec == http::error::partial_message)
        return do_close();
    ctx_->log->debug("http session {}: {}", what, ec.message());
    do_close();
}

}  // namespace gw::api
