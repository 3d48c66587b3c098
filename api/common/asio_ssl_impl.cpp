// Asio's SSL part compiled once (BOOST_ASIO_SEPARATE_COMPILATION, see devices/asio_impl.cpp), here
// rather than in gw_asio so that only the HTTP server (http.tls) and the MQTT bridge (broker_probe's
// handshake) link OpenSSL.
#include <boost/asio/ssl/impl/src.hpp>
