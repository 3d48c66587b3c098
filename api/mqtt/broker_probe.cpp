#include "api/mqtt/broker_probe.hpp"

#include <chrono>
#include <memory>
#include <openssl/x509_vfy.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/address.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/steady_timer.hpp>

namespace gw::api {

namespace {

namespace net = boost::asio;
namespace ssl = boost::asio::ssl;
using tcp = net::ip::tcp;

// One probe: everything its handlers need, alive until the last one ran.
struct probe_state : std::enable_shared_from_this<probe_state> {
    probe_state(net::strand<net::any_io_executor> s, bool tls_, ssl::context ctx_)
        : strand(s), resolver(s), context(std::move(ctx_)), stream(s, context), deadline(s), tls(tls_) {}

    net::strand<net::any_io_executor> strand;
    tcp::resolver resolver;
    ssl::context context;
    ssl::stream<tcp::socket> stream;
    net::steady_timer deadline;
    bool tls;
    bool finished = false;
    probe_done done;
    char byte = 0;

    void finish(std::string tcp_error, std::string tls_error) {
        if (finished) return;
        finished = true;
        deadline.cancel();
        boost::system::error_code ignored;
        stream.lowest_layer().close(ignored);
        done(std::move(tcp_error), std::move(tls_error));
    }

    // "certificate verify failed: hostname mismatch": OpenSSL's reason and the verify result.
    std::string tls_text(const boost::system::error_code& ec) {
        std::string text = ec.message();
        const long verify = SSL_get_verify_result(stream.native_handle());
        if (verify != X509_V_OK) text += ": " + std::string(X509_verify_cert_error_string(verify));
        return text;
    }
};

}  // namespace

void probe_broker(net::strand<net::any_io_executor> strand, const broker_address& address, bool tls,
                  const mqtt_tls_config& settings, probe_done done) {
    ssl::context ctx(ssl::context::tls_client);
    boost::system::error_code ec;
    if (!settings.ca_file.empty()) {
        ctx.load_verify_file(settings.ca_file, ec);
    } else {
        ctx.set_default_verify_paths(ec);
    }
    if (!ec && !settings.cert_file.empty()) ctx.use_certificate_chain_file(settings.cert_file, ec);
    if (!ec && !settings.key_file.empty()) ctx.use_private_key_file(settings.key_file, ssl::context::pem, ec);
    auto p = std::make_shared<probe_state>(strand, tls, std::move(ctx));
    p->done = std::move(done);
    if (tls && ec) return p->finish({}, "TLS files: " + ec.message());
    if (tls && settings.verify) {
        p->stream.set_verify_mode(ssl::verify_peer);
        // OpenSSL's own host check, so that a mismatch is reported as such ("hostname mismatch").
        auto* param = SSL_get0_param(p->stream.native_handle());
        boost::system::error_code not_ip;
        net::ip::make_address(address.host, not_ip);
        if (not_ip)
            X509_VERIFY_PARAM_set1_host(param, address.host.c_str(), 0);
        else
            X509_VERIFY_PARAM_set1_ip_asc(param, address.host.c_str());
        SSL_set_tlsext_host_name(p->stream.native_handle(), address.host.c_str());
    }
    p->deadline.expires_after(std::chrono::seconds(3));
    p->deadline.async_wait([p](boost::system::error_code ec) {
        if (!ec) p->finish("no answer within 3 s", {});
    });
    p->resolver.async_resolve(
        address.host, address.port,
        [p](boost::system::error_code ec, const tcp::resolver::results_type& results) {
            if (ec) return p->finish("cannot resolve the host name: " + ec.message(), {});
            net::async_connect(
                p->stream.lowest_layer(), results, [p](boost::system::error_code ec, const auto&) {
                    if (ec) return p->finish(ec.message(), {});
                    if (!p->tls) return p->finish({}, {});
                    p->stream.async_handshake(ssl::stream_base::client, [p](boost::system::error_code ec) {
                        if (ec) return p->finish({}, p->tls_text(ec));
                        // TLS 1.3: a refused client certificate arrives as an alert after the handshake.
                        p->deadline.expires_after(std::chrono::milliseconds(800));
                        p->deadline.async_wait([p](boost::system::error_code ec) {
                            if (!ec) p->finish({}, {});  // quiet: the broker took the certificate
                        });
                        p->stream.async_read_some(
                            net::buffer(&p->byte, 1), [p](boost::system::error_code ec, std::size_t) {
                                p->finish({}, ec && ec != net::error::operation_aborted ? ec.message()
                                                                                        : std::string());
                            });
                    });
                });
        });
}

}  // namespace gw::api
