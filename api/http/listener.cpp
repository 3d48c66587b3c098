#include "api/http/listener.hpp"

#include <spdlog/logger.h>

#include "api/http/http_session.hpp"
#include "gateway/common/metrics.hpp"

namespace gw::api {

listener::listener(const io_executor& executor, const net::ip::tcp::endpoint& endpoint,
                   std::shared_ptr<api_context> ctx)
    : executor_(executor),
      strand_(net::make_strand(executor)),
      acceptor_(strand_),
      retry_timer_(strand_),
      ctx_(std::move(ctx)),
      connections_(std::make_shared<connection_table>(
          connection_table::settings{.max_connections = ctx_->limits.max_connections,
                                     .max_per_address = ctx_->limits.max_connections_per_address,
                                     .patience = ctx_->limits.header_timeout,
                                     .proxies = ctx_->proxies})),
      bodies_(std::make_shared<body_budget>(ctx_->limits.max_buffered_body_bytes)) {
    acceptor_.open(endpoint.protocol());
    acceptor_.set_option(net::socket_base::reuse_address(true));
    acceptor_.bind(endpoint);
    acceptor_.listen(net::socket_base::max_listen_connections);
    acceptor_.non_blocking(true);  // on_accept takes the backlog in batches
    endpoint_ = acceptor_.local_endpoint();
}

void listener::run() {
    net::dispatch(strand_, [self = shared_from_this()] { self->do_accept(); });
}

void listener::stop() {
    {
        std::lock_guard lock(mutex_);
        stopped_ = true;
    }
    // Stop accepting first, then close every open connection.
    net::dispatch(strand_, [self = shared_from_this()] {
        beast::error_code ignored;
        self->acceptor_.close(ignored);
        self->retry_timer_.cancel();
        self->refused_.clear();  // closes them unanswered
    });
    connections_->close_all();
}

void listener::do_accept() {
    // Each connection gets its own strand.
    acceptor_.async_accept(net::make_strand(executor_),
                           beast::bind_front_handler(&listener::on_accept, shared_from_this()));
}

void listener::on_accept(beast::error_code ec, session_socket socket) {
    if (ec == net::error::operation_aborted || !acceptor_.is_open()) return;
    if (ec) {
        // EMFILE and friends: the pending connection stays queued; try again shortly instead of
        // spinning.
        ctx_->log->warn("accept: {}", ec.message());
        retry_timer_.expires_after(std::chrono::milliseconds(100));
        return retry_timer_.async_wait([self = shared_from_this()](beast::error_code e) {
            if (!e && self->acceptor_.is_open()) self->do_accept();
        });
    }
    {
        std::lock_guard lock(mutex_);
        if (stopped_) return;
    }
    start(std::move(socket));
    // Take every connection already waiting, up to a batch: under a flood, one accept per turn of the
    // I/O loop would queue a client behind every connection that came before it (each turn also runs
    // the other clients' work).
    for (int i = 0; i < max_accept_batch; ++i) {
        session_socket next(net::make_strand(executor_));
        beast::error_code aec;
        acceptor_.accept(next, aec);  // non-blocking: would_block once the backlog is empty
        if (aec) break;
        start(std::move(next));
    }
    do_accept();
}

void listener::start(session_socket socket) {
    beast::error_code remote_ec;
    const auto remote = socket.remote_endpoint(remote_ec);
    if (remote_ec) return;  // gone already
    auto a = connections_->admit(remote.address());
    if (auto victim = a.shed.lock()) victim->shed();
    if (a.refused != connection_table::refusal::none)
        ctx_->metrics->increment(
            "gw_http_connections_refused_total",
            {{"reason", a.refused == connection_table::refusal::address_limit ? "address" : "limit"}});
    if (!a.permit) return refuse(std::move(socket), std::move(a.detail));
    // Every answer and event is written whole: Nagle's algorithm would only hold a small write back
    // behind an unacknowledged one (up to the client's delayed ACK, about 40 ms).
    beast::error_code nodelay_ec;
    socket.set_option(net::ip::tcp::no_delay(true), nodelay_ec);
    // A HALT reserve slot (a.halt_only): the session serves a HALT, anything else gets a.detail in a 503.
    auto session = std::make_shared<http_session>(std::move(socket), ctx_, a.permit, bodies_,
                                                  a.halt_only ? std::move(a.detail) : std::string());
    a.permit->track(session);
    session->run();
}

void listener::refuse(session_socket socket, std::string detail) {
    if (refused_.size() >= max_refused_waiting) {
        beast::error_code ignored;
        socket.close(ignored);  // a flood beyond this gets no answer at all
        return;
    }
    refused_.emplace_back(std::move(socket), std::move(detail));
    if (refused_.size() == 1) net::post(strand_, [self = shared_from_this()] { self->answer_refused(); });
}

// One refusal per turn, then to the back of the queue: whatever the admitted clients need that came
// meanwhile runs first, so a flood of refused connections costs them little time.
void listener::answer_refused() {
    if (refused_.empty()) return;
    auto [socket, detail] = std::move(refused_.front());
    refused_.pop_front();
    std::make_shared<http_session>(std::move(socket), ctx_, nullptr, bodies_, std::move(detail))->run();
    if (!refused_.empty()) net::post(strand_, [self = shared_from_this()] { self->answer_refused(); });
}

}  // namespace gw::api
