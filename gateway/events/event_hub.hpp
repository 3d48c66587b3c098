#pragma once
// Fan-out of gateway events to subscribers (WebSocket sessions, the MQTT bridge), transport-agnostic.
//
// Threads: every public method may be called from any thread; it validates its arguments, posts to
// the hub's strand and returns. All state lives on the strand. Sinks are called on the strand (see
// event_sink.hpp for the credit-based flow control). Owned by the application as a shared_ptr;
// stop() before the io_context goes away closes every subscriber.
//
// Topics and sequence numbers: each topic ("controllers/<id>/state|position|reports|ttl",
// "jobs/<id>") numbers its events 1, 2, 3 ... without gaps and keeps the newest ones in a bounded
// replay buffer (settings: stream_replay, latest_replay).
//
// Retirement: a topic that has ended (a job's, once the job ended: its history is in the job store)
// leaves the hub a grace period after retire_topic(), with its replay buffer, its numbering and every
// subscriber's bookkeeping of it, so memory does not grow with the number of topics ever used. Each
// subscriber matching it gets one "retired" event after that topic's last event (or gap): nothing
// more comes on it. A subscriber still reading its replay gets a gap event for what it had not read,
// then the retired event. Later, a subscription that names a remembered retired topic exactly, or
// resumes it, gets a retired event at once rather than silence (settings: max_retired_topics).
//
// Per subscriber, two kinds of pending state, both bounded:
//  * latest-value topics (state, position): one slot per topic holding the newest undelivered event
//    (a newer one replaces it: "coalesced"), delivered at most max_rate_hz times per second per
//    topic. Sequence numbers seen by the client may skip here; that is the policy, not a loss.
//  * stream topics (reports, ttl, jobs): a FIFO of at most queue_limit events. When it is full, new
//    events are not queued and the subscriber later gets one gap event per topic
//    {"type":"gap","missed":n,"from":a,"to":b} before that topic's next event. A subscriber that
//    overflows again within overflow_window while it is not acknowledging (its batch waited slow_ack
//    or longer), or stays full/gapped longer than max_stall without acknowledging, is evicted:
//    event_sink::close("too slow: ..."). A subscriber that keeps acknowledging is never evicted: when
//    the gateway itself falls behind, every subscriber gets gaps, none is closed. Nothing else is
//    ever dropped silently. A resuming subscriber
//    that falls behind its topic's replay buffer while reading it gets a gap event and counts as
//    having overflowed.
// A subscriber that resumes reads the replay buffer lazily (into at most half of its queue), so a large
// replay neither overflows it nor blocks live events of other topics; live events of a topic in
// catch-up are taken from the buffer in order, so there are no duplicates and no holes between
// replay and live. A subscriber never receives the same (topic, sequence) twice, even with
// overlapping filters.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/system/error_code.hpp>
#include <nlohmann/json_fwd.hpp>

#include "gateway/events/event.hpp"
#include "gateway/events/event_hub_settings.hpp"
#include "gateway/events/event_sink.hpp"
#include "gateway/events/topic.hpp"

namespace gw {

using subscriber_id = std::uint64_t;

// For /metrics. Monotonic except `subscribers`, `topics` and `replay_bytes`.
struct event_hub_counters {
    std::uint64_t published = 0;     // events accepted by publish()
    std::uint64_t delivered = 0;     // events handed to sinks (data and gap)
    std::uint64_t replayed = 0;      // of those, data events taken from a replay buffer on resume
    std::uint64_t coalesced = 0;     // latest-value events replaced by a newer one before delivery
    std::uint64_t gap_events = 0;    // gap events created
    std::uint64_t gapped = 0;        // events those gap events reported missing
    std::uint64_t evicted = 0;       // subscribers closed for being too slow
    std::uint64_t subscribers = 0;   // current
    std::uint64_t topics = 0;        // current: topics with a replay buffer
    std::uint64_t replay_bytes = 0;  // current: replay_cost of every event held by replay buffers
    std::uint64_t retired = 0;       // topics retired (retire_topic, or forgotten beyond max_topics)
};

class event_hub : public std::enable_shared_from_this<event_hub> {
  public:
    static std::shared_ptr<event_hub> create(const boost::asio::any_io_executor& executor,
                                             event_hub_settings settings = {}, event_clock clock = {});
    ~event_hub();

    // Publishes one event; `data` is serialised once here. `time` defaults to the clock's now.
    // topic_error when `topic` is not a valid topic name (nothing is published).
    boost::system::error_code publish(std::string topic, const nlohmann::json& data,
                                      std::optional<std::chrono::system_clock::time_point> time = {});
    // `data_json` must hold one valid JSON value.
    boost::system::error_code publish(std::string topic, std::shared_ptr<const std::string> data_json,
                                      std::optional<std::chrono::system_clock::time_point> time = {});

    // Registers a sink; it receives nothing until it subscribes. settings default to the hub's.
    subscriber_id add_subscriber(std::weak_ptr<event_sink> sink);
    subscriber_id add_subscriber(std::weak_ptr<event_sink> sink, subscriber_settings settings);
    void remove_subscriber(subscriber_id id);

    // topic_error when the filter is invalid (nothing changes). Subscribing again to the same filter
    // replaces its options (and resumes again if asked to). Latest-value topics that already have
    // a value are delivered at once (the current state), stream topics from now on unless resumed.
    boost::system::error_code subscribe(subscriber_id id, std::string filter,
                                        subscription_options options = {});
    void unsubscribe(subscriber_id id, std::string filter);

    // The sink finished with its last batch and can take the next one.
    void request_more(subscriber_id id);

    // The topic has ended: `after` from now it is retired (see above). Called again, the time is
    // moved. A topic the hub does not have is ignored. topic_error for an invalid name.
    boost::system::error_code retire_topic(std::string topic, std::chrono::milliseconds after);

    // Re-evaluates time-based decisions (rate limits, stalls, retirements) now. The hub's own timer calls it;
    // tests with a manual clock call it after moving the clock.
    void tick();

    // Closes every subscriber ("event hub stopped") and refuses further work.
    void stop();

    event_hub_counters counters() const;

    // Identifies this hub instance (its creation time, epoch milliseconds): sequence numbers are
    // only comparable within one epoch. See subscription_options::resume_epoch.
    std::uint64_t epoch() const { return epoch_; }

  private:
    struct subscriber;
    struct subscription;
    // A subscriber whose subscriptions match a topic, and the first one that does.
    struct route {
        subscriber* target = nullptr;
        const subscription* via = nullptr;
        // The target's cursor of this topic (a map node: stable until the topic, and these routes
        // with it, are gone), so that an event costs no lookup by name per subscriber.
        std::uint64_t* cursor = nullptr;
    };
    struct topic_state {
        topic_class cls = topic_class::stream;
        std::uint64_t last_seq = 0;
        std::size_t capacity = 0;
        std::deque<std::shared_ptr<const event>> replay;  // consecutive sequence numbers, newest last
        std::uint64_t replay_bytes = 0;                   // replay_cost of what `replay` holds
        std::uint64_t last_publish = 0;                   // publish_order_ when last published
        // Who receives its events: worked out again only after subscriptions changed (routing_version_).
        std::vector<route> routes;
        std::uint64_t routes_version = 0;
        std::optional<std::multimap<std::chrono::steady_clock::time_point, std::string>::iterator>
            retirement;  // its entry in retirements_, once retire_topic() was called

        std::uint64_t oldest() const { return replay.empty() ? last_seq + 1 : replay.front()->sequence; }
    };
    struct subscription {
        std::string filter;
        double max_rate_hz = 0;
    };
    struct latest_slot {
        std::shared_ptr<const event> pending;
        double max_rate_hz = 0;
        std::optional<std::chrono::steady_clock::time_point> next_allowed;
    };
    struct gap_range {
        std::uint64_t from = 0;
        std::uint64_t to = 0;
    };
    struct catch_up_state {
        std::uint64_t next = 0;  // next sequence to read from the topic's replay buffer
        bool reading = false;    // read at least once (a gap now means it fell behind the buffer)
    };
    struct subscriber {
        subscriber_id id = 0;
        std::weak_ptr<event_sink> sink;
        subscriber_settings settings;
        std::vector<subscription> subscriptions;
        std::deque<std::shared_ptr<const event>> queue;  // stream and gap events; <= queue_limit
        std::map<std::string, latest_slot> latest;       // latest-value topics
        std::map<std::string, gap_range> gaps;           // stream events not queued (overflow)
        std::map<std::string, catch_up_state> catch_up;  // resumed topics still reading their replay
        std::map<std::string, std::uint64_t> cursor;     // topic -> highest sequence taken (no duplicates)
        // Retired events that found the queue full, sent once there is room (after the topic's gap).
        std::map<std::string, std::shared_ptr<const event>> retired;
        bool in_flight = false;                              // a batch was delivered, not yet acknowledged
        std::chrono::steady_clock::time_point delivered_at;  // when that batch was delivered
        std::optional<std::chrono::steady_clock::time_point> stalled_since;  // full or gapped, no ack
        std::optional<std::chrono::steady_clock::time_point> last_overflow;
        std::optional<std::string> evict_reason;

        std::size_t room() const {
            return queue.size() >= settings.queue_limit ? 0 : settings.queue_limit - queue.size();
        }
    };

    event_hub(const boost::asio::any_io_executor& executor, event_hub_settings settings, event_clock clock);

    void post_publish(std::string topic, std::shared_ptr<const std::string> data,
                      std::shared_ptr<const nlohmann::json> document,
                      std::optional<std::chrono::system_clock::time_point> time);
    void on_publish(const std::string& topic, std::shared_ptr<const std::string> data,
                    std::shared_ptr<const nlohmann::json> document,
                    std::chrono::system_clock::time_point time);
    void on_subscribe(subscriber_id id, std::string filter, subscription_options options);
    void on_unsubscribe(subscriber_id id, const std::string& filter);
    void on_request_more(subscriber_id id);
    void on_tick();

    topic_state& topic_for(const std::string& name);
    void forget_oldest_topic();
    void on_retire_topic(const std::string& name, std::chrono::milliseconds after);
    void retire_due_topics();
    // Removes the topic, tells its subscribers (a retired event) and remembers its name.
    void retire(std::map<std::string, topic_state>::iterator topic);
    void remember_retired(const std::string& name, std::uint64_t last_seq);
    void push_retired(subscriber& s, const std::shared_ptr<const event>& e);
    void flush_retired(subscriber& s);
    void add_to_replay(topic_state& t, std::shared_ptr<const event> e);
    void drop_oldest_replayed(topic_state& t);
    // Keeps the replay buffers within max_replay_bytes after `published` grew (see the settings).
    void trim_replay(topic_state& published);
    const subscription* matching(const subscriber& s, const std::string& topic) const;
    const std::vector<route>& routes_of(const std::string& name, topic_state& t);
    void offer(subscriber& s, const std::shared_ptr<const event>& e, const topic_state& t,
               const subscription& sub, std::uint64_t& cursor);
    void push_stream(subscriber& s, const std::shared_ptr<const event>& e);
    // Marks it for eviction when it overflows twice within the window. A live overflow counts only
    // while the subscriber is not acknowledging (slow_ack); falling behind its replay always counts.
    void note_overflow(subscriber& s, bool only_if_not_acknowledging);
    void push_gap(subscriber& s, const std::string& topic, std::uint64_t from, std::uint64_t to);
    void fill_catch_up(subscriber& s);
    void flush_gaps(subscriber& s);
    void pump(subscriber& s);
    void settle(subscriber_id id);                   // pump, then evict if it is too slow or its sink is gone
    bool needs_settling(const subscriber& s) const;  // whether settle(s) could do anything now
    void evict(subscriber_id id, std::string reason, bool count);
    // Arms the wake timer for the earliest deadline: retirements, stalls, rate-limited latest values.
    void schedule_wake();
    void schedule_wake_for(subscriber_id id);  // when only this subscriber's deadlines changed
    std::optional<std::chrono::steady_clock::time_point> next_deadline(const subscriber& s) const;
    void arm_wake(std::optional<std::chrono::steady_clock::time_point> at);
    void on_wake(boost::system::error_code ec);

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    event_hub_settings settings_;
    event_clock clock_;
    boost::asio::steady_timer wake_timer_;
    std::optional<std::chrono::steady_clock::time_point> wake_at_;
    bool stall_started_ = false;  // a subscriber began to stall since the last schedule_wake()
    std::uint64_t epoch_ = 0;
    bool stopped_ = false;
    std::map<std::string, topic_state> topics_;
    // Topics waiting to retire, by when (an entry per topic: topic_state::retirement).
    std::multimap<std::chrono::steady_clock::time_point, std::string> retirements_;
    // Retired topics still remembered: name -> {last sequence, retirement number}, and the names in
    // the order they retired (an entry whose number no longer matches is stale: it retired again).
    struct retired_topic {
        std::uint64_t last_seq = 0;
        std::uint64_t number = 0;
    };
    std::map<std::string, retired_topic> retired_;
    std::deque<std::pair<std::string, std::uint64_t>> retired_order_;
    std::uint64_t retirements_done_ = 0;
    std::map<subscriber_id, std::unique_ptr<subscriber>> subscribers_;
    std::uint64_t publish_order_ = 0;
    std::vector<subscriber_id> settle_ids_;  // on_publish's, kept to reuse its storage
    // Moves on whenever a subscriber or a subscription comes or goes: every topic's routes are stale.
    std::uint64_t routing_version_ = 1;
    std::uint64_t replay_bytes_ = 0;  // every topic's replay_bytes
    std::atomic<subscriber_id> next_id_{1};

    struct atomic_counters;
    std::unique_ptr<atomic_counters> counters_;
};

}  // namespace gw
