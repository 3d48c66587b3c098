#include "api/mqtt/mqtt_client.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdint>
#include <mqtt/async_client.h>
#include <optional>
#include <random>
#include <stdexcept>
#include <string_view>
#include <utility>

#include <boost/asio/post.hpp>
#include <spdlog/logger.h>

#include "api/mqtt/broker_probe.hpp"
#include "api/mqtt/connect_failure.hpp"
#include "api/mqtt/tcp_nodelay.hpp"
#include "gateway/common/timestamp.hpp"

namespace gw::api {

namespace net = boost::asio;

int paho_mqtt_version(mqtt_protocol p) {
    return p == mqtt_protocol::v5 ? MQTTVERSION_5 : MQTTVERSION_3_1_1;
}

const char* protocol_name(mqtt_protocol p) {
    return p == mqtt_protocol::v5 ? "5" : "3.1.1";
}

namespace {

bool uses_tls(const std::vector<std::string>& brokers) {
    return std::any_of(brokers.begin(), brokers.end(), [](const std::string& b) {
        return b.starts_with("ssl://") || b.starts_with("mqtts://");
    });
}

std::vector<std::uint16_t> broker_ports(const std::vector<std::string>& brokers) {
    std::vector<std::uint16_t> ports;
    for (const auto& b : brokers) {
        const auto port = parse_broker_address(b).port;
        unsigned value = 0;
        const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
        if (ec == std::errc() && end == port.data() + port.size() && value > 0 && value <= 65535)
            ports.push_back(static_cast<std::uint16_t>(value));
    }
    return ports;
}

std::string describe(const mqtt::token& t) {
    std::string s = "rc " + std::to_string(t.get_return_code());
    if (t.get_reason_code() != mqtt::SUCCESS) s += ", reason " + std::to_string(int(t.get_reason_code()));
    return s;
}

}  // namespace

// A Paho action listener: called on a Paho thread, posts the outcome onto the client's strand.
class mqtt_client::listener final : public mqtt::iaction_listener {
  public:
    using callback = std::function<void(mqtt_client&, bool ok, std::string what)>;
    listener(std::weak_ptr<mqtt_client> owner, strand s, std::uint64_t generation, callback cb)
        : owner_(std::move(owner)), strand_(std::move(s)), generation_(generation), cb_(std::move(cb)) {}

    void on_success(const mqtt::token& t) override { post(true, {}, 0, 0, session_present(t)); }
    void on_failure(const mqtt::token& t) override {
        post(false, describe(t), t.get_return_code(),
             t.get_reason_code() == mqtt::SUCCESS ? 0 : int(t.get_reason_code()));
    }

  private:
    // A connect's CONNACK flag: whether the broker had kept this client's session (none for other actions).
    static std::optional<bool> session_present(const mqtt::token& t) {
        if (t.get_type() != mqtt::token::Type::CONNECT) return std::nullopt;
        try {
            return t.get_connect_response().is_session_present();
        } catch (const mqtt::exception&) {
            return false;
        }
    }

    void post(bool ok, std::string what, int rc = 0, int reason = 0,
              std::optional<bool> session_present = std::nullopt) {
        net::post(strand_, [owner = owner_, generation = generation_, cb = cb_, ok, what = std::move(what),
                            rc, reason, session_present]() mutable {
            // A retired client's late report (its actions failed as it was destroyed) is nobody's.
            if (auto self = owner.lock(); self && self->generation_ == generation) {
                if (!ok) {
                    self->failure_rc_ = rc;
                    self->failure_reason_ = reason;
                } else if (session_present) {
                    self->session_present_ = *session_present;
                }
                cb(*self, ok, std::move(what));
            }
        });
    }
    std::weak_ptr<mqtt_client> owner_;
    strand strand_;
    std::uint64_t generation_;
    callback cb_;
};

// One Paho client and the listeners of its actions, which outlive it (declared before it). `last`
// hears of the message stop() publishes.
struct mqtt_client::paho {
    std::unique_ptr<listener> connect, publish, subscribe, disconnect, last;
    std::unique_ptr<mqtt::async_client> client;
};

std::shared_ptr<mqtt_client> mqtt_client::create(strand executor, const mqtt_config& config,
                                                 std::string client_id, mqtt_message_out will,
                                                 mqtt_client_handlers handlers,
                                                 std::shared_ptr<spdlog::logger> log) {
    std::shared_ptr<mqtt_client> c(new mqtt_client(std::move(executor), config, std::move(client_id),
                                                   std::move(will), std::move(handlers), std::move(log)));
    // The client first: Paho allocates the options' properties on its own heap, which a first client
    // starts (and the last one's destruction ends).
    c->paho_ = c->make_paho();
    c->make_options();
    c->fresh_client_ = true;
    return c;
}

mqtt_client::mqtt_client(strand executor, const mqtt_config& config, std::string client_id,
                         mqtt_message_out will, mqtt_client_handlers handlers,
                         std::shared_ptr<spdlog::logger> log)
    : strand_(std::move(executor)),
      config_(config),
      client_id_(std::move(client_id)),
      will_(std::move(will)),
      handlers_(std::move(handlers)),
      log_(std::move(log)),
      retry_timer_(strand_),
      stop_timer_(strand_),
      resubscribe_timer_(strand_),
      backoff_(config.reconnect_min, config.reconnect_max, std::random_device{}()),
      jitter_(std::random_device{}()) {
    protocol_ = config_.protocol;
    try_brokers_from(0);
}

void mqtt_client::make_options() {
    const int version = paho_mqtt_version(protocol_);
    options_ = std::make_unique<mqtt::connect_options>();
    auto& o = *options_;
    o.set_mqtt_version(version);
    // Without mqtt.session_expiry_s, a new session every time (v5: clean start; v3.1.1: clean
    // session). With it, the broker keeps the session and the commands sent to it meanwhile.
    // Subscriptions are made again after every connect either way.
    const bool keep_session = config_.session_expiry.count() > 0;
    if (version == MQTTVERSION_5) {
        o.set_clean_session(false);
        o.set_clean_start(!keep_session);
        // The broker drops what the gateway would only drop itself: a command payload over the cap
        // (plus room for its topic and properties) never crosses the network to it.
        const auto largest =
            static_cast<std::int32_t>(config_.command_max_payload_bytes + 65536);  // <= 64 MiB
        mqtt::properties props{{mqtt::property::MAXIMUM_PACKET_SIZE, largest}};
        if (keep_session)
            props.add({mqtt::property::SESSION_EXPIRY_INTERVAL,
                       static_cast<std::int32_t>(config_.session_expiry.count())});  // <= 7 days
        o.set_properties(std::move(props));  // Paho C++ 1.2 leaks a copied property list
    } else {
        o.set_clean_start(false);
        o.set_clean_session(!keep_session);
    }
    o.set_keep_alive_interval(static_cast<int>(config_.keepalive.count()));
    o.set_connect_timeout(10);
    o.set_automatic_reconnect(false);
    aim_at_front();
    if (!config_.username.empty()) o.set_user_name(config_.username);
    if (!config_.password.empty()) o.set_password(config_.password);
    mqtt::will_options w(will_.topic, will_.payload, will_.qos, will_.retained);
    o.set_will(w);
    if (uses_tls(config_.brokers)) {
        mqtt::ssl_options ssl;
        if (!config_.tls.ca_file.empty()) ssl.set_trust_store(config_.tls.ca_file);
        if (!config_.tls.cert_file.empty()) ssl.set_key_store(config_.tls.cert_file);
        if (!config_.tls.key_file.empty()) ssl.set_private_key(config_.tls.key_file);
        ssl.set_enable_server_cert_auth(config_.tls.verify);
        ssl.set_verify(config_.tls.verify);  // the host name too
        o.set_ssl(ssl);
    }
}

std::unique_ptr<mqtt_client::paho> mqtt_client::make_paho() {
    mqtt::create_options create(paho_mqtt_version(protocol_));
    // Paho refuses a publish while this many wait in its queue ("No more messages can be buffered"),
    // connected or not; its default, 100, is below the bridge's own bound on messages in flight
    // (mqtt_bridge_settings::max_in_flight), so busy report streams lost whole batches to it.
    create.set_max_buffered_messages(max_buffered_messages);
    auto p = std::make_unique<paho>();
    try {
        p->client =
            std::make_unique<mqtt::async_client>(config_.brokers.front(), client_id_, create, nullptr);
    } catch (const mqtt::exception& e) {
        throw std::runtime_error("mqtt: cannot create the client for " + config_.brokers.front() + ": " +
                                 e.what());
    }
    ++generation_;
    make_listeners(*p);
    install_callbacks(*p->client);
    return p;
}

void mqtt_client::renew_paho_client() {
    if (renewing_) return;
    renewing_ = true;
    auto renewed = [weak = weak_from_this(), s = strand_] {
        net::post(s, [weak] {
            if (auto self = weak.lock()) self->on_renewed();
        });
    };
    auto old = std::move(paho_);
    // The options go with it, freed before it: the last client's destruction ends Paho's heap, and a
    // block Paho allocated before is not freed after (it is no longer in Paho's books).
    auto old_options = std::move(options_);
    if (!old) return renewed();  // the last attempt to make one failed
    try {
        old->client->disable_callbacks();
    } catch (const std::exception&) {
    }
    // Destroying a Paho client waits (about 100 ms) for Paho's threads to stop: not on the strand.
    if (!retirer_.post([old = std::move(old), old_options = std::move(old_options), renewed]() mutable {
            old_options.reset();
            old.reset();
            renewed();
        }))
        renewed();  // never more than one waits; were it refused, the old client still goes in time
}

void mqtt_client::on_renewed() {
    renewing_ = false;
    if (stopping_) return;
    try {
        paho_ = make_paho();
        make_options();
    } catch (const std::exception& e) {
        // Paho took this client's settings before; should it refuse them now, the attempt is retried.
        if (log_) log_->error("{}", e.what());
        schedule_reconnect();
        return;
    }
    fresh_client_ = true;
    if (connect_due_) do_connect();
}

mqtt_client::~mqtt_client() {
    // Paho refuses (throws) while a connect is still in progress, e.g. a shutdown during an attempt:
    // a destructor must not throw, and the callbacks hold only weak references to this client.
    try {
        if (paho_) paho_->client->disable_callbacks();
    } catch (const std::exception&) {
    }
}

void mqtt_client::make_listeners(paho& p) {
    std::weak_ptr<mqtt_client> weak = weak_from_this();
    const auto g = generation_;
    p.connect = std::make_unique<listener>(
        weak, strand_, g, [](mqtt_client& c, bool ok, const std::string&) { c.on_connect_result(ok); });
    p.publish = std::make_unique<listener>(weak, strand_, g, [](mqtt_client& c, bool ok, std::string what) {
        if (c.in_flight_ > 0) --c.in_flight_;
        if (!ok && c.log_) c.log_->debug("publish failed: {}", what);
        if (c.handlers_.publish_done) c.handlers_.publish_done();
    });
    p.subscribe =
        std::make_unique<listener>(weak, strand_, g, [](mqtt_client& c, bool ok, const std::string& what) {
            if (!ok) c.on_subscribe_refused(what);
        });
    p.last = std::make_unique<listener>(weak, strand_, g, [](mqtt_client& c, bool ok, std::string what) {
        if (!ok && c.log_) c.log_->warn("the last message failed: {}", what);
        c.disconnect_now();
    });
    p.disconnect = std::make_unique<listener>(
        weak, strand_, g, [](mqtt_client& c, bool, const std::string&) { c.finish_stop(); });
}

void mqtt_client::install_callbacks(mqtt::async_client& cli) {
    std::weak_ptr<mqtt_client> weak = weak_from_this();
    auto s = strand_;
    const auto g = generation_;
    cli.set_connection_lost_handler([weak, s, g](const std::string& cause) {
        net::post(s, [weak, g, cause] {
            if (auto self = weak.lock(); self && self->generation_ == g)
                self->on_lost(cause.empty() ? "connection lost" : cause);
        });
    });
    cli.set_disconnected_handler([weak, s, g](const mqtt::properties&, mqtt::ReasonCode rc) {
        net::post(s, [weak, g, rc] {
            if (auto self = weak.lock(); self && self->generation_ == g)
                self->on_lost("the broker disconnected us (reason " + std::to_string(int(rc)) + ")");
        });
    });
    cli.set_message_callback([weak, s](const mqtt::const_message_ptr& msg) {
        if (!msg) return;
        mqtt_message_in in;
        in.topic = msg->get_topic();
        in.payload = msg->get_payload_str();
        in.retained = msg->is_retained();
        in.received_ms = epoch_ms(std::chrono::system_clock::now());
        const auto& props = msg->get_properties();
        try {
            if (props.contains(mqtt::property::RESPONSE_TOPIC))
                in.response_topic = mqtt::get<std::string>(props, mqtt::property::RESPONSE_TOPIC);
            if (props.contains(mqtt::property::CORRELATION_DATA))
                in.correlation_data = mqtt::get<std::string>(props, mqtt::property::CORRELATION_DATA);
            if (props.contains(mqtt::property::MESSAGE_EXPIRY_INTERVAL))
                in.expiry_s = mqtt::get<std::uint32_t>(props, mqtt::property::MESSAGE_EXPIRY_INTERVAL);
        } catch (const std::exception&) {
            // a property of an unexpected type: treated as absent
        }
        net::post(s, [weak, in = std::move(in)]() mutable {
            auto self = weak.lock();
            if (self && !self->stopping_ && self->handlers_.message) self->handlers_.message(std::move(in));
        });
    });
}

void mqtt_client::start() {
    do_connect();
}

void mqtt_client::try_brokers_from(std::size_t first) {
    const auto& all = config_.brokers;
    order_.clear();
    for (std::size_t i = 0; i < all.size(); ++i)
        order_.push_back(all[(first + i) % all.size()]);
    untried_ = order_.size();
    aim_at_front();
}

void mqtt_client::aim_at_front() {
    // One broker per Paho attempt, this one: given several, Paho tries them in turn but may report
    // the first as the one it connected to (seen on NATS, a dead node named after a fallback).
    if (!options_) return;
    options_->set_servers(
        std::make_shared<mqtt::string_collection>(std::vector<std::string>{order_.front()}));
}

std::string mqtt_client::brokers_tried() const {
    if (order_.size() == 1) return order_.front();
    std::string out = "any of ";
    for (std::size_t i = 0; i < order_.size(); ++i)
        out += (i ? ", " : "") + order_[i];
    return out;
}

void mqtt_client::do_connect() {
    if (stopping_ || connected_ || connecting_) return;
    // One Paho client per attempt. Debian's Paho (1.3.12, upstream alike) notices a finished TCP
    // connect only when its reading thread's poll times out: 1 s, except in the first poll of the
    // threads a new client starts (10 ms). A client made again after every attempt connects in 0.1 s.
    if (!fresh_client_) {
        connect_due_ = true;
        return renew_paho_client();
    }
    connect_due_ = false;
    fresh_client_ = false;
    connecting_ = true;
    try {
        paho_->client->connect(*options_, nullptr, *paho_->connect);
    } catch (const mqtt::exception& e) {
        connecting_ = false;
        if (log_) log_->warn("connect to {} refused at once: {}", brokers_tried(), e.what());
        schedule_reconnect();
    }
}

bool mqtt_client::refused_mqtt_5() const {
    // MQTT 3.1.1 CONNACK 1 (what a 3.1.1-only broker answers a version it does not know), MQTT 5
    // reason 0x84 (unsupported protocol version).
    return protocol_ == mqtt_protocol::v5 && (failure_rc_ == 1 || failure_reason_ == 0x84);
}

void mqtt_client::on_connect_result(bool ok) {
    connecting_ = false;
    if (stopping_) return;
    if (!ok && refused_mqtt_5()) {
        // Said once, loudly, and kept until a restart: every broker of a cluster is alike.
        if (log_)
            log_->warn(
                "{} refused MQTT 5 (unacceptable protocol version); speaking MQTT 3.1.1 from now on "
                "(set mqtt.protocol to \"3.1.1\" to start with it)",
                brokers_tried());
        protocol_ = mqtt_protocol::v3_1_1;  // the next client and its options are made for it
        return do_connect();
    }
    if (!ok && --untried_ > 0) {
        // The next broker of this round at once; a round that failed on every broker backs off.
        std::rotate(order_.begin(), order_.begin() + 1, order_.end());
        aim_at_front();
        return do_connect();
    }
    if (!ok) {
        // After a whole round the list is back in its order: the next round starts where this one did.
        std::rotate(order_.begin(), order_.begin() + 1, order_.end());
        untried_ = order_.size();
        aim_at_front();
        const auto wait = schedule_reconnect();
        // Attempts come every couple of seconds during an outage: the first failure and then one in 30
        // are warnings, the rest debug.
        const auto level = failed_attempts_++ % 30 == 0 ? spdlog::level::warn : spdlog::level::debug;
        if (log_) log_connect_failure(wait, level);
        return;
    }
    connected_ = true;
    ++connects_;
    failed_attempts_ = 0;
    refused_subscribes_ = 0;
    resubscribe_rounds_ = 0;
    backoff_.reset();
    if (config_.tcp_nodelay) disable_nagle_towards(broker_ports(config_.brokers));
    // The broker this attempt aimed at, its only one (Paho's report may name another).
    broker_ = order_.front();
    if (log_) log_connected();
    if (handlers_.connected) handlers_.connected();
}

void mqtt_client::log_connected() {
    const std::string_view session = this->session();
    if (session == "clean") return log_->info("connected to {} as {}", broker_, client_id_);
    if (session == "kept")
        return log_->info("connected to {} as {}; the broker kept the session", broker_, client_id_);
    // Expected after the first connect, or once the session expired; otherwise the broker lost it,
    // with whatever it held for this gateway (commands sent while it was away).
    log_->log(connects_ > 1 ? spdlog::level::warn : spdlog::level::info,
              "connected to {} as {}; the broker had no session for it: a new one begins{}", broker_,
              client_id_,
              connects_ > 1 ? " (commands sent to the old one while the gateway was away are lost)" : "");
}

void mqtt_client::log_connect_failure(std::chrono::milliseconds wait, spdlog::level::level_enum level) {
    connect_failure f{failure_rc_, failure_reason_, {}, {}};
    const auto failed = failed_attempts_;
    auto write = [log = log_, broker = brokers_tried(), wait, level, failed](const connect_failure& f) {
        log->log(level, "cannot connect to {}: {}; next attempt in {} ms ({} failed so far)", broker,
                 explain_connect_failure(f), wait.count(), failed);
    };
    const bool paho_said_why = f.reason_code != 0 || f.return_code > 0;  // a CONNACK code or reason
    if (paho_said_why || level < spdlog::level::warn) return write(f);
    // Paho's "failure" alone: the broker is asked directly (TCP, and the TLS handshake for mqtts://).
    const auto& broker = order_.front();
    probe_broker(strand_, parse_broker_address(broker), uses_tls({broker}), config_.tls,
                 [f, write](std::string tcp_error, std::string tls_error) mutable {
                     f.tcp_error = std::move(tcp_error);
                     f.tls_error = std::move(tls_error);
                     write(f);
                 });
}

void mqtt_client::on_lost(std::string cause) {
    if (stopping_) return;
    const bool was = connected_;
    connected_ = false;
    in_flight_ = 0;  // Paho fails or forgets them; none completes later
    const auto lost = std::exchange(broker_, std::string());
    if (was) {
        if (log_) log_->warn("connection to {} lost: {}", lost, cause);
        if (handlers_.disconnected) handlers_.disconnected(cause);
    }
    if (connecting_) return;
    // The next broker first, the lost one last (a cluster's node died: another one has the
    // session); later attempts back off.
    const auto& all = config_.brokers;
    const auto at = std::find(all.begin(), all.end(), lost);
    try_brokers_from(at == all.end() ? 0 : static_cast<std::size_t>(at - all.begin()) + 1);
    if (!was) {
        schedule_reconnect();
        return;
    }
    // The attempt after a random wait (after_loss_delay), so that a fleet that lost its node at one
    // instant does not come back in one burst; the used Paho client is replaced meanwhile.
    renew_paho_client();
    std::uniform_int_distribution<long> wait(after_loss_delay.count(), 9 * after_loss_delay.count());
    retry_timer_.expires_after(std::chrono::milliseconds(wait(jitter_)));
    retry_timer_.async_wait([weak = weak_from_this()](boost::system::error_code ec) {
        if (auto self = weak.lock(); self && !ec) self->do_connect();
    });
}

std::chrono::milliseconds mqtt_client::schedule_reconnect() {
    if (stopping_) return {};
    const auto wait = backoff_.next();
    retry_timer_.expires_after(wait);
    retry_timer_.async_wait([weak = weak_from_this()](boost::system::error_code ec) {
        if (ec) return;
        if (auto self = weak.lock()) self->do_connect();
    });
    return wait;
}

std::shared_ptr<const mqtt::message> mqtt_client::make_paho_message(const mqtt_message_out& m) const {
    auto msg = mqtt::make_message(m.topic, m.payload, m.qos, m.retained);
    if (!m.correlation_data.empty() && protocol_ == mqtt_protocol::v5)
        msg->set_properties(mqtt::properties{{mqtt::property::CORRELATION_DATA, m.correlation_data}});
    return msg;
}

bool mqtt_client::publish(const mqtt_message_out& m) {
    if (!connected_ || stopping_) return false;
    try {
        paho_->client->publish(make_paho_message(m), nullptr, *paho_->publish);
        ++in_flight_;
        return true;
    } catch (const mqtt::exception& e) {
        if (log_) log_->debug("publish to {} refused: {}", m.topic, e.what());
        return false;
    }
}

void mqtt_client::subscribe(const std::vector<std::string>& filters, int qos) {
    filters_ = filters;
    filters_qos_ = qos;
    if (!connected_ || filters.empty()) return;
    try {
        // Retain-as-published (MQTT 5): the retain flag arrives as the sender set it, even on live
        // messages, so that a retained command can be recognised (and refused) every time.
        mqtt::subscribe_options options;
        if (protocol_ == mqtt_protocol::v5) options.set_retain_as_published(true);
        for (const auto& f : filters)
            paho_->client->subscribe(f, qos, nullptr, *paho_->subscribe, options);
    } catch (const mqtt::exception& e) {
        if (log_) log_->warn("subscribe refused: {}", e.what());
    }
}

void mqtt_client::watch(const std::string& filter, int qos) {
    if (!connected_ || stopping_) return;
    try {
        paho_->client->subscribe(filter, qos);
    } catch (const mqtt::exception& e) {
        if (log_) log_->debug("subscribe to {} refused: {}", filter, e.what());
    }
}

void mqtt_client::unwatch(const std::string& filter) {
    if (!connected_ || stopping_) return;
    try {
        paho_->client->unsubscribe(filter);
    } catch (const mqtt::exception& e) {
        if (log_) log_->debug("unsubscribe from {} refused: {}", filter, e.what());
    }
}

void mqtt_client::on_subscribe_refused(const std::string& what) {
    if (stopping_ || !connected_) return;  // a lost connection's: the next connect subscribes again
    // A broker may refuse for a while and then take it (a cluster electing the leader of the streams
    // behind its subscriptions): asked again until it does, the first refusal of a connection logged.
    // Every second at first, then less often (a broker that will never allow it, an ACL).
    const auto delay = std::min(resubscribe_delay * (1 << std::min<std::uint64_t>(resubscribe_rounds_, 5)),
                                std::chrono::milliseconds(30'000));
    const auto level = refused_subscribes_++ == 0 ? spdlog::level::warn : spdlog::level::debug;
    if (log_) log_->log(level, "subscribe refused: {}; asking again in {} ms", what, delay.count());
    if (resubscribe_pending_) return;
    resubscribe_pending_ = true;
    ++resubscribe_rounds_;
    resubscribe_timer_.expires_after(delay);
    resubscribe_timer_.async_wait([weak = weak_from_this()](boost::system::error_code ec) {
        auto self = weak.lock();
        if (!self) return;
        self->resubscribe_pending_ = false;
        if (!ec && self->connected_) self->subscribe(self->filters_, self->filters_qos_);
    });
}

void mqtt_client::stop(const mqtt_message_out& last, std::chrono::milliseconds timeout,
                       std::function<void()> done) {
    retry_timer_.cancel();
    if (stopping_) {  // a second stop: the first one calls its own `done`
        if (done) done();
        return;
    }
    stopping_ = true;
    stop_done_ = std::move(done);
    if (!connected_) return finish_stop();
    // `last` has its own listener: once it is delivered (QoS 1: acknowledged; QoS 0: written), the
    // disconnect follows at once instead of waiting out Paho's disconnect timeout. The timer bounds
    // the wait for a broker that does not answer.
    try {
        paho_->client->publish(make_paho_message(last), nullptr, *paho_->last);
    } catch (const mqtt::exception& e) {
        if (log_) log_->debug("last message refused: {}", e.what());
        return disconnect_now();
    }
    stop_timer_.expires_after(timeout);
    stop_timer_.async_wait([weak = weak_from_this()](boost::system::error_code ec) {
        if (ec) return;
        auto self = weak.lock();
        if (!self) return;
        if (self->log_) self->log_->warn("the last message was not acknowledged in time; disconnecting");
        self->disconnect_now();
    });
}

void mqtt_client::disconnect_now() {
    if (disconnecting_) return;
    disconnecting_ = true;
    stop_timer_.cancel();
    try {
        // Nothing else is worth waiting for: `last` is through (or given up on).
        paho_->client->disconnect(0, nullptr, *paho_->disconnect);
    } catch (const std::exception& e) {
        if (log_) log_->debug("disconnect: {}", e.what());
        return finish_stop();
    }
    // Paho reports the disconnect on success and failure; this bounds a report that never comes.
    stop_timer_.expires_after(std::chrono::milliseconds(500));
    stop_timer_.async_wait([weak = weak_from_this()](boost::system::error_code ec) {
        if (ec) return;
        if (auto self = weak.lock()) self->finish_stop();
    });
}

void mqtt_client::finish_stop() {
    stop_timer_.cancel();
    connected_ = false;
    if (auto done = std::exchange(stop_done_, nullptr)) done();
}

}  // namespace gw::api
