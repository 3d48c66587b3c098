#pragma once
// The HTTP/WebSocket server as main sees it: checks the "no tokens, loopback only" rule, declares
// the metrics, attaches the controller metrics observer, binds the listener and stops it.
//
//   gw::api::server server(ioc.get_executor(), config, registry, hub, metrics, jobs, leases);
//   server.start();            // throws std::runtime_error with a message for the log
//   ...
//   server.stop();             // stop accepting, close sockets
// Methods are called from main's thread (start) and the signal handler (stop).

#include <memory>

#include "api/common/api_context.hpp"
#include "api/common/net.hpp"
#include "gateway/config/config.hpp"

namespace gw::api {

class listener;
class tls_server_context;

class server {
  public:
    server(const io_executor& executor, const gateway_config& config, controller_registry& registry,
           std::shared_ptr<event_hub> hub, std::shared_ptr<gw::metrics> metrics,
           std::shared_ptr<jobs::job_manager> jobs = nullptr, std::shared_ptr<lease_manager> leases = nullptr,
           std::shared_ptr<const controller_state_texts> state_texts = nullptr,
           const shared_ports* shares = nullptr, std::shared_ptr<tls_server_context> tls = nullptr,
           std::shared_ptr<recordings::recorder> recordings = nullptr);
    ~server();

    // Binds http.listen_address:http.port. Throws std::runtime_error (refused address, port in use).
    void start();
    void stop();

    net::ip::tcp::endpoint local_endpoint() const;
    const std::shared_ptr<api_context>& context() const { return ctx_; }

  private:
    io_executor executor_;  // the sessions' strands are made on it
    http_config http_;
    std::shared_ptr<api_context> ctx_;
    std::shared_ptr<listener> listener_;
};

}  // namespace gw::api
