#include "gateway/jobs/manager/job_execution.hpp"

#include <algorithm>
#include <fmt/format.h>

#include <boost/asio/redirect_error.hpp>
#include <boost/asio/use_awaitable.hpp>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/host_step_timing.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/jobs/job_commands.hpp"

namespace gw::jobs {

namespace net = boost::asio;
using std::chrono::steady_clock;

namespace {

// STATUS interval of wait_idle (the registry polls arrival at the same pace); the estimates of
// host-driven steps assume it (devices/ms2000/host_step_timing).
constexpr std::chrono::milliseconds idle_poll{
    static_cast<long>(devices::ms2000::host_link_timing{}.arrival_poll_ms)};

}  // namespace

job_execution::job_execution(strand_type strand, controller_registry& registry,
                             std::weak_ptr<execution_host> host, std::shared_ptr<live_job> job,
                             std::size_t first_step, std::uint64_t halts_seen)
    : strand_(strand),
      registry_(registry),
      host_(std::move(host)),
      job_(std::move(job)),
      first_step_(first_step),
      halts_seen_(halts_seen),
      request_id_("job-" + job_->record.id),
      signal_(strand) {}

devices::controller_snapshot job_execution::snapshot() const {
    auto s = registry_.get(job_->record.controller);
    return s ? std::move(*s) : devices::controller_snapshot{};
}

void job_execution::throw_if_stopped() const {
    if (cancelled_ || abandoned_) throw job_cancelled{};
    if (halted_by_) throw job_halted(*halted_by_);
    if (failure_) throw job_failure(*failure_);
}

void job_execution::wake() {
    signal_.cancel();
}

net::awaitable<void> job_execution::wait_until(steady_clock::time_point deadline) {
    boost::system::error_code ec;
    signal_.expires_at(deadline);
    co_await signal_.async_wait(net::redirect_error(net::use_awaitable, ec));
}

net::awaitable<void> job_execution::checkpoint() {
    throw_if_stopped();
    if (!pause_requested_) co_return;
    waiting_paused_ = true;
    if (auto h = host_.lock()) h->on_paused(*job_);
    while (pause_requested_ && !cancelled_ && !abandoned_ && !failure_ && !halted_by_)
        co_await wait_until(steady_clock::time_point::max());
    waiting_paused_ = false;
    throw_if_stopped();
}

void job_execution::step_started(std::size_t index) {
    if (abandoned_) return;
    if (auto h = host_.lock()) h->on_step_started(*job_, index);
}

void job_execution::step_done(std::size_t index, nlohmann::json detail) {
    if (abandoned_) return;
    if (auto h = host_.lock()) h->on_step_done(*job_, index, std::move(detail));
}

void job_execution::emit(std::string kind, nlohmann::json detail) {
    if (abandoned_) return;
    nlohmann::json event = {{"type", kind}};
    if (detail.is_object()) event.update(detail);
    event["type"] = std::move(kind);
    if (auto h = host_.lock()) h->on_emit(*job_, std::move(event));
}

std::vector<nlohmann::json> job_execution::completed_steps() const {
    if (auto h = host_.lock()) return h->step_events(*job_);
    return {};
}

std::filesystem::path job_execution::gcode_files() const {
    if (auto h = host_.lock()) return h->gcode_files();
    return {};
}

void job_execution::restore_if_stopped(std::string command) {
    auto& list = job_->restore_commands;
    if (std::find(list.begin(), list.end(), command) != list.end()) return;
    list.push_back(std::move(command));
    if (abandoned_) return;
    if (auto h = host_.lock()) h->on_restore_commands_changed(*job_);
}

net::awaitable<std::map<char, double>> job_execution::settings_before(std::string verb, std::string letters) {
    std::map<char, double> out;
    for (const auto& registered : job_->restore_commands)
        for (const auto& [letter, value] : values_set(registered, verb))
            if (letters.find(letter) != std::string::npos) out.try_emplace(letter, value);
    std::string ask;
    for (const char letter : letters)
        if (!out.contains(letter)) ask += letter;
    if (ask.empty()) co_return out;
    auto query = devices::ms2000::query(verb, ask);
    auto reply = co_await command(std::move(query));
    for (const char letter : ask) {
        const auto* v = reply.axis(letter);
        std::optional<double> value = v ? v->number : std::nullopt;
        if (!value && ask.size() == 1) value = reply.number(0);  // ":A 0": no letter in the answer
        if (!value)
            throw job_failure(make_error(operation_error_kind::controller_error,
                                         fmt::format("unexpected {} reply \"{}\"", verb, reply.raw)));
        out[letter] = *value;
    }
    co_return out;
}

net::awaitable<devices::ms2000::reply> job_execution::command(devices::ms2000::command c) {
    throw_if_stopped();
    // Named arguments only: g++ 12 mishandles temporaries that live across a co_await.
    std::string controller = job_->record.controller;
    const std::string line = text_of(c);
    command_request request{std::move(c), halts_seen_};
    std::string request_id = request_id_;
    auto r = co_await registry_.async_command(std::move(controller), std::move(request),
                                              std::move(request_id), net::use_awaitable);
    throw_if_stopped();
    if (!r) throw job_failure(r.error());
    if (r->reply.what == devices::ms2000::reply::kind::error) {
        const int code = r->reply.error_code;
        auto e =
            make_error(operation_error_kind::controller_error,
                       fmt::format("{} answered \"{}\" to \"{}\" ({})", job_->record.controller, r->raw_reply,
                                   line, devices::ms2000::controller_error_description(code)));
        e.controller_code = code;
        e.controller_code_name = std::string(devices::ms2000::controller_error_name(code));
        throw job_failure(std::move(e));
    }
    co_return std::move(r->reply);
}

net::awaitable<move_result> job_execution::move(move_request request) {
    throw_if_stopped();
    request.halts_seen = halts_seen_;
    std::string controller = job_->record.controller;
    std::string request_id = request_id_;
    auto r = co_await registry_.async_move(std::move(controller), std::move(request), std::move(request_id),
                                           net::use_awaitable);
    throw_if_stopped();
    if (!r) throw job_failure(r.error());
    co_return std::move(*r);
}

net::awaitable<void> job_execution::wait_idle(std::chrono::milliseconds timeout) {
    const auto deadline = steady_clock::now() + timeout;
    for (;;) {
        auto status = devices::ms2000::status();
        auto reply = co_await command(std::move(status));
        if (reply.what == devices::ms2000::reply::kind::status && !reply.busy) co_return;
        if (steady_clock::now() >= deadline)
            throw job_failure(make_error(operation_error_kind::timeout,
                                         fmt::format("{}: the stage was still busy after {} ms",
                                                     job_->record.controller, timeout.count())));
        co_await sleep(idle_poll);
    }
}

net::awaitable<void> job_execution::sleep(std::chrono::milliseconds duration) {
    const auto deadline = steady_clock::now() + duration;
    throw_if_stopped();
    while (steady_clock::now() < deadline) {
        co_await wait_until(deadline);  // woken early by a signal: re-check the flags, sleep on
        throw_if_stopped();
    }
}

net::awaitable<void> job_execution::dwell(std::chrono::milliseconds duration) {
    throw_if_stopped();
    const bool shown = duration >= min_shown_timer;
    if (shown) set_waiting(job_wait::timer);
    co_await sleep(duration);
    if (shown) set_waiting(std::nullopt);
}

net::awaitable<void> job_execution::wait_advance(advance_source source) {
    throw_if_stopped();
    if (source == advance_source::timer) co_return;
    auto& pending = source == advance_source::ttl ? ttl_pending_ : next_pending_;
    // An advance that came before it was awaited is no wait.
    const bool waits = pending == 0;
    if (waits) set_waiting(source == advance_source::ttl ? job_wait::ttl : job_wait::next);
    while (pending == 0) {
        co_await wait_until(steady_clock::time_point::max());
        throw_if_stopped();
    }
    --pending;
    if (waits) set_waiting(std::nullopt);
}

void job_execution::set_waiting(std::optional<job_wait> what) {
    if (abandoned_) return;
    if (auto h = host_.lock()) h->on_waiting(*job_, what);
}

void job_execution::cancel() {
    cancelled_ = true;
    wake();
}

void job_execution::fail(operation_error error) {
    if (failure_ || cancelled_) return;
    failure_ = std::move(error);
    wake();
}

void job_execution::halt(std::string by) {
    if (halted_by_ || cancelled_) return;
    halted_by_ = std::move(by);
    wake();
}

void job_execution::request_pause() {
    pause_requested_ = true;
}

void job_execution::resume() {
    pause_requested_ = false;
    wake();
}

void job_execution::ttl_edge() {
    ++ttl_pending_;
    wake();
}

void job_execution::next() {
    ++next_pending_;
    wake();
}

void job_execution::abandon() {
    abandoned_ = true;
    wake();
}

}  // namespace gw::jobs
