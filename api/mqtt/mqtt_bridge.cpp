#include "api/mqtt/mqtt_bridge.hpp"

#include <algorithm>
#include <utility>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/post.hpp>
#include <spdlog/logger.h>

#include "api/common/mqtt_link_state.hpp"
#include "api/mqtt/mqtt_commands.hpp"
#include "api/mqtt/retained_birth_check.hpp"
#include "gateway/common/metrics.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/events/event_json.hpp"
#include "gateway/events/topic.hpp"

namespace gw::api {

namespace net = boost::asio;
using nlohmann::json;

namespace {

void describe_metrics(gw::metrics& m) {
    m.describe("gw_mqtt_connected", metric_type::gauge, "1 while connected to the MQTT broker");
    m.describe("gw_mqtt_connects_total", metric_type::counter, "Successful MQTT (re)connects");
    m.describe("gw_mqtt_broker", metric_type::gauge,
               "1 for the configured broker the gateway is connected to, 0 for the others");
    m.describe("gw_mqtt_published_total", metric_type::counter,
               "MQTT messages handed to the client, by kind");
    m.describe("gw_mqtt_dropped_total", metric_type::counter,
               "Events that did not reach MQTT (disconnected, or the hub reported a gap), by kind");
    m.describe("gw_mqtt_commands_total", metric_type::counter,
               "MQTT commands by outcome (ok, refused, failed, unreadable, unauthenticated, replayed)");
    m.describe("gw_mqtt_job_queue", metric_type::gauge, "Job state changes waiting for the broker");
}

}  // namespace

std::shared_ptr<mqtt_bridge> mqtt_bridge::create(std::shared_ptr<api_context> ctx,
                                                 mqtt_bridge_settings settings) {
    return std::shared_ptr<mqtt_bridge>(new mqtt_bridge(std::move(ctx), std::move(settings)));
}

mqtt_bridge::mqtt_bridge(std::shared_ptr<api_context> ctx, mqtt_bridge_settings settings)
    : ctx_(std::move(ctx)),
      settings_(std::move(settings)),
      log_(settings_.log ? settings_.log : ctx_->log),
      topics_(settings_.config.topic_prefix, settings_.gateway_id),
      strand_(net::make_strand(ctx_->executor)),
      housekeeping_(strand_),
      batch_timer_(strand_) {
    if (settings_.version.empty()) settings_.version = GW_VERSION;
    if (ctx_->metrics) {
        describe_metrics(*ctx_->metrics);
        ctx_->metrics->set("gw_mqtt_connected", {}, 0);
        ctx_->metrics->set("gw_mqtt_job_queue", {}, 0);
    }
}

mqtt_bridge::~mqtt_bridge() = default;

void mqtt_bridge::start() {
    const auto& c = settings_.config;
    mqtt_message_out will{topics_.status(),
                          offline_payload(settings_.gateway_id, "connection lost", std::nullopt),
                          c.qos.status,
                          true,
                          {}};
    std::weak_ptr<mqtt_bridge> weak = weak_from_this();
    mqtt_client_handlers h;
    h.connected = [weak] {
        if (auto self = weak.lock()) self->on_connected();
    };
    h.disconnected = [weak](const std::string&) {
        if (auto self = weak.lock()) self->on_disconnected();
    };
    h.message = [weak](const mqtt_message_in& in) {
        auto self = weak.lock();
        if (!self || self->stopped_) return;
        if (self->birth_check_ && self->birth_check_->on_message(in)) return;
        if (self->commands_) self->commands_->handle(in);
    };
    h.publish_done = [weak] {
        if (auto self = weak.lock()) self->maybe_request_more();
    };
    const auto client_id = c.client_id.empty() ? "asi-gateway-" + settings_.gateway_id : c.client_id;
    client_ = mqtt_client::create(strand_, c, client_id, std::move(will), std::move(h), log_);
    birth_check_ = std::make_unique<retained_birth_check>(
        strand_, topics_.status(),
        retained_birth_check::hooks{[weak](const std::string& topic) {
                                        if (auto self = weak.lock()) self->client_->watch(topic, 0);
                                    },
                                    [weak](const std::string& topic) {
                                        if (auto self = weak.lock()) self->client_->unwatch(topic);
                                    },
                                    [weak] {
                                        if (auto self = weak.lock()) {
                                            self->publish_birth();
                                            self->publish_states();
                                        }
                                    }},
        log_);
    if (c.commands_enabled && (!c.command_signing_keys.empty() || c.accept_bearer_tokens)) {
        commands_ = std::make_shared<mqtt_commands>(
            ctx_, topics_, c.qos.responses, strand_,
            [weak](const mqtt_message_out& m) {
                if (auto self = weak.lock()) self->send(m, "response");
            },
            c.command_max_payload_bytes,
            mqtt_commands::authentication{c.command_signing_keys, c.command_signature_window,
                                          c.accept_bearer_tokens},
            mqtt_commands::freshness{c.command_max_age, c.command_redelivery_window});
    }
    net::post(strand_, [self = shared_from_this()] {
        self->subscribe_hub();
        self->client_->start();
        self->schedule_housekeeping();
    });
}

void mqtt_bridge::subscribe_hub() {
    subscriber_ = ctx_->hub->add_subscriber(weak_from_this(), settings_.hub_subscriber);
    ctx_->hub->subscribe(subscriber_, "controllers/+/state");  // the current states come at once
    ctx_->hub->subscribe(subscriber_, "controllers/+/position",
                         {.max_rate_hz = settings_.config.position_max_hz});
    // Stream topics resume after the last event seen (nothing the first time): after an eviction the
    // hub replays what it still has and announces the rest as gaps (counted), so no job change,
    // report or TTL event disappears without a trace.
    subscription_options resume;
    resume.resume = stream_seq_;
    ctx_->hub->subscribe(subscriber_, "controllers/+/reports", resume);
    ctx_->hub->subscribe(subscriber_, "controllers/+/ttl", resume);
    ctx_->hub->subscribe(subscriber_, "controllers/+/errors", resume);
    ctx_->hub->subscribe(subscriber_, "jobs/#", resume);
    ctx_->hub->subscribe(subscriber_, "recordings/#", resume);
}

void mqtt_bridge::async_stop(std::function<void()> done) {
    // The io_context must not run out of work while Paho finishes the disconnect on its thread.
    auto work = net::make_work_guard(ctx_->executor);
    net::post(strand_, [self = shared_from_this(), done = std::move(done), work = std::move(work)]() mutable {
        if (self->stopped_) {
            if (done) done();
            return;
        }
        self->stopped_ = true;
        self->housekeeping_.cancel();
        self->batch_timer_.cancel();
        if (self->birth_check_) self->birth_check_->disconnected();
        if (self->subscriber_ != 0) self->ctx_->hub->remove_subscriber(self->subscriber_);
        self->subscriber_ = 0;
        if (!self->client_) {
            if (done) done();
            return;
        }
        mqtt_message_out offline{
            self->topics_.status(),
            offline_payload(self->settings_.gateway_id, "shutdown", std::chrono::system_clock::now()),
            self->settings_.config.qos.status,
            true,
            {}};
        // Only a connected client publishes "offline"; a broker never reached has nothing to take down.
        const bool was_connected = self->client_->connected();
        const bool ever_connected = self->client_->connects() > 0;
        self->client_->stop(
            offline, std::chrono::milliseconds(1000),
            [self, done = std::move(done), work = std::move(work), was_connected, ever_connected]() mutable {
                if (self->ctx_->metrics) self->ctx_->metrics->set("gw_mqtt_connected", {}, 0);
                if (self->log_) {
                    if (was_connected)
                        self->log_->info("offline published, disconnected");
                    else if (ever_connected)
                        self->log_->info(
                            "not connected at shutdown: offline not published (the "
                            "broker has the last will)");
                    else
                        self->log_->info("the broker was never reached: nothing published");
                }
                work.reset();
                if (done) done();
            });
    });
}

void mqtt_bridge::deliver(std::vector<std::shared_ptr<const event>> batch) {
    net::post(strand_,
              [self = shared_from_this(), batch = std::move(batch)]() mutable { self->on_deliver(batch); });
}

void mqtt_bridge::close(std::string reason) {
    net::post(strand_, [self = shared_from_this(), reason = std::move(reason)] {
        // "event hub stopped": the gateway is shutting down, nothing to do.
        if (self->stopped_ || !reason.starts_with("too slow")) return;
        // Evicted as too slow (a broker that stalled): join again; latest-value topics come back at
        // once, what was lost of the stream topics is counted.
        if (self->log_)
            self->log_->warn("mqtt: the event hub dropped the bridge ({}); subscribing again", reason);
        self->drop("evicted");
        self->awaiting_more_ = false;
        self->subscribe_hub();
    });
}

// ---- on the strand ----

void mqtt_bridge::on_connected() {
    if (stopped_) return;
    if (ctx_->metrics) ctx_->metrics->increment("gw_mqtt_connects_total", {});
    show_link();
    // Subscribe before the birth: the broker handles one connection's packets in order, so a client
    // that sees the birth and sends a command at once finds the subscription in place.
    if (commands_) client_->subscribe(topics_.command_filters(), settings_.config.qos.responses);
    publish_birth();
    publish_states();
    birth_check_->connected();
    // Job state changes from while we were away, in order; then every tracked job again (retained).
    if (log_ && (!job_queue_.empty() || job_queue_dropped_ != 0))
        log_->info("mqtt: publishing {} job state changes queued while disconnected ({} older ones dropped)",
                   job_queue_.size(), job_queue_dropped_);
    job_queue_dropped_ = 0;
    for (const auto& topic : lost_clears_)
        send({topic, "", settings_.config.qos.jobs, true, {}}, "jobs");
    lost_clears_.clear();
    while (!job_queue_.empty()) {
        send(job_queue_.front(), "jobs");
        job_queue_.pop_front();
    }
    if (ctx_->metrics) ctx_->metrics->set("gw_mqtt_job_queue", {}, 0);
    for (auto& [id, j] : jobs_)
        publish_job(id, j);
    // Frames lost meanwhile are announced at once (an empty batch with "missed").
    flush_reports();
    maybe_request_more();
}

void mqtt_bridge::on_disconnected() {
    show_link();
    birth_check_->disconnected();
    maybe_request_more();  // nothing is in flight any more: keep draining the hub
}

void mqtt_bridge::show_link() {
    const auto& on = client_->broker();  // empty while disconnected
    if (ctx_->metrics) {
        ctx_->metrics->set("gw_mqtt_connected", {}, on.empty() ? 0 : 1);
        for (const auto& broker : settings_.config.brokers)
            ctx_->metrics->set("gw_mqtt_broker", {{"broker", broker}}, broker == on ? 1 : 0);
    }
    if (!ctx_->mqtt_link) return;
    if (on.empty())
        ctx_->mqtt_link->disconnected();
    else
        ctx_->mqtt_link->connected(on, protocol_name(client_->protocol()), client_->session());
}

void mqtt_bridge::publish_birth() {
    mqtt_birth b;
    b.gateway = settings_.gateway_id;
    b.version = settings_.version;
    b.protocol = protocol_name(client_->protocol());  // 3.1.1 after a broker refused 5
    b.prefix = settings_.config.topic_prefix;
    b.broker = client_->broker();
    b.url = settings_.public_url;
    b.commands = commands_ != nullptr;
    for (const auto& s : ctx_->registry.list())
        b.controllers.push_back(birth_controller(state_json(s)));
    b.time = std::chrono::system_clock::now();
    auto payload = birth_payload(b);
    birth_check_->birth_published(payload);
    send({topics_.status(), std::move(payload), settings_.config.qos.status, true, {}}, "status");
}

void mqtt_bridge::publish_states() {
    for (auto& [id, c] : controllers_)
        if (c.state)
            send({topics_.controller(id, "state"), *c.state->message, settings_.config.qos.state, true, {}},
                 "state");
}

void mqtt_bridge::on_deliver(const std::vector<std::shared_ptr<const event>>& batch) {
    if (stopped_) return;
    const auto& qos = settings_.config.qos;
    for (const auto& e : batch) {
        const auto kind = e->address.kind;
        const bool stream = kind == topic_kind::controller_reports || kind == topic_kind::controller_ttl ||
                            kind == topic_kind::controller_errors || kind == topic_kind::job ||
                            kind == topic_kind::recording;
        if (e->kind == event_kind::retired) {
            // The topic left the hub (an ended job's, after events.ended_job_topic_ttl_s): nothing to
            // resume there any more. A job's retained state goes on its own clock (clear_at).
            stream_seq_.erase(e->topic);
            continue;
        }
        if (stream) {
            auto& seen = stream_seq_[e->topic];
            seen = std::max(seen, e->kind == event_kind::gap ? e->gap_to : e->sequence);
        }
        const std::string id(e->key());
        switch (kind) {
            case topic_kind::controller_state:
                if (e->kind == event_kind::data) on_state(id, e);
                break;
            case topic_kind::controller_reports:
                controllers_[id].reports.add(*e);
                break;
            case topic_kind::controller_position:
            case topic_kind::controller_ttl:
            case topic_kind::controller_errors: {
                // The controller's own error log is rare and matters: delivered like state changes.
                const auto leaf = controller_leaf(kind);
                const int level = kind == topic_kind::controller_errors ? qos.state : qos.telemetry;
                if (e->kind == event_kind::gap)
                    drop(leaf, e->missed());
                else
                    send({topics_.controller(id, leaf), *e->message, level, false, {}}, leaf);
                break;
            }
            case topic_kind::job:
                if (e->kind == event_kind::gap)
                    drop("jobs", e->missed());
                else
                    on_job(id, e);
                break;
            case topic_kind::recording:
                // A flush's rows in one message: at most a few per second per recording.
                if (e->kind == event_kind::gap)
                    drop("recordings", e->missed());
                else if (auto topic = topics_.for_hub_topic(kind, id))
                    send({*topic, *e->message, qos.telemetry, false, {}}, "recordings");
                break;
            case topic_kind::other:
                break;
        }
    }
    flush_reports();
    awaiting_more_ = true;
    open_batch_window();
    maybe_request_more();
}

void mqtt_bridge::open_batch_window() {
    const auto window = settings_.config.reports_batch;
    if (window.count() == 0) return;
    // Report frames gather in the hub meanwhile: one message per controller per window, not one per
    // handful of frames (the broker's and the client's cost is per message).
    batch_window_open_ = true;
    batch_timer_.expires_after(window);
    batch_timer_.async_wait([weak = weak_from_this()](boost::system::error_code ec) {
        if (ec) return;
        if (auto self = weak.lock()) {
            self->batch_window_open_ = false;
            self->maybe_request_more();
        }
    });
}

void mqtt_bridge::on_state(const std::string& id, const std::shared_ptr<const event>& e) {
    auto& c = controllers_[id];
    c.state = e;
    const auto connection =
        e->document && e->document->is_object() ? e->document->value("state", "") : std::string();
    const bool changed = connection != c.connection;
    c.connection = connection;
    if (!client_->connected()) return;  // republished on reconnect
    send({topics_.controller(id, "state"), *e->message, settings_.config.qos.state, true, {}}, "state");
    if (changed) publish_birth();  // the birth lists every controller's connection state
}

void mqtt_bridge::flush_reports() {
    const auto now = std::chrono::system_clock::now();
    for (auto& [id, c] : controllers_) {
        if (c.reports.empty() && c.dropped_reports == 0) continue;
        if (!client_->connected()) {
            const auto lost = c.reports.frames() + c.reports.missed();
            drop("reports", c.reports.frames());
            c.dropped_reports += lost;
            c.reports.take_payload(id, now);  // discarded
            continue;
        }
        c.reports.add_missed(c.dropped_reports);
        c.dropped_reports = 0;
        const auto frames = c.reports.frames();
        const auto lost = frames + c.reports.missed();
        // A batch the client refused (its queue full) is lost like one while disconnected: counted per
        // frame, and the next batch's "missed" carries it, so a subscriber is never silently short.
        if (!send({topics_.controller(id, "reports"),
                   c.reports.take_payload(id, now),
                   settings_.config.qos.telemetry,
                   false,
                   {}},
                  "reports", frames))
            c.dropped_reports = lost;
    }
}

void mqtt_bridge::on_job(const std::string& id, const std::shared_ptr<const event>& e) {
    auto& j = jobs_[id];
    if (!e->document || !j.state.apply(*e->document)) {
        if (!j.state.known()) {  // a step of a job we never saw a state of
            jobs_.erase(id);
            stream_seq_.erase(e->topic);
        }
        return;
    }
    j.seq = e->sequence;
    j.time = e->time;
    if (j.state.terminal() && !j.clear_at)
        j.clear_at = std::chrono::steady_clock::now() + settings_.config.retain_finished_jobs;
    publish_job(id, j);
    // Bounded: beyond max_tracked_jobs, the ended job due to be cleared first goes now.
    if (jobs_.size() > settings_.max_tracked_jobs) {
        auto oldest = jobs_.end();
        for (auto it = jobs_.begin(); it != jobs_.end(); ++it)
            if (it->second.clear_at &&
                (oldest == jobs_.end() || *it->second.clear_at < *oldest->second.clear_at))
                oldest = it;
        if (oldest != jobs_.end()) clear_job(oldest->first);
    }
}

void mqtt_bridge::publish_job(const std::string& id, const tracked_job& job) {
    mqtt_message_out m{
        topics_.job_state(id), job.state.payload(job.seq, job.time), settings_.config.qos.jobs, true, {}};
    if (client_->connected())
        send(m, "jobs");
    else
        queue_job_message(std::move(m));
}

void mqtt_bridge::clear_job(const std::string& id) {
    // An empty retained message deletes the retained state at the broker.
    mqtt_message_out m{topics_.job_state(id), "", settings_.config.qos.jobs, true, {}};
    if (client_->connected())
        send(m, "jobs");
    else
        queue_job_message(std::move(m));
    jobs_.erase(id);
    stream_seq_.erase("jobs/" + id);
}

void mqtt_bridge::queue_job_message(mqtt_message_out m) {
    job_queue_.push_back(std::move(m));
    if (job_queue_.size() > settings_.config.job_queue_limit) {
        // The oldest change goes: the newest state of every tracked job is published again on the
        // reconnect anyway, so what is lost is history, and it is counted. A lost clear (an empty
        // retained message) is remembered, or the broker would keep that job's state for ever.
        if (job_queue_.front().payload.empty() && lost_clears_.size() < settings_.max_tracked_jobs)
            lost_clears_.insert(job_queue_.front().topic);
        job_queue_.pop_front();
        drop("jobs");
        if (job_queue_dropped_++ == 0 && log_)
            log_->warn("mqtt: job state queue full ({} changes) while disconnected; dropping the oldest",
                       settings_.config.job_queue_limit);
    }
    if (ctx_->metrics) ctx_->metrics->set("gw_mqtt_job_queue", {}, static_cast<double>(job_queue_.size()));
}

bool mqtt_bridge::send(const mqtt_message_out& m, std::string_view kind, std::uint64_t items) {
    if (client_ && client_->publish(m)) {
        if (ctx_->metrics) ctx_->metrics->increment("gw_mqtt_published_total", {{"kind", std::string(kind)}});
        return true;
    }
    drop(kind, items);
    return false;
}

void mqtt_bridge::drop(std::string_view kind, std::uint64_t n) {
    if (n != 0 && ctx_->metrics)
        ctx_->metrics->increment("gw_mqtt_dropped_total", {{"kind", std::string(kind)}},
                                 static_cast<double>(n));
}

void mqtt_bridge::maybe_request_more() {
    if (!awaiting_more_ || batch_window_open_ || stopped_ || subscriber_ == 0) return;
    if (client_->connected() && client_->in_flight() >= settings_.max_in_flight) return;
    awaiting_more_ = false;
    ctx_->hub->request_more(subscriber_);
}

void mqtt_bridge::schedule_housekeeping() {
    housekeeping_.expires_after(std::chrono::seconds(1));
    housekeeping_.async_wait([weak = weak_from_this()](boost::system::error_code ec) {
        if (ec) return;
        if (auto self = weak.lock()) self->on_housekeeping();
    });
}

void mqtt_bridge::on_housekeeping() {
    if (stopped_) return;
    const auto now = std::chrono::steady_clock::now();
    std::vector<std::string> due;
    for (const auto& [id, j] : jobs_)
        if (j.clear_at && *j.clear_at <= now) due.push_back(id);
    for (const auto& id : due)
        clear_job(id);
    schedule_housekeeping();
}

}  // namespace gw::api
