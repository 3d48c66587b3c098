#pragma once
// One HTTP or WebSocket connection's byte stream: plain TCP, or TLS over it (http.tls). The sessions
// are written once against this stream; it chooses at run time, per operation, which of the two
// carries the bytes. Its interface is the subset of beast::basic_stream the sessions use (timeouts,
// socket, close) plus the TLS handshake, so Beast's HTTP and WebSocket operations take it as they
// take a basic_stream; the WebSocket close handshake ends it through async_teardown below.

#include <memory>
#include <utility>
#include <variant>

#include <boost/asio/ssl.hpp>
#include <boost/beast/ssl/ssl_stream.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <boost/beast/websocket/teardown.hpp>

#include "api/common/net.hpp"

namespace gw::api {

class http_stream {
  public:
    using executor_type = session_strand;
    using tls_stream = beast::ssl_stream<session_stream>;

    // Plain TCP without a TLS context, TLS (after async_handshake) with one.
    http_stream(session_socket&& socket, std::shared_ptr<net::ssl::context> tls)
        : tls_context_(std::move(tls)), stream_(open(std::move(socket), tls_context_.get())) {}

    bool is_tls() const { return std::holds_alternative<tls_stream>(stream_); }
    executor_type get_executor() noexcept { return tcp().get_executor(); }

    // The TCP layer under TLS, or the stream itself: timeouts, the socket, close.
    session_stream& tcp() {
        if (auto* tls = std::get_if<tls_stream>(&stream_)) return tls->next_layer();
        return std::get<session_stream>(stream_);
    }
    tls_stream* tls() { return std::get_if<tls_stream>(&stream_); }

    net::ip::tcp::socket::rebind_executor<session_strand>::other& socket() { return tcp().socket(); }
    template <typename Duration>
    void expires_after(Duration d) {
        tcp().expires_after(d);
    }
    void expires_never() { tcp().expires_never(); }
    void close() { tcp().close(); }

    // The server's side of the TLS handshake (only for a TLS stream).
    template <typename Token>
    auto async_handshake(Token&& token) {
        return std::get<tls_stream>(stream_).async_handshake(net::ssl::stream_base::server,
                                                             std::forward<Token>(token));
    }

    template <typename Buffers, typename Token>
    auto async_read_some(const Buffers& buffers, Token&& token) {
        return net::async_initiate<Token, void(beast::error_code, std::size_t)>(
            [this](auto handler, const Buffers& b) {
                if (auto* tls = std::get_if<tls_stream>(&stream_))
                    tls->async_read_some(b, std::move(handler));
                else
                    std::get<session_stream>(stream_).async_read_some(b, std::move(handler));
            },
            token, buffers);
    }

    template <typename Buffers, typename Token>
    auto async_write_some(const Buffers& buffers, Token&& token) {
        return net::async_initiate<Token, void(beast::error_code, std::size_t)>(
            [this](auto handler, const Buffers& b) {
                if (auto* tls = std::get_if<tls_stream>(&stream_))
                    tls->async_write_some(b, std::move(handler));
                else
                    std::get<session_stream>(stream_).async_write_some(b, std::move(handler));
            },
            token, buffers);
    }

  private:
    using either = std::variant<session_stream, tls_stream>;
    static either open(session_socket&& socket, net::ssl::context* tls) {
        if (tls) return either(std::in_place_type<tls_stream>, session_stream(std::move(socket)), *tls);
        return either(std::in_place_type<session_stream>, std::move(socket));
    }

    std::shared_ptr<net::ssl::context> tls_context_;  // kept while the stream lives (a reload swaps it)
    either stream_;
};

// The end of a WebSocket connection (Beast finds these by argument-dependent lookup): TLS's
// close_notify first when there is TLS, then TCP's.
template <typename TeardownHandler>
void async_teardown(beast::role_type role, http_stream& stream, TeardownHandler&& handler) {
    if (auto* tls = stream.tls()) {
        using boost::beast::async_teardown;
        async_teardown(role, *tls, std::forward<TeardownHandler>(handler));
    } else {
        using boost::beast::websocket::async_teardown;
        async_teardown(role, stream.tcp(), std::forward<TeardownHandler>(handler));
    }
}

// Beast's websocket stream closes the socket through this when a close times out.
inline void beast_close_socket(http_stream& stream) {
    stream.close();
}

inline void teardown(beast::role_type role, http_stream& stream, beast::error_code& ec) {
    if (auto* tls = stream.tls()) {
        using boost::beast::teardown;
        teardown(role, *tls, ec);
    } else {
        using boost::beast::websocket::teardown;
        teardown(role, stream.tcp(), ec);
    }
}

}  // namespace gw::api
