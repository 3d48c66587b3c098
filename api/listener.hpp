#pragma once
// Accepts TCP connections and starts an http_session for each, on its own strand. Enforces the
// connection limit over HTTP and upgraded WebSocket connections alike (each connection holds a
// connection_permit; one over the limit gets a 503 problem and is closed) and stops gracefully:
// stop() closes the acceptor, then every open HTTP session (WebSocket sessions are closed by the
// event hub's stop()). Owned by shared_ptr (its pending accept and
// api::server hold it); public methods may be called from any thread.

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>

#include "api/api_context.hpp"
#include "api/connection_permit.hpp"
#include "api/net.hpp"

namespace gw::api {

class http_session;

class listener : public std::enable_shared_from_this<listener> {
  public:
    // Opens, binds and listens. Throws boost::system::system_error (start-up only).
    listener(net::any_io_executor executor, net::ip::tcp::endpoint endpoint,
             std::shared_ptr<api_context> ctx);

    void run();
    void stop();

    net::ip::tcp::endpoint local_endpoint() const { return endpoint_; }
    // Open connections, HTTP and WebSocket (the permits in use).
    std::size_t open_connections() const { return connections_->load(); }

    // Called by sessions.
    void remove(std::uint64_t id);

  private:
    void do_accept();
    void on_accept(beast::error_code ec, net::ip::tcp::socket socket);

    net::any_io_executor executor_;
    net::strand<net::any_io_executor> strand_;  // the acceptor's
    net::ip::tcp::acceptor acceptor_;
    net::steady_timer retry_timer_;  // after an accept error (EMFILE), retry a little later
    net::ip::tcp::endpoint endpoint_;
    std::shared_ptr<api_context> ctx_;
    mutable std::mutex mutex_;  // guards the fields below: held only to copy/insert/erase
    bool stopped_ = false;
    std::uint64_t next_id_ = 1;
    std::map<std::uint64_t, std::weak_ptr<http_session>> sessions_;  // HTTP only, for stop()
    std::shared_ptr<connection_permit::counter> connections_ =
        std::make_shared<connection_permit::counter>(0);

    friend class http_session;
    std::uint64_t add(const std::shared_ptr<http_session>& s);
};

}  // namespace gw::api
