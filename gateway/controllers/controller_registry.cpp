#include "gateway/controllers/controller_registry.hpp"

#include <unistd.h>

#include <boost/asio/append.hpp>
#include <boost/asio/bind_executor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <spdlog/spdlog.h>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/error.hpp"

namespace gw {

namespace net = boost::asio;
namespace ms2000 = devices::ms2000;
using std::chrono::steady_clock;

namespace {

std::chrono::microseconds since(steady_clock::time_point start) {
    return std::chrono::duration_cast<std::chrono::microseconds>(steady_clock::now() - start);
}

}  // namespace

// Keeps the latest snapshot of every controller and forwards every event to the added observers.
// Called on the controllers' strands (several at once).
class controller_registry::store final : public devices::controller_observer {
  public:
    void seed(devices::controller_snapshot s) {
        std::lock_guard lock(mutex_);
        snapshots_[s.id] = std::move(s);
    }

    void add(std::weak_ptr<devices::controller_observer> o) {
        std::lock_guard lock(mutex_);
        observers_.push_back(std::move(o));
    }

    std::optional<devices::controller_snapshot> get(const std::string& id) const {
        std::lock_guard lock(mutex_);
        auto it = snapshots_.find(id);
        if (it == snapshots_.end()) return std::nullopt;
        return it->second;
    }

    // Sets (a later HALT renews who and when) or clears the controller's halt latch in its stored
    // snapshot; false when nothing changed. The observers hear of it with the next on_snapshot
    // (controller_registry::republish).
    bool set_latch(const std::string& id, std::optional<devices::halt_latch> latch) {
        std::lock_guard lock(mutex_);
        auto& stored = latches_[id];
        if (stored == latch) return false;
        stored = latch;
        if (auto it = snapshots_.find(id); it != snapshots_.end()) it->second.halted = std::move(latch);
        return true;
    }

    void on_snapshot(const devices::controller_snapshot& s) override {
        // The driver knows nothing of the latch: the registry's own is merged into what it publishes.
        std::optional<devices::controller_snapshot> latched;
        {
            std::lock_guard lock(mutex_);
            auto latch = latches_.find(s.id);
            if (latch != latches_.end() && latch->second) {
                latched = s;
                latched->halted = latch->second;
            }
            snapshots_[s.id] = latched ? *latched : s;
        }
        for (const auto& o : live())
            o->on_snapshot(latched ? *latched : s);
    }
    void on_report(const devices::report_event& e) override {
        for (const auto& o : live())
            o->on_report(e);
    }
    void on_ttl(const devices::ttl_event& e) override {
        for (const auto& o : live())
            o->on_ttl(e);
    }
    void on_error_log(const devices::error_log_event& e) override {
        for (const auto& o : live())
            o->on_error_log(e);
    }
    void on_trace(const devices::command_trace& t) override {
        for (const auto& o : live())
            o->on_trace(t);
    }
    void on_link_fault(const devices::link_fault& f) override {
        for (const auto& o : live())
            o->on_link_fault(f);
    }

  private:
    // Called outside the lock, so an observer may call back into the registry.
    std::vector<std::shared_ptr<devices::controller_observer>> live() {
        std::vector<std::shared_ptr<devices::controller_observer>> out;
        std::lock_guard lock(mutex_);
        std::erase_if(observers_, [&out](const auto& w) {
            auto p = w.lock();
            if (!p) return true;
            out.push_back(std::move(p));
            return false;
        });
        return out;
    }

    mutable std::mutex mutex_;
    std::map<std::string, devices::controller_snapshot> snapshots_;
    std::map<std::string, std::optional<devices::halt_latch>> latches_;
    std::vector<std::weak_ptr<devices::controller_observer>> observers_;
};

// A move with wait: the move command, then STATUS until "N" (or the deadline), then "W <axes>".
struct controller_registry::move_op : std::enable_shared_from_this<move_op> {
    move_op(controller_registry& r, const net::any_io_executor& ex) : reg(r), timer(ex) {}

    controller_registry& reg;
    std::string id;
    std::string request_id;
    std::shared_ptr<devices::controller> ctl;
    std::string axes;                         // hardware order
    std::optional<std::uint64_t> halts_seen;  // move_request::halts_seen: every command guarded
    steady_clock::time_point deadline;
    net::steady_timer timer;
    std::optional<handler<move_result>> h;

    template <typename Handler>
    void send(ms2000::command cmd, Handler&& handler) {
        if (halts_seen)
            ctl->async_guarded_command(std::move(cmd), request_id, *halts_seen,
                                       std::forward<Handler>(handler));
        else
            ctl->async_command(std::move(cmd), request_id, std::forward<Handler>(handler));
    }

    void finish(operation_result<move_result> r) {
        if (!h) return;
        auto handler = std::move(*h);
        h.reset();
        reg.deliver(std::move(handler), std::move(r), id, request_id);
    }

    void check_status() {
        send(ms2000::status(),
             [self = shared_from_this()](boost::system::error_code ec, ms2000::reply reply) {
                 self->on_status(ec, reply);
             });
    }

    void on_status(boost::system::error_code ec, const ms2000::reply& reply) {
        if (ec) return finish(from_driver_error(ec, reply.error_code, id));
        if (!reply.busy) return read_positions();
        if (steady_clock::now() >= deadline)
            return finish(make_error(operation_error_kind::timeout,
                                     id + ": the stage did not arrive before wait_timeout", "wait_timeout"));
        timer.expires_after(reg.options_.arrival_poll);
        timer.async_wait([self = shared_from_this()](boost::system::error_code) { self->check_status(); });
    }

    void read_positions() {
        send(ms2000::where(axes),
             [self = shared_from_this()](boost::system::error_code ec, ms2000::reply reply) {
                 self->on_where(ec, reply);
             });
    }

    void on_where(boost::system::error_code ec, const ms2000::reply& reply) {
        if (ec) return finish(from_driver_error(ec, reply.error_code, id));
        move_result result;
        result.waited = true;
        for (std::size_t i = 0; i < axes.size(); ++i) {
            const auto tenths = reply.number(i);
            if (!tenths) {
                auto e = make_error(operation_error_kind::controller_error,
                                    id + ": unexpected WHERE reply \"" + reply.raw + "\"");
                e.controller_code_name = "unrecognized_reply";
                return finish(std::move(e));
            }
            result.positions.push_back({axes[i], *tenths / 10.0});
        }
        finish(std::move(result));
    }
};

registry_options make_registry_options(const gateway_config& config) {
    registry_options o;
    o.controllers = config.controllers;
    o.simulate = config.simulate;
    o.halt_on_exit = config.shutdown.halt_on_exit;
    return o;
}

controller_registry::controller_registry(const net::any_io_executor& executor, registry_options options)
    : executor_(executor),
      options_(std::move(options)),
      log_(get_logger("gateway")),
      store_(std::make_shared<store>()) {
    auto settings = options_.controllers;
    if (options_.simulate.count > 0) {
        auto dir = options_.simulate.directory;
        if (dir.empty()) dir = "/tmp/asi-gateway-" + std::to_string(::getpid());
        fleet_ = std::make_unique<simulated_fleet>(executor_, options_.simulate.count,
                                                   options_.simulate.time_scale, dir);
        for (auto s : fleet_->controller_settings()) {
            s.poll_interval = options_.simulated_poll_interval;
            settings.push_back(std::move(s));
        }
    }
    for (auto& s : settings) {
        get_logger("ms2000." + s.id);  // so the driver logs with the configured level
        devices::controller_snapshot initial;
        initial.id = s.id;
        initial.port = s.port;
        initial.report =
            s.report_port.empty() ? devices::report_port_state::none : devices::report_port_state::closed;
        store_->seed(initial);
        order_.push_back(s.id);
        auto id = s.id;
        controllers_[id] = std::make_shared<devices::controller>(executor_, std::move(s), store_);
    }
}

controller_registry::~controller_registry() {
    stop();
}

void controller_registry::start() {
    {
        std::lock_guard lock(mutex_);
        if (started_) return;
        started_ = true;
    }
    if (fleet_) {
        fleet_->start();
        for (const auto& sim : fleet_->simulators())
            log_->info("simulated {} ({}) on {}{}", sim->config().name, sim->config().build_name,
                       sim->port_path(),
                       sim->report_port_path().empty() ? "" : ", reports on " + sim->report_port_path());
    }
    for (const auto& id : order_)
        controllers_.at(id)->start();
}

void controller_registry::stop() {
    {
        std::lock_guard lock(mutex_);
        if (stopped_) return;
        stopped_ = true;
    }
    for (const auto& id : order_)
        controllers_.at(id)->stop();
    if (fleet_) fleet_->stop();
}

void controller_registry::async_shutdown(std::function<void()> done) {
    struct state {
        explicit state(const net::strand<net::any_io_executor>& s) : strand(s), timer(s) {}
        net::strand<net::any_io_executor> strand;
        net::steady_timer timer;
        std::size_t pending = 0;
        bool finished = false;
        std::function<void()> done;
    };
    std::vector<std::shared_ptr<devices::controller>> moving;
    if (options_.halt_on_exit) {
        for (const auto& id : order_) {
            auto s = store_->get(id);
            if (s && s->state == devices::connection_state::connected) moving.push_back(controllers_.at(id));
        }
    }
    auto st = std::make_shared<state>(net::make_strand(executor_));
    st->done = std::move(done);
    st->pending = moving.size();
    auto finish = [this, st] {  // on the strand
        if (st->finished) return;
        st->finished = true;
        st->timer.cancel();
        stop();
        net::post(executor_, std::move(st->done));
    };
    if (moving.empty()) {
        net::post(st->strand, finish);
        return;
    }
    log_->info("halting {} controller(s) before stopping", moving.size());
    st->timer.expires_after(options_.halt_timeout);
    st->timer.async_wait([this, st, finish](boost::system::error_code ec) {
        if (ec || st->finished) return;
        log_->warn("HALT not answered within {} ms; closing the ports anyway", options_.halt_timeout.count());
        finish();
    });
    for (const auto& c : moving) {
        c->async_command(
            ms2000::halt(), "shutdown",
            net::bind_executor(st->strand, [this, st, finish, id = c->id()](boost::system::error_code ec,
                                                                            const ms2000::reply&) {
                if (ec) log_->warn("{}: HALT at shutdown failed: {}", id, ec.message());
                if (--st->pending == 0) finish();
            }));
    }
}

void controller_registry::add_observer(std::weak_ptr<devices::controller_observer> observer) {
    store_->add(std::move(observer));
}

void controller_registry::add_observer(std::shared_ptr<devices::controller_observer> observer) {
    {
        std::lock_guard lock(mutex_);
        owned_observers_.push_back(observer);
    }
    store_->add(observer);
}

std::vector<devices::controller_snapshot> controller_registry::list() const {
    std::vector<devices::controller_snapshot> out;
    for (const auto& id : order_) {
        if (auto s = store_->get(id)) out.push_back(std::move(*s));
    }
    return out;
}

std::optional<devices::controller_snapshot> controller_registry::get(const std::string& id) const {
    return store_->get(id);
}

bool controller_registry::ready() const {
    for (const auto& id : order_) {
        auto s = store_->get(id);
        if (!s || s->state != devices::connection_state::connected || !s->identity) return false;
    }
    return true;
}

std::shared_ptr<devices::controller> controller_registry::controller(const std::string& id) const {
    auto it = controllers_.find(id);
    return it == controllers_.end() ? nullptr : it->second;
}

operation_result<controller_registry::target> controller_registry::find(const std::string& id) const {
    auto it = controllers_.find(id);
    auto snapshot = store_->get(id);
    if (it == controllers_.end() || !snapshot)
        return make_error(operation_error_kind::unknown_controller, "no controller with id \"" + id + "\"");
    return target{it->second, std::move(*snapshot)};
}

template <typename T>
void controller_registry::deliver(handler<T> h, operation_result<T> r, const std::string& id,
                                  const std::string& request_id) {
    if (!r) note_failure(r.error(), id, request_id);
    // Through executor_, then on the handler's own associated executor if it has one. Posted: this
    // may be the initiating call, which must not complete inline.
    net::post(executor_, net::append(std::move(h), std::move(r)));
}

template <typename T>
void controller_registry::deliver_completion(handler<T> h, operation_result<T> r, const std::string& id,
                                             const std::string& request_id) {
    if (!r) note_failure(r.error(), id, request_id);
    // The driver already posted its completion, so nothing of its own is on the stack: the handler
    // runs at once when its executor allows (a round trip's queue hop, and a poll of the reactor,
    // fewer), otherwise it is queued as above.
    net::dispatch(executor_, net::append(std::move(h), std::move(r)));
}

void controller_registry::note_failure(const operation_error& e, const std::string& id,
                                       const std::string& request_id) {
    // Refusals are the client's business; failures of the controller are ours, but may repeat a lot.
    const bool client_side =
        e.kind == operation_error_kind::invalid_value || e.kind == operation_error_kind::unknown_controller ||
        e.kind == operation_error_kind::missing_module || e.kind == operation_error_kind::busy ||
        e.kind == operation_error_kind::leased || e.kind == operation_error_kind::halted;
    if (client_side) {
        log_->debug("[{}] {}: refused ({}): {}", request_id, id, to_string(e.kind), e.message);
        return;
    }
    std::uint64_t suppressed = 0;
    if (!failures_.allow(id + "/" + std::string(to_string(e.kind)), suppressed)) return;
    if (suppressed > 0)
        log_->warn("[{}] {}: {} ({} similar messages suppressed)", request_id, to_string(e.kind), e.message,
                   suppressed);
    else
        log_->warn("[{}] {}: {}", request_id, to_string(e.kind), e.message);
}

template <typename Request>
void controller_registry::run_simple(std::string id, Request r, std::string request_id,
                                     handler<operation_done> h) {
    auto t = find(id);
    if (!t) return deliver<operation_done>(std::move(h), t.error(), id, request_id);
    auto cmd = plan(r, t->snapshot);
    if (!cmd) return deliver<operation_done>(std::move(h), cmd.error(), id, request_id);
    const auto started = steady_clock::now();
    t->controller->async_command(std::move(*cmd), request_id,
                                 [this, h = std::move(h), id, request_id, started](
                                     boost::system::error_code ec, ms2000::reply reply) mutable {
                                     if (ec)
                                         deliver_completion<operation_done>(
                                             std::move(h), from_driver_error(ec, reply.error_code, id), id,
                                             request_id);
                                     else
                                         deliver_completion<operation_done>(
                                             std::move(h), operation_done{since(started)}, id, request_id);
                                 });
}

template void controller_registry::run_simple<halt_request>(std::string, halt_request, std::string,
                                                            handler<operation_done>);
template void controller_registry::run_simple<home_request>(std::string, home_request, std::string,
                                                            handler<operation_done>);
template void controller_registry::run_simple<zero_request>(std::string, zero_request, std::string,
                                                            handler<operation_done>);
template void controller_registry::run_simple<here_request>(std::string, here_request, std::string,
                                                            handler<operation_done>);
template void controller_registry::run_simple<speed_request>(std::string, speed_request, std::string,
                                                             handler<operation_done>);
template void controller_registry::run_simple<ttl_request>(std::string, ttl_request, std::string,
                                                           handler<operation_done>);
template void controller_registry::run_simple<dac_request>(std::string, dac_request, std::string,
                                                           handler<operation_done>);
template void controller_registry::run_simple<led_request>(std::string, led_request, std::string,
                                                           handler<operation_done>);

void controller_registry::run_emergency_halt(std::string id, std::string by, std::string request_id,
                                             handler<operation_done> h) {
    if (!controllers_.contains(id))
        return deliver<operation_done>(
            std::move(h),
            make_error(operation_error_kind::unknown_controller, "no controller with id \"" + id + "\""), id,
            request_id);
    latch_halt(id, by, request_id);
    run_simple<halt_request>(std::move(id), halt_request{}, std::move(request_id), std::move(h));
}

void controller_registry::latch_halt(const std::string& id, const std::string& by,
                                     const std::string& request_id) {
    if (!controllers_.contains(id)) return;
    if (store_->set_latch(id, devices::halt_latch{by, std::chrono::system_clock::now()})) {
        log_->warn("[{}] {}: HALT by {}: jobs there stay stopped until one is resumed or submitted",
                   request_id, id, by);
        republish(id);
    }
}

void controller_registry::release_halt_latch(const std::string& id) {
    if (!controllers_.contains(id) || !store_->set_latch(id, std::nullopt)) return;
    log_->info("{}: the HALT latch is released", id);
    republish(id);
}

void controller_registry::republish(const std::string& id) {
    controllers_.at(id)->get_snapshot(
        [store = store_](devices::controller_snapshot s) { store->on_snapshot(s); });
}

std::uint64_t controller_registry::halts_accepted(const std::string& id) const {
    auto it = controllers_.find(id);
    return it == controllers_.end() ? 0 : it->second->halts_accepted();
}

void controller_registry::run_move(std::string id, move_request r, std::string request_id,
                                   handler<move_result> h) {
    auto t = find(id);
    if (!t) return deliver<move_result>(std::move(h), t.error(), id, request_id);
    auto cmd = plan(r, t->snapshot);
    if (!cmd) return deliver<move_result>(std::move(h), cmd.error(), id, request_id);
    auto op = std::make_shared<move_op>(*this, executor_);
    op->id = id;
    op->request_id = request_id;
    op->ctl = t->controller;
    op->axes = hardware_order(r.axes, t->snapshot);
    op->halts_seen = r.halts_seen;
    op->h.emplace(std::move(h));
    const bool wait = r.wait;
    const auto timeout = r.wait_timeout;
    op->send(std::move(*cmd), [op, wait, timeout](boost::system::error_code ec, ms2000::reply reply) {
        if (ec) return op->finish(from_driver_error(ec, reply.error_code, op->id));
        if (!wait) return op->finish(move_result{});
        op->deadline = steady_clock::now() + timeout;
        op->check_status();
    });
}

template <typename Request>
void controller_registry::run_answered(std::string id, Request r, std::string request_id,
                                       handler<raw_command_result> h) {
    auto t = find(id);
    if (!t) return deliver<raw_command_result>(std::move(h), t.error(), id, request_id);
    auto cmd = plan(r, t->snapshot);
    if (!cmd) return deliver<raw_command_result>(std::move(h), cmd.error(), id, request_id);
    send_answered(t->controller, std::move(*cmd), r.halts_seen, id, request_id, std::move(h));
}

template void controller_registry::run_answered<raw_command_request>(std::string, raw_command_request,
                                                                     std::string,
                                                                     handler<raw_command_result>);
template void controller_registry::run_answered<command_request>(std::string, command_request, std::string,
                                                                 handler<raw_command_result>);

void controller_registry::send_answered(const std::shared_ptr<devices::controller>& controller,
                                        ms2000::command cmd, std::optional<std::uint64_t> halts_seen,
                                        const std::string& id, const std::string& request_id,
                                        handler<raw_command_result> h) {
    const auto started = steady_clock::now();
    auto answered = [this, h = std::move(h), id, request_id, started](boost::system::error_code ec,
                                                                      ms2000::reply reply) mutable {
        // ":N-<code>" is an answer: the caller sees it in the parsed reply.
        if (ec && ec != devices::ms2000::error::controller_rejected)
            return deliver_completion<raw_command_result>(
                std::move(h), from_driver_error(ec, reply.error_code, id), id, request_id);
        raw_command_result result;
        result.raw_reply = reply.raw;
        result.reply = std::move(reply);
        result.latency = since(started);
        deliver_completion<raw_command_result>(std::move(h), std::move(result), id, request_id);
    };
    if (halts_seen)
        controller->async_guarded_command(std::move(cmd), request_id, *halts_seen, std::move(answered));
    else
        controller->async_command(std::move(cmd), request_id, std::move(answered));
}

}  // namespace gw
