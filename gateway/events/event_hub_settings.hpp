#pragma once
// Settings of the event hub and of each subscriber. Plain values: the gateway runs the hub on the defaults;
// a subscriber (the MQTT bridge) may bring its own.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>

namespace gw {

struct subscriber_settings {
    // Stream and gap events waiting for this subscriber (latest-value topics keep one slot per topic
    // outside this bound). Overflow policy: new stream events are not queued; the subscriber gets one
    // gap event per topic with the exact count once there is room again.
    std::size_t queue_limit = 256;
    std::size_t max_batch_events = 64;  // stream/gap events per deliver()
    // Evicted (event_sink::close) when it overflows again within this window after an earlier
    // overflow ...
    std::chrono::milliseconds overflow_window{10'000};
    // ... or when its queue stays full (or it has undelivered gaps) for longer than this.
    std::chrono::milliseconds max_stall{5'000};
    // An overflow counts against the subscriber only when its last batch has waited this long for its
    // acknowledgement. One that keeps taking its batches while its queue fills is not slow: the
    // gateway is behind (overloaded), and it gets gap events with exact counts, not a close.
    std::chrono::milliseconds slow_ack{1'000};
};

struct subscription_options {
    // Latest-value topics: at most this many events per second per topic; the newest wins. 0: no
    // rate limit (events still coalesce while the sink is busy).
    double max_rate_hz = 0;
    // Resume: topic name -> the last sequence number the client already has. Events after it that
    // are still in the replay buffer come first, then live events; missing ones become a gap event.
    // A number above the topic's newest sequence (the hub restarted) counts as 0.
    std::map<std::string, std::uint64_t> resume{};
    // The event_hub::epoch() the client's numbers come from (the session tells clients the epoch
    // when they connect). When it differs, the hub was restarted: every resume number counts as 0.
    std::optional<std::uint64_t> resume_epoch{};
};

// Injectable time sources so tests drive rate limits and eviction deterministically.
struct event_clock {
    std::function<std::chrono::steady_clock::time_point()> steady = [] {
        return std::chrono::steady_clock::now();
    };
    std::function<std::chrono::system_clock::time_point()> system = [] {
        return std::chrono::system_clock::now();
    };
};

struct event_hub_settings {
    std::size_t stream_replay = 1000;  // replay buffer per stream topic (reports, ttl, jobs/<id>)
    std::size_t latest_replay = 8;     // replay buffer per latest-value topic (state, position)
    // Every replay buffer together holds at most this much (an event's text plus its bookkeeping:
    // replay_cost). Over it, the topic being published gives up its oldest events down to its fair
    // share (this bound over the number of topics), then the largest buffers theirs; each keeps at
    // least its newest event. So memory follows this bound, not the number of busy report streams.
    std::size_t max_replay_bytes = std::size_t{16} * 1024 * 1024;
    // Distinct topics remembered; beyond it the topic published least recently is forgotten (its
    // replay buffer and sequence counter; a later publish starts again at 1), as if it was retired.
    std::size_t max_topics = 4096;
    // Retired topics whose name and last sequence are remembered, so that a subscription naming one
    // later (or resuming it) is told that it is gone instead of hearing nothing; beyond it the oldest
    // retirement is forgotten. About 150 bytes each.
    std::size_t max_retired_topics = 1024;
    subscriber_settings subscriber{};  // defaults for add_subscriber()
};

}  // namespace gw
