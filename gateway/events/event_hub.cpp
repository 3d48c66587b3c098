#include "gateway/events/event_hub.hpp"

#include <algorithm>
#include <set>
#include <utility>

#include <boost/asio/post.hpp>
#include <nlohmann/json.hpp>

#include "gateway/common/json_text.hpp"
#include "gateway/common/timestamp.hpp"

namespace gw {

namespace net = boost::asio;
using std::chrono::steady_clock;

struct event_hub::atomic_counters {
    std::atomic<std::uint64_t> published{0};
    std::atomic<std::uint64_t> delivered{0};
    std::atomic<std::uint64_t> replayed{0};
    std::atomic<std::uint64_t> coalesced{0};
    std::atomic<std::uint64_t> gap_events{0};
    std::atomic<std::uint64_t> gapped{0};
    std::atomic<std::uint64_t> evicted{0};
    std::atomic<std::uint64_t> subscribers{0};
    std::atomic<std::uint64_t> topics{0};
    std::atomic<std::uint64_t> replay_bytes{0};
    std::atomic<std::uint64_t> retired{0};
};

namespace {

void add(std::atomic<std::uint64_t>& counter, std::uint64_t n = 1) {
    counter.fetch_add(n, std::memory_order_relaxed);
}

std::string millis(std::chrono::milliseconds ms) {
    return std::to_string(ms.count()) + " ms";
}

// What an event in a replay buffer costs: its text, the event itself, and the heap blocks of the
// event, its two strings and their shared_ptr control blocks (an estimate of allocator overhead).
std::uint64_t replay_cost(const event& e) {
    constexpr std::uint64_t bookkeeping = sizeof(event) + std::uint64_t{5} * 32;
    return bookkeeping + e.topic.size() + (e.data ? e.data->size() : 0) + (e.message ? e.message->size() : 0);
}

}  // namespace

std::shared_ptr<event_hub> event_hub::create(const net::any_io_executor& executor,
                                             event_hub_settings settings, event_clock clock) {
    return std::shared_ptr<event_hub>(new event_hub(executor, settings, std::move(clock)));
}

event_hub::event_hub(const net::any_io_executor& executor, event_hub_settings settings, event_clock clock)
    : strand_(net::make_strand(executor)),
      settings_(settings),
      clock_(std::move(clock)),
      wake_timer_(strand_),
      counters_(std::make_unique<atomic_counters>()) {
    epoch_ = static_cast<std::uint64_t>(std::max<std::int64_t>(epoch_ms(clock_.system()), 0));
}

event_hub::~event_hub() = default;

event_hub_counters event_hub::counters() const {
    auto get = [](const std::atomic<std::uint64_t>& c) { return c.load(std::memory_order_relaxed); };
    return {get(counters_->published),    get(counters_->delivered),   get(counters_->replayed),
            get(counters_->coalesced),    get(counters_->gap_events),  get(counters_->gapped),
            get(counters_->evicted),      get(counters_->subscribers), get(counters_->topics),
            get(counters_->replay_bytes), get(counters_->retired)};
}

// ---- public entry points: validate, post to the strand ----

boost::system::error_code event_hub::publish(std::string topic, const nlohmann::json& data,
                                             std::optional<std::chrono::system_clock::time_point> time) {
    if (auto ec = validate_topic_name(topic)) return ec;
    std::shared_ptr<const nlohmann::json> document;
    if (carries_document(address_of(topic).kind)) document = std::make_shared<const nlohmann::json>(data);
    post_publish(std::move(topic), std::make_shared<const std::string>(to_json_text(data)),
                 std::move(document), time);
    return {};
}

boost::system::error_code event_hub::publish(std::string topic, std::shared_ptr<const std::string> data_json,
                                             std::optional<std::chrono::system_clock::time_point> time) {
    if (auto ec = validate_topic_name(topic)) return ec;
    post_publish(std::move(topic), std::move(data_json), {}, time);
    return {};
}

void event_hub::post_publish(std::string topic, std::shared_ptr<const std::string> data,
                             std::shared_ptr<const nlohmann::json> document,
                             std::optional<std::chrono::system_clock::time_point> time) {
    auto when = time ? *time : clock_.system();
    net::post(strand_, [self = shared_from_this(), topic = std::move(topic), data = std::move(data),
                        document = std::move(document), when]() mutable {
        self->on_publish(topic, std::move(data), std::move(document), when);
    });
}

subscriber_id event_hub::add_subscriber(std::weak_ptr<event_sink> sink) {
    return add_subscriber(std::move(sink), settings_.subscriber);
}

subscriber_id event_hub::add_subscriber(std::weak_ptr<event_sink> sink, subscriber_settings settings) {
    auto id = next_id_.fetch_add(1);
    settings.queue_limit = std::max<std::size_t>(settings.queue_limit, 2);  // a gap and its next event
    settings.max_batch_events = std::max<std::size_t>(settings.max_batch_events, 1);
    net::post(strand_, [self = shared_from_this(), id, sink = std::move(sink), settings]() mutable {
        if (self->stopped_) {
            if (auto s = sink.lock()) s->close("event hub stopped");
            return;
        }
        auto s = std::make_unique<subscriber>();
        s->id = id;
        s->sink = std::move(sink);
        s->settings = settings;
        self->subscribers_.emplace(id, std::move(s));
        ++self->routing_version_;
        add(self->counters_->subscribers);
    });
    return id;
}

void event_hub::remove_subscriber(subscriber_id id) {
    net::post(strand_, [self = shared_from_this(), id] {
        if (self->subscribers_.erase(id) != 0) self->counters_->subscribers.fetch_sub(1);
        ++self->routing_version_;
    });
}

boost::system::error_code event_hub::subscribe(subscriber_id id, std::string filter,
                                               subscription_options options) {
    if (auto ec = validate_topic_filter(filter)) return ec;
    net::post(strand_, [self = shared_from_this(), id, filter = std::move(filter),
                        options = std::move(options)]() mutable {
        self->on_subscribe(id, std::move(filter), std::move(options));
    });
    return {};
}

void event_hub::unsubscribe(subscriber_id id, std::string filter) {
    net::post(strand_, [self = shared_from_this(), id, filter = std::move(filter)] {
        self->on_unsubscribe(id, filter);
    });
}

void event_hub::request_more(subscriber_id id) {
    net::post(strand_, [self = shared_from_this(), id] { self->on_request_more(id); });
}

boost::system::error_code event_hub::retire_topic(std::string topic, std::chrono::milliseconds after) {
    if (auto ec = validate_topic_name(topic)) return ec;
    net::post(strand_, [self = shared_from_this(), topic = std::move(topic), after] {
        self->on_retire_topic(topic, after);
    });
    return {};
}

void event_hub::tick() {
    net::post(strand_, [self = shared_from_this()] { self->on_tick(); });
}

void event_hub::stop() {
    net::post(strand_, [self = shared_from_this()] {
        self->stopped_ = true;
        self->wake_timer_.cancel();
        auto subscribers = std::move(self->subscribers_);
        self->subscribers_.clear();
        ++self->routing_version_;
        self->counters_->subscribers.store(0);
        for (auto& [id, s] : subscribers)
            if (auto sink = s->sink.lock()) sink->close("event hub stopped");
        self->topics_.clear();
        self->retirements_.clear();
        self->retired_.clear();
        self->retired_order_.clear();
        self->counters_->topics.store(0);
        self->replay_bytes_ = 0;
        self->counters_->replay_bytes.store(0);
    });
}

// ---- on the strand ----

event_hub::topic_state& event_hub::topic_for(const std::string& name) {
    auto it = topics_.find(name);
    if (it != topics_.end()) return it->second;
    if (topics_.size() >= std::max<std::size_t>(settings_.max_topics, 1)) forget_oldest_topic();
    topic_state t;
    t.cls = classify_topic(name);
    t.capacity = std::max<std::size_t>(
        t.cls == topic_class::latest_value ? settings_.latest_replay : settings_.stream_replay, 1);
    retired_.erase(name);  // in use again (numbered from 1)
    auto& created = topics_.emplace(name, std::move(t)).first->second;
    counters_->topics.store(topics_.size());
    return created;
}

void event_hub::forget_oldest_topic() {
    auto oldest = std::min_element(topics_.begin(), topics_.end(), [](const auto& a, const auto& b) {
        return a.second.last_publish < b.second.last_publish;
    });
    if (oldest == topics_.end()) return;
    // Its numbering starts again at 1: for its subscribers, it is retired.
    retire(oldest);
}

void event_hub::on_retire_topic(const std::string& name, std::chrono::milliseconds after) {
    if (stopped_) return;
    auto it = topics_.find(name);
    if (it == topics_.end()) return;
    auto& t = it->second;
    if (t.retirement) retirements_.erase(*t.retirement);
    t.retirement =
        retirements_.emplace(clock_.steady() + std::max(after, std::chrono::milliseconds(0)), name);
    retire_due_topics();  // a grace period of 0: now
    schedule_wake();
}

void event_hub::retire_due_topics() {
    const auto now = clock_.steady();
    while (!retirements_.empty() && retirements_.begin()->first <= now) {
        auto t = topics_.find(retirements_.begin()->second);
        if (t == topics_.end()) {  // cannot happen (retire() erases the entry): do not loop on it
            retirements_.erase(retirements_.begin());
            continue;
        }
        retire(t);
    }
}

void event_hub::retire(std::map<std::string, topic_state>::iterator topic) {
    const std::string name = topic->first;
    const auto last_seq = topic->second.last_seq;
    if (topic->second.retirement) retirements_.erase(*topic->second.retirement);
    replay_bytes_ -= topic->second.replay_bytes;
    counters_->replay_bytes.store(replay_bytes_, std::memory_order_relaxed);
    topics_.erase(topic);
    counters_->topics.store(topics_.size());
    add(counters_->retired);
    remember_retired(name, last_seq);

    std::shared_ptr<const event> notice;  // one event shared by every subscriber
    std::vector<subscriber_id> told;
    for (auto& [id, s] : subscribers_) {
        // Its numbering is gone: per-subscriber bookkeeping of it must go too.
        s->cursor.erase(name);
        if (auto c = s->catch_up.find(name); c != s->catch_up.end()) {
            // What it had not read of the replay buffer can no longer come: a gap says so.
            if (c->second.next <= last_seq) s->gaps.emplace(name, gap_range{c->second.next, last_seq});
            s->catch_up.erase(c);
        }
        if (auto slot = s->latest.find(name); slot != s->latest.end()) {
            if (slot->second.pending)
                push_stream(*s, slot->second.pending);  // still delivered, before the notice
            s->latest.erase(slot);
        }
        if (!matching(*s, name)) continue;
        if (!notice) notice = make_retired_event(name, last_seq, clock_.system());
        push_retired(*s, notice);
        told.push_back(id);
    }
    for (auto id : told)
        settle(id);
}

void event_hub::remember_retired(const std::string& name, std::uint64_t last_seq) {
    const auto number = ++retirements_done_;
    retired_[name] = retired_topic{last_seq, number};
    retired_order_.emplace_back(name, number);
    while (retired_order_.size() > settings_.max_retired_topics) {
        const auto& [oldest, n] = retired_order_.front();
        if (auto it = retired_.find(oldest); it != retired_.end() && it->second.number == n)
            retired_.erase(it);
        retired_order_.pop_front();
    }
}

void event_hub::push_retired(subscriber& s, const std::shared_ptr<const event>& e) {
    // After the topic's gap event when one waits, and only into free room: it is never dropped.
    if (!s.gaps.contains(e->topic) && s.room() > 0) {
        s.retired.erase(e->topic);
        s.queue.push_back(e);
        return;
    }
    s.retired[e->topic] = e;
}

void event_hub::flush_retired(subscriber& s) {
    for (auto it = s.retired.begin(); it != s.retired.end() && s.room() > 0;) {
        if (s.gaps.contains(it->first)) {
            ++it;
            continue;
        }
        s.queue.push_back(std::move(it->second));
        it = s.retired.erase(it);
    }
}

void event_hub::add_to_replay(topic_state& t, std::shared_ptr<const event> e) {
    const auto cost = replay_cost(*e);
    t.replay.push_back(std::move(e));
    t.replay_bytes += cost;
    replay_bytes_ += cost;
    while (t.replay.size() > t.capacity)
        drop_oldest_replayed(t);
    trim_replay(t);
    counters_->replay_bytes.store(replay_bytes_, std::memory_order_relaxed);
}

void event_hub::drop_oldest_replayed(topic_state& t) {
    const auto cost = replay_cost(*t.replay.front());
    t.replay.pop_front();
    t.replay_bytes -= cost;
    replay_bytes_ -= cost;
}

void event_hub::trim_replay(topic_state& published) {
    const std::uint64_t bound = settings_.max_replay_bytes;
    if (replay_bytes_ <= bound) return;
    const std::uint64_t fair_share = bound / std::max<std::size_t>(topics_.size(), 1);
    while (replay_bytes_ > bound && published.replay_bytes > fair_share && published.replay.size() > 1)
        drop_oldest_replayed(published);
    // Still over: other buffers hold more than their share (they grew when there were fewer topics).
    while (replay_bytes_ > bound) {
        topic_state* largest = nullptr;
        for (auto& [name, t] : topics_)
            if (t.replay.size() > 1 && (!largest || t.replay_bytes > largest->replay_bytes)) largest = &t;
        if (!largest) return;  // every buffer is down to its newest event
        drop_oldest_replayed(*largest);
    }
}

const event_hub::subscription* event_hub::matching(const subscriber& s, const std::string& topic) const {
    for (const auto& sub : s.subscriptions)
        if (topic_matches(sub.filter, topic)) return &sub;
    return nullptr;
}

void event_hub::on_publish(const std::string& topic, std::shared_ptr<const std::string> data,
                           std::shared_ptr<const nlohmann::json> document,
                           std::chrono::system_clock::time_point time) {
    if (stopped_) return;
    auto& t = topic_for(topic);
    auto e = make_data_event(topic, ++t.last_seq, time, std::move(data), std::move(document));
    add_to_replay(t, e);
    t.last_publish = ++publish_order_;
    add(counters_->published);

    const auto& routes = routes_of(topic, t);
    settle_ids_.clear();
    for (const auto& r : routes) {
        offer(*r.target, e, t, *r.via, *r.cursor);
        if (needs_settling(*r.target)) settle_ids_.push_back(r.target->id);
    }
    // settle() may evict (and so change the routes): by id from here on.
    for (auto id : settle_ids_)
        settle(id);
    // Its deadlines scan every subscriber: looked at again only when this event can have added one (a
    // rate-limited latest value, or a subscriber that just started to stall), not for every frame.
    if (t.cls == topic_class::latest_value || stall_started_) schedule_wake();
}

const std::vector<event_hub::route>& event_hub::routes_of(const std::string& name, topic_state& t) {
    if (t.routes_version == routing_version_) return t.routes;
    t.routes.clear();
    for (auto& [id, s] : subscribers_)
        if (const auto* sub = matching(*s, name)) t.routes.push_back({s.get(), sub, &s->cursor[name]});
    t.routes_version = routing_version_;
    return t.routes;
}

void event_hub::offer(subscriber& s, const std::shared_ptr<const event>& e, const topic_state& t,
                      const subscription& sub, std::uint64_t& cursor) {
    // A topic in catch-up reads this event from the replay buffer in its turn.
    if (!s.catch_up.empty() && s.catch_up.contains(e->topic)) return;
    if (e->sequence <= cursor) return;
    cursor = e->sequence;
    if (t.cls == topic_class::latest_value) {
        auto& slot = s.latest[e->topic];
        if (slot.pending) add(counters_->coalesced);
        slot.pending = e;
        slot.max_rate_hz = sub.max_rate_hz;
        return;
    }
    push_stream(s, e);
}

void event_hub::push_stream(subscriber& s, const std::shared_ptr<const event>& e) {
    auto gap = s.gaps.find(e->topic);
    if (gap != s.gaps.end()) {
        // This topic already lost events: its gap event must come before anything newer.
        if (s.room() >= 2) {
            auto [from, to] = gap->second;
            s.gaps.erase(gap);
            push_gap(s, e->topic, from, to);
            s.queue.push_back(e);
        } else {
            gap->second.to = e->sequence;
        }
        return;
    }
    if (s.room() >= 1) {
        s.queue.push_back(e);
        return;
    }
    // Overflow: the event is not queued; the subscriber hears about it through a gap event.
    if (s.gaps.empty()) note_overflow(s, true);
    s.gaps.emplace(e->topic, gap_range{e->sequence, e->sequence});
}

void event_hub::note_overflow(subscriber& s, bool only_if_not_acknowledging) {
    auto now = clock_.steady();
    // It takes its batches: the overflow is the gateway's backlog, not this subscriber's.
    if (only_if_not_acknowledging && (!s.in_flight || now - s.delivered_at < s.settings.slow_ack)) return;
    if (s.last_overflow && now - *s.last_overflow < s.settings.overflow_window)
        s.evict_reason = "too slow: send queue overflowed twice within " + millis(s.settings.overflow_window);
    s.last_overflow = now;
}

void event_hub::push_gap(subscriber& s, const std::string& topic, std::uint64_t from, std::uint64_t to) {
    s.queue.push_back(make_gap_event(topic, from, to, clock_.system()));
    add(counters_->gap_events);
    add(counters_->gapped, to - from + 1);
}

void event_hub::flush_gaps(subscriber& s) {
    for (auto it = s.gaps.begin(); it != s.gaps.end() && s.room() > 0;) {
        push_gap(s, it->first, it->second.from, it->second.to);
        it = s.gaps.erase(it);
    }
}

void event_hub::fill_catch_up(subscriber& s) {
    // Replay may use only half of the queue: live events of other topics keep room while it catches up.
    auto replay_room = [&] {
        auto limit = std::max<std::size_t>(s.settings.queue_limit / 2, 1);
        return s.queue.size() < limit;
    };
    for (auto it = s.catch_up.begin(); it != s.catch_up.end();) {
        auto t = topics_.find(it->first);
        if (t == topics_.end()) {
            it = s.catch_up.erase(it);
            continue;
        }
        auto& [next, reading] = it->second;
        const auto& topic = t->second;
        while (replay_room() && next <= topic.last_seq) {
            auto oldest = topic.oldest();
            if (next < oldest) {  // already gone from the replay buffer
                // Gone before it was asked for: a plain gap. Gone while it read: it is too slow.
                if (reading) note_overflow(s, false);
                push_gap(s, it->first, next, oldest - 1);
                next = oldest;
                reading = true;
                continue;
            }
            s.queue.push_back(topic.replay[next - oldest]);
            add(counters_->replayed);
            s.cursor[it->first] = next;
            ++next;
            reading = true;
        }
        if (next > topic.last_seq)
            it = s.catch_up.erase(it);  // caught up: live from now on
        else
            ++it;
    }
}

void event_hub::pump(subscriber& s) {
    if (s.in_flight) return;
    auto sink = s.sink.lock();
    if (!sink) return;

    flush_gaps(s);
    flush_retired(s);
    fill_catch_up(s);
    std::vector<std::shared_ptr<const event>> batch;
    auto n = std::min(s.queue.size(), s.settings.max_batch_events);
    batch.reserve(n + s.latest.size());
    for (std::size_t i = 0; i < n; ++i) {
        batch.push_back(std::move(s.queue.front()));
        s.queue.pop_front();
    }
    auto now = clock_.steady();
    for (auto& [topic, slot] : s.latest) {
        if (!slot.pending) continue;
        if (slot.next_allowed && now < *slot.next_allowed) continue;
        // Replayed events of this topic still queued go first.
        // (a named copy of the binding: clang 14 cannot capture structured bindings)
        const auto& slot_topic = topic;
        bool queued = std::any_of(s.queue.begin(), s.queue.end(),
                                  [&slot_topic](const auto& e) { return e->topic == slot_topic; });
        if (queued) continue;
        batch.push_back(std::move(slot.pending));
        slot.pending.reset();
        if (slot.max_rate_hz > 0)
            slot.next_allowed = now + std::chrono::duration_cast<steady_clock::duration>(
                                          std::chrono::duration<double>(1.0 / slot.max_rate_hz));
        else
            slot.next_allowed.reset();
    }
    // Keep the queue primed for the next batch.
    flush_gaps(s);
    flush_retired(s);
    fill_catch_up(s);
    if (batch.empty()) return;
    s.in_flight = true;
    s.delivered_at = clock_.steady();
    add(counters_->delivered, batch.size());
    sink->deliver(std::move(batch));
}

bool event_hub::needs_settling(const subscriber& s) const {
    // Waiting for its acknowledgement with room in its queue and nothing lost: a new event changes
    // nothing settle() looks at (most subscribers, most of the time, with a batch window).
    return !s.in_flight || s.evict_reason || s.stalled_since || !s.gaps.empty() ||
           s.queue.size() >= s.settings.queue_limit || s.sink.expired();
}

void event_hub::settle(subscriber_id id) {
    auto it = subscribers_.find(id);
    if (it == subscribers_.end()) return;
    auto& s = *it->second;
    if (s.sink.expired()) {
        subscribers_.erase(it);
        ++routing_version_;
        counters_->subscribers.fetch_sub(1);
        return;
    }
    if (s.evict_reason) return evict(id, *s.evict_reason, true);
    pump(s);
    bool stalled = s.queue.size() >= s.settings.queue_limit || !s.gaps.empty();
    if (!stalled) {
        s.stalled_since.reset();
        return;
    }
    auto now = clock_.steady();
    if (!s.stalled_since) {
        s.stalled_since = now;
        stall_started_ = true;
    }
    if (now - *s.stalled_since > s.settings.max_stall)
        evict(id, "too slow: send queue full for more than " + millis(s.settings.max_stall), true);
}

void event_hub::evict(subscriber_id id, std::string reason, bool count) {
    auto it = subscribers_.find(id);
    if (it == subscribers_.end()) return;
    auto sink = it->second->sink.lock();
    subscribers_.erase(it);
    ++routing_version_;
    counters_->subscribers.fetch_sub(1);
    if (count) add(counters_->evicted);
    if (sink) sink->close(std::move(reason));
}

void event_hub::on_subscribe(subscriber_id id, std::string filter, subscription_options options) {
    auto it = subscribers_.find(id);
    if (it == subscribers_.end()) return;
    auto& s = *it->second;
    auto existing = std::find_if(s.subscriptions.begin(), s.subscriptions.end(),
                                 [&](const auto& sub) { return sub.filter == filter; });
    ++routing_version_;
    if (existing == s.subscriptions.end())
        s.subscriptions.push_back({filter, options.max_rate_hz});
    else
        existing->max_rate_hz = options.max_rate_hz;

    for (auto& [name, t] : topics_) {
        if (!topic_matches(filter, name)) continue;
        auto& cursor = s.cursor[name];
        if (auto resume = options.resume.find(name); resume != options.resume.end()) {
            bool same_epoch = !options.resume_epoch || *options.resume_epoch == epoch_;
            // A number of an earlier hub: everything still buffered is new to this client.
            auto from = !same_epoch || resume->second > t.last_seq ? 0 : resume->second;
            auto next = std::max(from, cursor) + 1;
            if (next > t.last_seq) continue;
            auto [pos, inserted] = s.catch_up.emplace(name, catch_up_state{next});
            if (!inserted) pos->second.next = std::min(pos->second.next, next);
            if (auto slot = s.latest.find(name); slot != s.latest.end()) slot->second.pending.reset();
            continue;
        }
        if (t.cls != topic_class::latest_value) continue;
        auto& slot = s.latest[name];
        slot.max_rate_hz = options.max_rate_hz;
        // The current value at once: a new subscriber should not wait for the next change.
        if (!s.catch_up.contains(name) && t.last_seq > cursor && !t.replay.empty()) {
            slot.pending = t.replay.back();
            cursor = t.last_seq;
        }
    }
    // A retired topic it names exactly, or resumes: it is told so at once rather than hearing nothing.
    std::set<std::string> gone;
    if (!validate_topic_name(filter) && retired_.contains(filter) && !topics_.contains(filter))
        gone.insert(filter);
    for (const auto& [name, seq] : options.resume)
        if (topic_matches(filter, name) && retired_.contains(name) && !topics_.contains(name))
            gone.insert(name);
    for (const auto& name : gone)
        push_retired(s, make_retired_event(name, retired_.at(name).last_seq, clock_.system()));
    settle(id);
    schedule_wake();
}

void event_hub::on_unsubscribe(subscriber_id id, const std::string& filter) {
    auto it = subscribers_.find(id);
    if (it == subscribers_.end()) return;
    auto& s = *it->second;
    std::erase_if(s.subscriptions, [&](const auto& sub) { return sub.filter == filter; });
    ++routing_version_;
    auto unwanted = [&](const std::string& topic) { return matching(s, topic) == nullptr; };
    std::erase_if(s.latest, [&](const auto& kv) { return unwanted(kv.first); });
    std::erase_if(s.gaps, [&](const auto& kv) { return unwanted(kv.first); });
    std::erase_if(s.catch_up, [&](const auto& kv) { return unwanted(kv.first); });
    std::erase_if(s.retired, [&](const auto& kv) { return unwanted(kv.first); });
    std::erase_if(s.queue, [&](const auto& e) { return unwanted(e->topic); });
    settle(id);
}

void event_hub::on_request_more(subscriber_id id) {
    auto it = subscribers_.find(id);
    if (it == subscribers_.end()) return;
    it->second->in_flight = false;
    it->second->stalled_since.reset();  // it made progress
    settle(id);
    // Only this subscriber's deadlines changed (a rate-limited value it may take now, a new stall):
    // every client's acknowledgement must not scan every subscriber.
    schedule_wake_for(id);
}

void event_hub::on_tick() {
    if (stopped_) return;
    retire_due_topics();
    std::vector<subscriber_id> ids;
    ids.reserve(subscribers_.size());
    for (auto& [id, s] : subscribers_)
        ids.push_back(id);
    for (auto id : ids)
        settle(id);
    schedule_wake();
}

std::optional<steady_clock::time_point> event_hub::next_deadline(const subscriber& s) const {
    std::optional<steady_clock::time_point> earliest;
    auto consider = [&](steady_clock::time_point t) {
        if (!earliest || t < *earliest) earliest = t;
    };
    if (!s.in_flight)
        for (const auto& [topic, slot] : s.latest)
            if (slot.pending && slot.next_allowed) consider(*slot.next_allowed);
    if (s.stalled_since) consider(*s.stalled_since + s.settings.max_stall + std::chrono::milliseconds(1));
    return earliest;
}

void event_hub::schedule_wake() {
    stall_started_ = false;
    if (stopped_) return;
    std::optional<steady_clock::time_point> earliest;
    if (!retirements_.empty()) earliest = retirements_.begin()->first;
    for (const auto& [id, s] : subscribers_)
        if (auto due = next_deadline(*s); due && (!earliest || *due < *earliest)) earliest = due;
    arm_wake(earliest);
}

void event_hub::schedule_wake_for(subscriber_id id) {
    if (stopped_) return;
    if (auto it = subscribers_.find(id); it != subscribers_.end()) arm_wake(next_deadline(*it->second));
}

void event_hub::arm_wake(std::optional<steady_clock::time_point> at) {
    if (!at) return;
    if (wake_at_ && *wake_at_ <= *at) return;
    wake_at_ = at;
    auto delay = std::max(*at - clock_.steady(), steady_clock::duration::zero());
    wake_timer_.expires_after(delay);
    wake_timer_.async_wait([weak = weak_from_this()](boost::system::error_code ec) {
        if (auto self = weak.lock()) self->on_wake(ec);
    });
}

void event_hub::on_wake(boost::system::error_code ec) {
    if (ec == net::error::operation_aborted) return;  // re-armed or stopped
    wake_at_.reset();
    on_tick();
}

}  // namespace gw
