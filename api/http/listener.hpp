#pragma once
// Accepts TCP connections and starts an http_session for each, on its own strand. Enforces the
// connection limits over HTTP and upgraded WebSocket connections alike through the connection table
// (each connection holds a connection_permit; one refused gets a 503 problem, after the admitted
// clients' work, and is closed; one that only waits for a header may be shed for a newcomer), owns
// the budget of request bodies held in
// memory that every session shares, and stops gracefully: stop() closes the acceptor, then every open
// HTTP session (WebSocket sessions are closed by the event hub's stop()). Owned by shared_ptr (its
// pending accept and api::server hold it); public methods may be called from any thread.

#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "api/common/api_context.hpp"
#include "api/common/body_budget.hpp"
#include "api/common/connection_table.hpp"
#include "api/common/net.hpp"

namespace gw::api {

class listener : public std::enable_shared_from_this<listener> {
  public:
    // Opens, binds and listens. Throws boost::system::system_error (start-up only).
    listener(const io_executor& executor, const net::ip::tcp::endpoint& endpoint,
             std::shared_ptr<api_context> ctx);

    void run();
    void stop();

    net::ip::tcp::endpoint local_endpoint() const { return endpoint_; }
    // Open connections, HTTP and WebSocket (the permits in use).
    std::size_t open_connections() const { return connections_->open(); }

  private:
    void do_accept();
    void on_accept(beast::error_code ec, session_socket socket);
    // Admits a connection (or refuses it) and starts its session.
    void start(session_socket socket);
    // A connection the limits refused: answered 503 later, after the admitted clients' work.
    void refuse(session_socket socket, std::string detail);
    void answer_refused();

    // Refused connections waiting for their 503; beyond, one is closed unanswered (a flood must not
    // take the process's descriptors either).
    static constexpr std::size_t max_refused_waiting = 512;
    static constexpr int max_accept_batch = 256;

    io_executor executor_;
    session_strand strand_;  // the acceptor's
    net::ip::tcp::acceptor acceptor_;
    net::steady_timer retry_timer_;  // after an accept error (EMFILE), retry a little later
    net::ip::tcp::endpoint endpoint_;
    std::shared_ptr<api_context> ctx_;
    std::shared_ptr<connection_table> connections_;
    std::shared_ptr<body_budget> bodies_;
    std::deque<std::pair<session_socket, std::string>> refused_;  // on strand_
    mutable std::mutex mutex_;                                    // guards stopped_
    bool stopped_ = false;
};

}  // namespace gw::api
