#pragma once
// The MQTT fleet interface of one gateway: event hub -> broker, broker commands -> the API functions.
//
// It is an event hub subscriber (controllers/+/state, position at mqtt.telemetry.position_max_hz,
// reports, ttl, jobs/#) and owns the MQTT client (api/mqtt/mqtt_client.hpp). Topics and payloads:
// api/mqtt/mqtt_topics.hpp, api/mqtt/mqtt_payloads.hpp, openapi/asyncapi.yaml.
//
// After every (re)connect, in this order: the command subscriptions (when enabled), the retained birth
// on <base>/status, every controller's last state, the job state changes queued while disconnected (in
// order), every tracked job's state again (retained), and report batches carrying the count of frames
// dropped meanwhile. While disconnected: positions, reports and TTL events are dropped
// and counted (gw_mqtt_dropped_total; reports also in the next batch's "missed"), controller states
// are kept (the newest per controller), job state changes are queued (mqtt.jobs.queue_limit; the
// oldest is dropped beyond it: counted in gw_mqtt_dropped_total{kind="jobs"}, logged once per outage;
// every tracked job's newest state and every dropped clear are published again on the reconnect).
// Flow control: the bridge asks the hub for more events only while fewer than max_in_flight
// publishes are in flight, so a slow broker backs up into the hub's bounded queue. Evicted by the hub
// as too slow, the bridge subscribes again at once: controller states come back at once (and are
// published, retained), stream topics resume after the last event seen (replayed, or counted gaps).
// A job's retained state is cleared (an empty retained message) mqtt.jobs.retain_finished_s after it
// ends (by default events.ended_job_topic_ttl_s, when the hub retires the job's topic; the hub's
// "retired" event is not a state and only ends the bridge's resume point for that topic).
// stop() publishes "offline" (reason "shutdown") itself; the Last Will covers a crash.
// Everything runs on the bridge's strand; public methods may be called from any thread.

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <nlohmann/json.hpp>

#include "api/common/api_context.hpp"
#include "api/mqtt/mqtt_client.hpp"
#include "api/mqtt/mqtt_payloads.hpp"
#include "api/mqtt/mqtt_topics.hpp"
#include "gateway/config/config.hpp"
#include "gateway/events/event_hub_settings.hpp"
#include "gateway/events/event_sink.hpp"

namespace spdlog {
class logger;
}

namespace gw::api {

class mqtt_commands;
class retained_birth_check;

struct mqtt_bridge_settings {
    mqtt_config config;
    std::string gateway_id;           // resolved (resolve_gateway_id)
    std::string version;              // in the birth message; empty: the project version
    std::string public_url;           // http.public_url, in the birth message
    std::size_t max_in_flight = 256;  // below mqtt_client::max_buffered_messages
    // Its subscription to the event hub: room for bursts (a second of 32 busy report streams), and
    // patience with a slow broker.
    subscriber_settings hub_subscriber{
        .queue_limit = 16384, .max_batch_events = 2048, .max_stall = std::chrono::seconds(30)};
    std::size_t max_tracked_jobs = 10000;  // jobs whose state is kept retained; the oldest ended go first
    std::shared_ptr<spdlog::logger> log;   // "mqtt"; null: the API's logger
};

class mqtt_bridge final : public gw::event_sink, public std::enable_shared_from_this<mqtt_bridge> {
  public:
    static std::shared_ptr<mqtt_bridge> create(std::shared_ptr<api_context> ctx,
                                               mqtt_bridge_settings settings);
    ~mqtt_bridge() override;

    // Subscribes to the hub and starts connecting. Throws std::runtime_error when the client cannot be
    // created (Paho refuses the broker URI).
    void start();
    // "offline" (shutdown), disconnect, leave the hub; `done` runs on the bridge's strand.
    void async_stop(std::function<void()> done);

    // event_sink (called on the hub's strand).
    void deliver(std::vector<std::shared_ptr<const event>> batch) override;
    void close(std::string reason) override;

    const mqtt_topics& topics() const { return topics_; }
    // The bridge's current event hub subscriber (0 before start and after stop); read on the strand
    // or while nothing runs (tests).
    std::uint64_t hub_subscriber() const { return subscriber_; }

  private:
    struct tracked_job {
        mqtt_job_state state;
        std::uint64_t seq = 0;
        std::chrono::system_clock::time_point time;
        std::optional<std::chrono::steady_clock::time_point> clear_at;  // ended: when to clear
    };
    struct controller_cache {
        std::shared_ptr<const event> state;  // the newest state event
        std::string connection;              // its "state" field ("connected", ...)
        mqtt_report_batch reports;
        std::uint64_t dropped_reports = 0;  // while disconnected, for the next batch's "missed"
    };

    mqtt_bridge(std::shared_ptr<api_context> ctx, mqtt_bridge_settings settings);

    void on_connected();
    void on_disconnected();
    // The link as it is now (connected or not, and to which broker) in /metrics and for /api/v1/health.
    void show_link();
    void on_deliver(const std::vector<std::shared_ptr<const event>>& batch);
    void open_batch_window();
    void on_state(const std::string& id, const std::shared_ptr<const event>& e);
    void on_job(const std::string& id, const std::shared_ptr<const event>& e);
    void publish_birth();
    void publish_states();  // every controller's newest state, retained
    void publish_job(const std::string& id, const tracked_job& job);
    void clear_job(const std::string& id);
    void flush_reports();
    void queue_job_message(mqtt_message_out m);
    // items: what a refused message counts as in gw_mqtt_dropped_total (a report batch: its frames).
    bool send(const mqtt_message_out& m, std::string_view kind, std::uint64_t items = 1);
    void drop(std::string_view kind, std::uint64_t n = 1);
    void maybe_request_more();
    void subscribe_hub();
    void schedule_housekeeping();
    void on_housekeeping();

    std::shared_ptr<api_context> ctx_;
    mqtt_bridge_settings settings_;
    std::shared_ptr<spdlog::logger> log_;
    mqtt_topics topics_;
    mqtt_client::strand strand_;
    std::shared_ptr<mqtt_client> client_;
    std::shared_ptr<mqtt_commands> commands_;
    std::unique_ptr<retained_birth_check> birth_check_;
    std::uint64_t subscriber_ = 0;
    bool awaiting_more_ = false;  // a batch was handled, request_more is due when in-flight drops
    bool stopped_ = false;
    std::map<std::string, controller_cache> controllers_;
    std::map<std::string, tracked_job> jobs_;
    // Stream topic (controllers/<id>/reports|ttl, jobs/<id> of a tracked job) -> the last hub
    // sequence seen: where the hub subscription resumes after an eviction.
    std::map<std::string, std::uint64_t> stream_seq_;
    std::deque<mqtt_message_out> job_queue_;  // job state changes while disconnected, in order
    std::uint64_t job_queue_dropped_ = 0;     // oldest changes dropped from it during this outage
    std::set<std::string> lost_clears_;       // job topics whose clearing was dropped from it
    boost::asio::steady_timer housekeeping_;
    boost::asio::steady_timer batch_timer_;
    bool batch_window_open_ =
        false;  // the hub is asked for more once mqtt.telemetry.reports_batch_ms is over
};

}  // namespace gw::api
