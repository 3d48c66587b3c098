#pragma once
// The Paho MQTT C++ client (1.2) behind a small interface the bridge uses. Paho runs its callbacks
// on its own threads; every one of them only copies what it got and posts it onto this object's
// strand. Everything else happens on the strand.
//
// Connection: MQTT 5 (clean start) or 3.1.1 (clean session), the Last Will given at creation, TLS
// for mqtts:// and ssl:// brokers. With several brokers (a cluster's nodes), each attempt tries them
// all in order; after a lost connection the next attempt starts at once with the broker after the
// lost one (the lost one last). After a failed connect or a lost connection it reconnects forever
// with capped exponential backoff and jitter (reconnect_backoff.hpp: reconnect_min doubling up to
// reconnect_max, each wait drawn from its upper half), so the broker's return is noticed within
// reconnect_max however long it was away; Paho's own
// automatic reconnect is not used, so that the first connect is retried the same way and the bridge
// learns about every (re)connect. Publishes while disconnected are refused (the caller decides what
// to keep). Publishes in flight are counted; the bridge stops taking events when too many are.

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <spdlog/common.h>

#include "api/mqtt/reconnect_backoff.hpp"
#include "gateway/common/worker_thread.hpp"
#include "gateway/config/config.hpp"

namespace spdlog {
class logger;
}
namespace mqtt {
class async_client;
class connect_options;
class message;
}  // namespace mqtt

namespace gw::api {

struct mqtt_message_in {
    std::string topic;
    std::string payload;
    std::string response_topic;    // MQTT 5 property, "" when absent
    std::string correlation_data;  // MQTT 5 property, "" when absent
    bool retained = false;
    std::optional<std::uint32_t> expiry_s;  // MQTT 5 message expiry interval (what was left of it)
    std::int64_t received_ms = 0;           // Unix ms, when Paho handed it over
};

struct mqtt_message_out {
    std::string topic;
    std::string payload;
    int qos = 0;
    bool retained = false;
    std::string correlation_data;  // MQTT 5 only; "" for none
};

struct mqtt_client_handlers {
    std::function<void()> connected;                      // after every successful (re)connect
    std::function<void(std::string cause)> disconnected;  // the connection was lost
    std::function<void(mqtt_message_in)> message;         // a message on a subscribed topic
    std::function<void()> publish_done;                   // one publish left flight (sent or failed)
};

class mqtt_client : public std::enable_shared_from_this<mqtt_client> {
  public:
    using strand = boost::asio::strand<boost::asio::any_io_executor>;
    // Messages Paho may hold before it has written them: well above what the bridge keeps in flight.
    static constexpr int max_buffered_messages = 1024;

    // Handlers run on `strand`. Throws std::runtime_error when Paho refuses the settings (a bad URI).
    static std::shared_ptr<mqtt_client> create(strand executor, const mqtt_config& config,
                                               std::string client_id, mqtt_message_out will,
                                               mqtt_client_handlers handlers,
                                               std::shared_ptr<spdlog::logger> log);
    ~mqtt_client();

    // On the strand from here on.
    void start();  // the first connect attempt
    bool connected() const { return connected_; }
    std::size_t in_flight() const { return in_flight_; }
    std::uint64_t connects() const { return connects_; }
    // The broker it is connected to (one of mqtt.brokers, as configured); empty while disconnected.
    const std::string& broker() const { return broker_; }
    // mqtt.protocol, or 3.1.1 once a broker refused MQTT 5.
    mqtt_protocol protocol() const { return protocol_; }
    // The session of the last connect: "clean" (mqtt.session_expiry_s 0: a new one every time), "kept"
    // (the broker had kept it) or "new" (it had not).
    const char* session() const {
        if (config_.session_expiry.count() == 0) return "clean";
        return session_present_ ? "kept" : "new";
    }
    // False (nothing sent) while disconnected or when Paho refuses it.
    bool publish(const mqtt_message_out& m);
    // Kept: made again after a refusal while connected (after resubscribe_delay, doubling up to 30 s).
    // The caller subscribes again after each connect.
    void subscribe(const std::vector<std::string>& filters, int qos);
    static constexpr std::chrono::milliseconds resubscribe_delay{1000};
    // The first attempt after a lost connection, to the next broker: after a wait drawn from
    // [after_loss_delay, 9 * after_loss_delay], so that a fleet that lost its node at one instant
    // does not come back in one burst.
    static constexpr std::chrono::milliseconds after_loss_delay{100};
    // A subscription of its own, beside subscribe()'s and not made again after a reconnect (the
    // retained birth check's); nothing while disconnected.
    void watch(const std::string& filter, int qos);
    void unwatch(const std::string& filter);
    // Stops reconnecting; if connected, publishes `last`, waits until it is delivered (QoS 1: the
    // broker acknowledged it) but at most `timeout`, and disconnects without waiting for anything
    // else. Calls `done` on the strand (at once when not connected).
    void stop(const mqtt_message_out& last, std::chrono::milliseconds timeout, std::function<void()> done);

  private:
    class listener;
    struct paho;
    mqtt_client(strand executor, const mqtt_config& config, std::string client_id, mqtt_message_out will,
                mqtt_client_handlers handlers, std::shared_ptr<spdlog::logger> log);
    // The connect options for protocol_ (mqtt.protocol, or 3.1.1 after a broker refused MQTT 5), aimed
    // at order_.front(); made again with every Paho client, after it.
    void make_options();
    // A Paho client for protocol_, of a new generation_, its listeners made and callbacks installed.
    std::unique_ptr<paho> make_paho();
    void make_listeners(paho& p);
    void install_callbacks(mqtt::async_client& cli);
    // The used client is destroyed on retirer_ and a new one made on the strand; do_connect() follows
    // if an attempt is due.
    void renew_paho_client();
    void on_renewed();            // on the strand, the used client destroyed
    bool refused_mqtt_5() const;  // the last connect failed for the protocol version
    void do_connect();
    // The brokers in the order the next attempts try them: from mqtt.brokers[first] on, wrapping.
    void try_brokers_from(std::size_t first);
    void aim_at_front();                // the next attempt goes to order_.front() alone
    std::string brokers_tried() const;  // for the log: "tcp://a:1883" or "any of tcp://a, tcp://b"
    void on_connect_result(bool ok);
    void log_connected();  // names the broker, and with a kept session whether the broker had it
    // The warning for a failed connect, with a reason a person can act on (connect_failure.hpp); when
    // Paho gives none, after broker_probe has asked the broker itself (TCP, TLS handshake).
    void log_connect_failure(std::chrono::milliseconds wait, spdlog::level::level_enum level);
    void on_lost(std::string cause);
    void on_subscribe_refused(const std::string& what);
    std::chrono::milliseconds schedule_reconnect();  // the wait until the attempt
    std::shared_ptr<const mqtt::message> make_paho_message(const mqtt_message_out& m) const;
    void disconnect_now();  // stop(): `last` is through or given up on
    void finish_stop();     // stop(): disconnected; calls the stop's `done`

    strand strand_;
    mqtt_config config_;
    mqtt_protocol protocol_ = mqtt_protocol::v5;
    std::string client_id_;
    mqtt_message_out will_;
    mqtt_client_handlers handlers_;
    std::shared_ptr<spdlog::logger> log_;
    boost::asio::steady_timer retry_timer_;
    boost::asio::steady_timer stop_timer_;  // bounds stop()'s waits
    boost::asio::steady_timer resubscribe_timer_;
    bool resubscribe_pending_ = false;
    std::uint64_t refused_subscribes_ = 0;  // since the last connect (for the log)
    std::uint64_t resubscribe_rounds_ = 0;  // since the last connect: the retries' backoff
    std::vector<std::string> filters_;      // the last subscribe()'s, made again after a refusal
    int filters_qos_ = 0;
    reconnect_backoff backoff_;
    std::minstd_rand jitter_;  // the wait after a loss
    bool connected_ = false;
    bool connecting_ = false;
    bool stopping_ = false;
    bool disconnecting_ = false;
    std::uint64_t failed_attempts_ = 0;  // since the last connect (for the log)
    std::size_t in_flight_ = 0;
    std::uint64_t connects_ = 0;
    std::string broker_;              // connected to; empty while disconnected
    std::vector<std::string> order_;  // the brokers of a round, the next attempt's first
    std::size_t untried_ = 0;         // brokers of this round not tried yet
    int failure_rc_ = 0;              // of the last failed action (set by the listener, on the strand)
    int failure_reason_ = 0;          // MQTT 5 reason code of it, 0 if none
    bool session_present_ = false;    // the last CONNACK's: the broker had kept the session
    std::unique_ptr<paho> paho_;      // null while renewing_
    // After paho_, so freed before it (Paho's heap ends with its last client; make_options()).
    std::unique_ptr<mqtt::connect_options> options_;
    std::uint64_t generation_ = 0;  // paho_'s: what an older client reports is ignored
    bool fresh_client_ = false;     // paho_ has made no attempt yet
    bool renewing_ = false;
    bool connect_due_ = false;  // an attempt waits for the new client
    std::function<void()> stop_done_;
    // Destroys used Paho clients (with their listeners, which post to the strand and hold this client
    // weakly); its destructor waits for a destruction under way.
    worker_thread retirer_{2};
};

// Paho's MQTT version number for the config's protocol.
int paho_mqtt_version(mqtt_protocol p);
// "5" or "3.1.1", as the config, the birth and the health say it.
const char* protocol_name(mqtt_protocol p);

}  // namespace gw::api
