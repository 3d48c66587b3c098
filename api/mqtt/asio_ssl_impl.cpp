// Asio's SSL part compiled once (BOOST_ASIO_SEPARATE_COMPILATION, see devices/asio_impl.cpp), here
// rather than in gw_asio so that only the MQTT library links OpenSSL (broker_probe's handshake).
#include <boost/asio/ssl/impl/src.hpp>
