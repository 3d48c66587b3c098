#pragma once
// Finds out why a connect to the broker failed when Paho says only "failure" (Paho C++ 1.2 cannot
// hand over OpenSSL's error text safely: its SSL error callback's context dangles, paho.mqtt.cpp
// issues 325 and 439). Connects to the broker's host and port itself, on the client's strand, and for
// a TLS broker runs a handshake with the same CA, client certificate, key and host name check, then
// waits briefly for the broker's verdict on the client certificate (TLS 1.3 sends it after the
// handshake). Reports what it saw as connect_failure.tcp_error / tls_error text.

#include <functional>
#include <string>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/strand.hpp>

#include "api/mqtt/connect_failure.hpp"
#include "gateway/config/config.hpp"

namespace gw::api {

using probe_done = std::function<void(std::string tcp_error, std::string tls_error)>;

// `tls`: run the handshake (mqtts:// and ssl:// brokers). `done` runs on `strand`, once, within about
// four seconds.
void probe_broker(boost::asio::strand<boost::asio::any_io_executor> strand, const broker_address& address,
                  bool tls, const mqtt_tls_config& settings, probe_done done);

}  // namespace gw::api
