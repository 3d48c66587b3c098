#pragma once
// The HTTPS/WSS server's TLS context (OpenSSL through Asio), built from http.tls's PEM files:
// TLS 1.2 and 1.3 only, forward-secret AEAD cipher suites for 1.2, the server's preference, no
// compression, no renegotiation. reload() reads the files again (SIGHUP): new connections get the
// new certificate, open ones keep theirs; a reload that fails keeps the old context and says why.
// Thread-safe: current() from the listener's strand, reload() from the signal handler.

#include <memory>
#include <mutex>
#include <string>

#include <boost/asio/ssl/context.hpp>
#include <boost/system/result.hpp>

#include "gateway/config/config.hpp"

namespace gw::api {

struct tls_problem {
    std::string message;  // names the file: "http.tls.key_file: /etc/k.pem: no such file"
};

// A server context from the certificate chain and key files; the key must match the certificate.
boost::system::result<std::shared_ptr<boost::asio::ssl::context>, tls_problem> make_tls_server_context(
    const http_tls_config& files);

class tls_server_context {
  public:
    // Throws std::runtime_error with the problem's message (start-up).
    explicit tls_server_context(http_tls_config files);

    std::shared_ptr<boost::asio::ssl::context> current() const;
    // Reads the files again; on success the new context serves new connections. Empty, or the problem.
    std::string reload();

  private:
    const http_tls_config files_;
    mutable std::mutex mutex_;
    std::shared_ptr<boost::asio::ssl::context> current_;  // guarded by mutex_
};

}  // namespace gw::api
