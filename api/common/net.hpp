#pragma once
// Namespace aliases for the api layer (Beast's chat-multi net.hpp/beast.hpp), nothing else.

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace gw::api {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = boost::beast::http;
namespace websocket = boost::beast::websocket;

// The sessions' executor types, spelled out: with the type-erased any_io_executor every operation
// copied and destroyed an executor object (about 9 % of a small request's CPU time).
using io_executor = net::io_context::executor_type;
using session_strand = net::strand<io_executor>;
using session_socket = net::basic_stream_socket<net::ip::tcp, session_strand>;
using session_stream = beast::basic_stream<net::ip::tcp, session_strand>;

}  // namespace gw::api
