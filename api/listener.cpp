#include "api/listener.hpp"

#include <spdlog/logger.h>

#include "api/http_session.hpp"

namespace gw::api {

listener::listener(net::any_io_executor executor, net::ip::tcp::endpoint endpoint,
                   std::shared_ptr<api_context> ctx)
    : executor_(executor),
      strand_(net::make_strand(executor)),
      acceptor_(strand_),
      retry_timer_(strand_),
      ctx_(std::move(ctx)) {
    acceptor_.open(endpoint.protocol());
    acceptor_.set_option(net::socket_base::reuse_address(true));
    acceptor_.bind(endpoint);
    acceptor_.listen(net::socket_base::max_listen_connections);
    endpoint_ = acceptor_.local_endpoint();
}

void listener::run() {
    net::dispatch(strand_, [self = shared_from_this()] { self->do_accept(); });
}

void listener::stop() {
    std::vector<std::weak_ptr<http_session>> sessions;
    {
        std::lock_guard lock(mutex_);
        stopped_ = true;
        for (const auto& [id, s] : sessions_)
            sessions.push_back(s);
    }
    // Stop accepting first, then close every open connection.
    net::dispatch(strand_, [self = shared_from_this()] {
        beast::error_code ignored;
        self->acceptor_.close(ignored);
        self->retry_timer_.cancel();
    });
    for (auto& w : sessions)
        if (auto s = w.lock()) s->close();
}

std::uint64_t listener::add(const std::shared_ptr<http_session>& s) {
    std::lock_guard lock(mutex_);
    auto id = next_id_++;
    sessions_.emplace(id, s);
    return id;
}

void listener::remove(std::uint64_t id) {
    std::lock_guard lock(mutex_);
    sessions_.erase(id);
}

void listener::do_accept() {
    // Each connection gets its own strand.
    acceptor_.async_accept(net::make_strand(executor_),
                           beast::bind_front_handler(&listener::on_accept, shared_from_this()));
}

void listener::on_accept(beast::error_code ec, net::ip::tcp::socket socket) {
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
    std::shared_ptr<connection_permit> permit;
    {
        std::lock_guard lock(mutex_);
        if (stopped_) return;
        // Only this strand takes permits, so the count can only fall between the check and the take.
        if (connections_->load() < ctx_->limits.max_connections)
            permit = std::make_shared<connection_permit>(connections_);
    }
    const bool reject = !permit;
    auto session =
        std::make_shared<http_session>(std::move(socket), ctx_, weak_from_this(), std::move(permit));
    if (!reject) session->set_id(add(session));
    session->run();
    do_accept();
}

}  // namespace gw::api
