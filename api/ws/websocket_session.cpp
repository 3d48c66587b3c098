#include "api/ws/websocket_session.hpp"

#include <algorithm>
#include <atomic>
#include <utility>
#include <variant>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "api/calls/job_requests.hpp"
#include "api/ws/batch_text_cache.hpp"
#include "api/ws/websocket_protocol.hpp"
#include "gateway/common/metrics.hpp"
#include "gateway/events/event_hub.hpp"

namespace gw::api {

using nlohmann::json;

namespace {

std::atomic<std::uint64_t> next_connection{1};

// RFC 6455: a close reason fits in 123 bytes.
std::string close_reason_text(std::string reason) {
    if (reason.size() > 123) reason.resize(123);
    return reason;
}

void describe_metrics(gw::metrics& m) {
    // gw_websocket_clients is declared by the HTTP layer (controller_metrics); these are ours.
    m.describe("gw_websocket_connections_total", metric_type::counter, "WebSocket connections accepted");
    m.describe("gw_websocket_disconnects_total", metric_type::counter,
               "WebSocket connections ended, by reason (client, idle, too_slow, going_away, error)");
    m.describe("gw_websocket_messages_received_total", metric_type::counter,
               "WebSocket client messages, by op (invalid: refused with an error message)");
    m.describe("gw_websocket_gap_events_total", metric_type::counter,
               "Gap events sent to WebSocket clients (they fell behind or resumed too late)");
    m.describe("gw_websocket_gapped_events_total", metric_type::counter,
               "Stream events WebSocket clients were told they missed (dropped for them)");
}

}  // namespace

websocket_limits websocket_limits_from(const http_limits& limits) {
    websocket_limits l;
    l.max_message_bytes = limits.max_websocket_message_bytes;
    // Pings after one read_timeout of silence, closes after two: a healthy client answers the ping.
    l.idle_timeout = 2 * limits.read_timeout;
    l.write_timeout = limits.read_timeout;
    return l;
}

void start_websocket_session(http_stream&& stream, http::request<http::string_body>&& request,
                             std::shared_ptr<api_context> context, auth_identity who,
                             std::shared_ptr<connection_permit> permit,
                             std::optional<std::chrono::milliseconds> batch_window) {
    auto limits = websocket_limits_from(context->limits);
    auto session = std::make_shared<websocket_session>(std::move(stream), std::move(context), std::move(who),
                                                       limits, std::move(permit), batch_window);
    session->run(std::move(request));
}

websocket_session::websocket_session(http_stream&& stream, std::shared_ptr<api_context> context,
                                     auth_identity who, websocket_limits limits,
                                     std::shared_ptr<connection_permit> permit,
                                     std::optional<std::chrono::milliseconds> batch_window)
    : ws_(std::move(stream)),
      ctx_(std::move(context)),
      who_(std::move(who)),
      limits_(limits),
      connection_("ws-" + std::to_string(next_connection.fetch_add(1))),
      watchdog_(ws_.get_executor()),
      permit_(std::move(permit)),
      batch_window_(batch_window),
      batch_timer_(ws_.get_executor()) {}

websocket_session::~websocket_session() {
    // Normally finish() ran already; this covers an io_context torn down mid-session.
    if (subscriber_ != 0 && !hub_closed_ && ctx_->hub) ctx_->hub->remove_subscriber(subscriber_);
    if (counted_ && ctx_->metrics) ctx_->metrics->increment("gw_websocket_clients", {}, -1);
}

void websocket_session::run(http::request<http::string_body> request) {
    upgrade_ = std::move(request);
    beast::error_code ec;
    const auto peer = beast::get_lowest_layer(ws_).socket().remote_endpoint(ec);
    if (!ec) client_address_ = ctx_->proxies.client_address(peer.address(), upgrade_["X-Forwarded-For"]);
    net::dispatch(ws_.get_executor(), [self = shared_from_this()] {
        if (self->ctx_->metrics) describe_metrics(*self->ctx_->metrics);
        // Beast's own timers govern the WebSocket from here; the HTTP stream's must be off.
        beast::get_lowest_layer(self->ws_).expires_never();
        websocket::stream_base::timeout timeouts;
        timeouts.handshake_timeout = self->limits_.close_timeout;
        timeouts.idle_timeout = self->limits_.idle_timeout;
        timeouts.keep_alive_pings = true;
        self->ws_.set_option(timeouts);
        self->ws_.set_option(websocket::stream_base::decorator(
            [](websocket::response_type& res) { res.set(http::field::server, "asi-gateway"); }));
        self->ws_.read_message_max(self->limits_.max_message_bytes);
        // Each message in one frame: Beast would cut it into 4 KiB frames (a write each), and a
        // batch of events is often much larger.
        self->ws_.auto_fragment(false);
        self->ws_.async_accept(self->upgrade_,
                               beast::bind_front_handler(&websocket_session::on_accept, self));
    });
}

void websocket_session::stop(std::string reason) {
    net::post(ws_.get_executor(), [self = shared_from_this(), reason = std::move(reason)]() mutable {
        self->begin_close(websocket::close_code::going_away, std::move(reason));
    });
}

void websocket_session::deliver(std::vector<std::shared_ptr<const event>> batch) {
    net::post(ws_.get_executor(),
              [self = shared_from_this(), batch = std::move(batch)]() mutable { self->on_deliver(batch); });
}

void websocket_session::close(std::string reason) {
    net::post(ws_.get_executor(), [self = shared_from_this(), reason = std::move(reason)]() mutable {
        self->hub_closed_ = true;
        const bool slow = reason.starts_with("too slow");
        self->begin_close(slow ? websocket::close_code::policy_error : websocket::close_code::going_away,
                          std::move(reason));
    });
}

// ---- on the session's strand ----

void websocket_session::on_accept(beast::error_code ec) {
    upgrade_ = {};
    if (ec) {
        fail(ec, "accept");
        return finish("error");
    }
    if (phase_ != phase::handshake) return finish("going_away");  // stopped during the handshake
    phase_ = phase::open;
    counted_ = true;
    if (ctx_->metrics) {
        ctx_->metrics->increment("gw_websocket_clients", {}, 1);
        ctx_->metrics->increment("gw_websocket_connections_total", {});
    }
    if (ctx_->log)
        ctx_->log->info("{}: WebSocket open ({}, {})", connection_, who_.name, gw::to_string(who_.role));
    if (batch_window_) {
        // Events wait in the hub between batches: room for a window's worth of busy report streams
        // (32 controllers at 500 frames/s fill 1,600 in 100 ms), and bigger batches under load.
        subscriber_settings batched;
        batched.queue_limit = 8192;
        batched.max_batch_events = 2048;
        // It holds back its acknowledgement for up to one window on purpose: not a sign of slowness.
        batched.slow_ack += *batch_window_;
        subscriber_ = ctx_->hub->add_subscriber(weak_from_this(), batched);
    } else {
        subscriber_ = ctx_->hub->add_subscriber(weak_from_this());
    }
    answer(ws_hello_message(connection_, who_.name, whoami_json(ctx_->auth, who_), limits_.max_message_bytes,
                            batch_window_));
    schedule_watchdog();
    do_read();
}

bool websocket_session::reading_blocked() const {
    return answers_queued_ >= limits_.answer_queue_limit;
}

void websocket_session::maybe_resume_reading() {
    if (phase_ == phase::open && !reading_ && !reading_blocked()) do_read();
}

void websocket_session::do_read() {
    if (phase_ != phase::open || reading_ || reading_blocked()) return;
    reading_ = true;
    ws_.async_read(in_, beast::bind_front_handler(&websocket_session::on_read, shared_from_this()));
}

void websocket_session::on_read(beast::error_code ec, std::size_t) {
    reading_ = false;
    if (ec) {
        if (phase_ == phase::closing) return;  // on_close or the watchdog finishes
        fail(ec, "read");
        // A close frame, or a client that just went away, is the client's choice.
        const bool by_client =
            ec == websocket::error::closed || ec == net::error::eof || ec == net::error::connection_reset;
        return finish(by_client ? "client" : ec == beast::error::timeout ? "idle" : "error");
    }
    if (phase_ != phase::open) return;
    if (!ws_.got_text()) {
        in_.consume(in_.size());
        if (ctx_->metrics)
            ctx_->metrics->increment("gw_websocket_messages_received_total", {{"op", "invalid"}});
        auto e = binary_frame_error();
        answer_error(e.id, std::move(e.error));
    } else {
        const std::string text = beast::buffers_to_string(in_.data());
        in_.consume(in_.size());
        handle_message(text);
    }
    do_read();
}

void websocket_session::handle_message(std::string_view text) {
    auto parsed = parse_client_message(text);
    if (!parsed) {
        if (ctx_->metrics)
            ctx_->metrics->increment("gw_websocket_messages_received_total", {{"op", "invalid"}});
        if (ctx_->log) ctx_->log->debug("{}: refused message: {}", connection_, parsed.error().error.detail);
        auto e = std::move(parsed.error());
        return answer_error(e.id, std::move(e.error));
    }
    std::visit(
        [this](auto& m) {
            using T = std::decay_t<decltype(m)>;
            auto count = [this](const char* op) {
                if (ctx_->metrics)
                    ctx_->metrics->increment("gw_websocket_messages_received_total", {{"op", op}});
            };
            if constexpr (std::is_same_v<T, ws_ping>) {
                count("ping");
                answer(ws_pong_message(m.id));
            } else if constexpr (std::is_same_v<T, ws_subscribe>) {
                count("subscribe");
                std::size_t added = 0;
                for (const auto& t : m.topics)
                    added += filters_.contains(t) ? 0 : 1;
                if (filters_.size() + added > limits_.max_subscriptions) {
                    auto p = make_problem(make_error(operation_error_kind::invalid_value,
                                                     "at most " + std::to_string(limits_.max_subscriptions) +
                                                         " subscriptions per connection (unsubscribe first)",
                                                     "topics"));
                    return answer_error(m.id, std::move(p));
                }
                // The ack first: the hub delivers on its strand and posts back, so events of this
                // subscription can only be queued after it.
                answer(ws_subscribed_message(m));
                for (const auto& t : m.topics) {
                    filters_.insert(t);
                    ctx_->hub->subscribe(subscriber_, t, {.max_rate_hz = m.max_rate_hz, .resume = m.resume});
                }
            } else if constexpr (std::is_same_v<T, ws_unsubscribe>) {
                count("unsubscribe");
                for (const auto& t : m.topics) {
                    filters_.erase(t);
                    ctx_->hub->unsubscribe(subscriber_, t);
                }
                answer(ws_unsubscribed_message(m));
            } else if constexpr (std::is_same_v<T, command_message> || std::is_same_v<T, job_message>) {
                count(std::is_same_v<T, command_message> ? "command" : "job");
                // Taken before the message is moved into its call.
                json id = m.id;
                auto lease = m.lease;
                run_call(id, std::move(lease), to_call(std::move(m)));
            } else if constexpr (std::is_same_v<T, gcode_message>) {
                count("gcode");
                json id = m.id;
                run_call(id, std::nullopt, to_call(std::move(m)));
            } else if constexpr (std::is_same_v<T, halt_all_message>) {
                count("halt_all");
                run_call(m.id, std::nullopt, halt_all_call{});
            }
        },
        *parsed);
}

// The same dispatch as REST and MQTT: same roles, leases, validation and shapes.
void websocket_session::run_call(const json& id, std::optional<std::string> lease, call c) {
    if (is_emergency_stop(c) || commands_in_flight_ < limits_.max_commands_in_flight)
        return start_call(id, std::move(lease), std::move(c));
    if (commands_waiting_.size() >= limits_.max_commands_waiting)
        return answer_error(id, make_problem(make_error(
                                    operation_error_kind::queue_full,
                                    "this connection has " + std::to_string(commands_in_flight_) +
                                        " commands running and " + std::to_string(commands_waiting_.size()) +
                                        " waiting; send more once some are answered (a HALT always runs)")));
    commands_waiting_.push_back({id, std::move(lease), std::move(c)});
}

void websocket_session::start_call(const json& id, std::optional<std::string> lease, call c) {
    ++commands_in_flight_;
    caller who{who_.name,        who_.role,   ws_request_id(connection_, id),
               std::move(lease), "websocket", client_address_};
    dispatch_call(*ctx_, who, std::move(c),
                  net::bind_executor(ws_.get_executor(), [self = shared_from_this(), id](api_outcome out) {
                      self->on_call_done(id, std::move(out));
                  }));
}

void websocket_session::on_call_done(const json& id, api_outcome outcome) {
    --commands_in_flight_;
    if (phase_ != phase::open) return;
    if (!commands_waiting_.empty() && commands_in_flight_ < limits_.max_commands_in_flight) {
        auto next = std::move(commands_waiting_.front());
        commands_waiting_.pop_front();
        start_call(next.id, std::move(next.lease), std::move(next.c));
    }
    if (outcome.error)
        answer_error(id, std::move(*outcome.error));
    else
        answer(call_result_message(id, outcome.body, outcome.replayed));
    maybe_resume_reading();
}

void websocket_session::answer_error(const json& id, problem p) {
    p.instance = std::string(websocket_path);
    answer(call_error_message(id, p));
}

void websocket_session::answer(std::string text) {
    if (phase_ != phase::open) return;
    out_.push_back({std::make_shared<const std::string>(std::move(text)), false, true});
    ++answers_queued_;
    if (!writing_) do_write();
}

void websocket_session::on_deliver(const std::vector<std::shared_ptr<const event>>& batch) {
    // Not open any more: the hub keeps the rest until remove_subscriber (we never ask for more).
    if (phase_ != phase::open || batch.empty()) return;
    std::uint64_t gaps = 0;
    std::uint64_t missed = 0;
    for (auto& e : batch) {
        if (e->kind == event_kind::gap) {
            ++gaps;
            missed += e->missed();
        }
        // The hub's serialised message, shared with every other subscriber: sent as is.
        if (!batch_window_) out_.push_back({e->message, false, false});
    }
    if (batch_window_) {
        batch_arrived_ = std::chrono::steady_clock::now();
        out_.push_back({ctx_->batch_texts ? ctx_->batch_texts->text(batch)
                                          : std::make_shared<const std::string>(ws_batch_message(batch)),
                        false, false});
    }
    out_.back().ends_batch = true;
    if (ctx_->metrics && gaps != 0) {
        ctx_->metrics->increment("gw_websocket_gap_events_total", {}, static_cast<double>(gaps));
        ctx_->metrics->increment("gw_websocket_gapped_events_total", {}, static_cast<double>(missed));
    }
    if (!writing_) do_write();
}

// One write in flight: the next frame starts in on_write.
void websocket_session::do_write() {
    if (writing_ || out_.empty() || phase_ != phase::open) return;
    writing_ = true;
    write_started_ = std::chrono::steady_clock::now();
    ws_.text(true);
    ws_.async_write(net::buffer(*out_.front().text),
                    beast::bind_front_handler(&websocket_session::on_write, shared_from_this()));
}

void websocket_session::on_write(beast::error_code ec, std::size_t) {
    writing_ = false;
    if (ec) {
        if (phase_ == phase::closed) return;
        fail(ec, "write");
        return finish(phase_ == phase::closing ? end_reason_ : "error");
    }
    if (!out_.empty()) {
        const auto done = out_.front();
        out_.pop_front();
        if (done.answer) --answers_queued_;
        if (done.ends_batch && phase_ == phase::open) request_next_batch();
    }
    if (phase_ == phase::closing) return do_close();
    do_write();
    maybe_resume_reading();
}

void websocket_session::request_next_batch() {
    if (!batch_window_ || batch_window_->count() == 0) return ctx_->hub->request_more(subscriber_);
    // The next point of a grid of the window's length: sessions with the same window ask at the same
    // moments, get the same events, and share one batch text (batch_text_cache).
    const auto window = std::chrono::duration_cast<std::chrono::steady_clock::duration>(*batch_window_);
    const auto due =
        std::chrono::steady_clock::time_point((batch_arrived_.time_since_epoch() / window + 1) * window);
    if (std::chrono::steady_clock::now() >= due) return ctx_->hub->request_more(subscriber_);
    batch_timer_.expires_at(due);
    batch_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
        if (!ec && self->phase_ == phase::open) self->ctx_->hub->request_more(self->subscriber_);
    });
}

void websocket_session::begin_close(websocket::close_code code, std::string reason) {
    if (phase_ == phase::closing || phase_ == phase::closed) return;
    const bool in_handshake = phase_ == phase::handshake;
    phase_ = phase::closing;
    close_code_ = code;
    close_reason_ = close_reason_text(std::move(reason));
    end_reason_ = code == websocket::close_code::policy_error ? "too_slow" : "going_away";
    close_deadline_ = std::chrono::steady_clock::now() + limits_.close_timeout;
    if (ctx_->log) {
        if (code == websocket::close_code::policy_error)
            ctx_->log->warn("{}: closing: {}", connection_, close_reason_);
        else
            ctx_->log->info("{}: closing: {}", connection_, close_reason_);
    }
    // Only the frame being written stays; nothing new is written but the close frame.
    while (out_.size() > (writing_ ? 1u : 0u)) {
        if (out_.back().answer) --answers_queued_;
        out_.pop_back();
    }
    if (in_handshake) return;  // on_accept sees the phase and ends
    if (!writing_) do_close();
    // else: on_write closes; a write that never completes is cut by the watchdog at close_deadline_.
}

void websocket_session::do_close() {
    if (close_started_) return;
    close_started_ = true;
    ws_.async_close(websocket::close_reason(close_code_, close_reason_),
                    beast::bind_front_handler(&websocket_session::on_close, shared_from_this()));
}

void websocket_session::on_close(beast::error_code ec) {
    if (ec) fail(ec, "close");
    finish(end_reason_);
}

void websocket_session::schedule_watchdog() {
    const auto period = std::clamp<std::chrono::milliseconds>(
        limits_.write_timeout / 4, std::chrono::milliseconds(20), std::chrono::milliseconds(1000));
    watchdog_.expires_after(period);
    watchdog_.async_wait(beast::bind_front_handler(&websocket_session::on_watchdog, shared_from_this()));
}

void websocket_session::on_watchdog(beast::error_code ec) {
    if (ec || phase_ == phase::closed) return;
    const auto now = std::chrono::steady_clock::now();
    if (phase_ == phase::open && writing_ && now - write_started_ >= limits_.write_timeout) {
        begin_close(
            websocket::close_code::policy_error,
            "too slow: a message waited " +
                std::to_string(
                    std::chrono::duration_cast<std::chrono::milliseconds>(now - write_started_).count()) +
                " ms to be written");
        // The close frame would queue behind the stuck write: cut the connection now.
        return finish(end_reason_);
    }
    if (phase_ == phase::closing && now >= close_deadline_) {
        // The peer takes neither our data nor the close frame: cut the connection.
        return finish(end_reason_);
    }
    schedule_watchdog();
}

void websocket_session::finish(std::string_view why) {
    if (phase_ == phase::closed) return;
    phase_ = phase::closed;
    watchdog_.cancel();
    batch_timer_.cancel();
    if (subscriber_ != 0 && !hub_closed_) ctx_->hub->remove_subscriber(subscriber_);
    subscriber_ = 0;
    out_.clear();
    answers_queued_ = 0;
    if (counted_) {
        counted_ = false;
        if (ctx_->metrics) {
            ctx_->metrics->increment("gw_websocket_clients", {}, -1);
            ctx_->metrics->increment("gw_websocket_disconnects_total", {{"reason", std::string(why)}});
        }
        if (ctx_->log) ctx_->log->info("{}: WebSocket closed ({})", connection_, why);
    }
    // Whatever is still pending (a stuck write, the read, an unanswered close) ends now.
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(net::ip::tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).close();
    permit_.reset();  // the socket is closed: its slot is free, even if a handler still holds us
}

void websocket_session::fail(beast::error_code ec, std::string_view what) {
    if (ec == net::error::operation_aborted || ec == websocket::error::closed || ec == net::error::eof ||
        ec == net::error::connection_reset || ec == beast::error::timeout)
        return;
    if (ctx_->log) ctx_->log->debug("{}: {}: {}", connection_, what, ec.message());
}

}  // namespace gw::api
