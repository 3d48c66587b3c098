// The registry's runs of the focus modules' operations (CRISP, AUTOFOCUS): several serial commands
// each, so coroutines on the registry's executor; every command still goes through the driver's
// queue like any other.
#include <exception>
#include <fmt/format.h>
#include <tuple>

#include <boost/asio/append.hpp>
#include <boost/asio/as_tuple.hpp>
#include <boost/asio/co_spawn.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/use_awaitable.hpp>

#include "devices/ms2000/crisp.hpp"
#include "gateway/controllers/controller_registry.hpp"

namespace gw {

namespace net = boost::asio;
namespace ms2000 = devices::ms2000;
using std::chrono::steady_clock;

namespace {

// A failed step: its error, carried out of the coroutine.
struct step_failed {
    operation_error error;
};

struct run_context {
    std::shared_ptr<devices::controller> controller;
    std::string id;
    std::string request_id;
    std::chrono::milliseconds poll{20};
};

// One command; any failure (":N-<code>" included) ends the run.
net::awaitable<ms2000::reply> send(const run_context& ctx, ms2000::command cmd) {
    std::string request_id = ctx.request_id;
    auto [ec, reply] = co_await ctx.controller->async_command(std::move(cmd), std::move(request_id),
                                                              net::as_tuple(net::use_awaitable));
    if (ec) throw step_failed{from_driver_error(ec, reply.error_code, ctx.id)};
    co_return std::move(reply);
}

operation_error unreadable(const run_context& ctx, const ms2000::reply& r, std::string_view what) {
    auto e = make_error(operation_error_kind::controller_error,
                        fmt::format("{}: unexpected {} reply \"{}\"", ctx.id, what, r.raw));
    e.controller_code_name = "unrecognized_reply";
    return e;
}

net::awaitable<void> pause(std::chrono::milliseconds d) {
    net::steady_timer timer(co_await net::this_coro::executor, d);
    co_await timer.async_wait(net::as_tuple(net::use_awaitable));
}

net::awaitable<char> crisp_state(const run_context& ctx) {
    const auto r = co_await send(ctx, ms2000::crisp_state_query());
    const auto state = ms2000::crisp_state_of(r);
    if (!state) throw step_failed{unreadable(ctx, r, "LK X?")};
    co_return *state;
}

net::awaitable<crisp_result> run_crisp_plan(run_context ctx, crisp_plan plan, crisp_request r) {
    const auto started = steady_clock::now();
    for (auto& c : plan.writes)
        co_await send(ctx, std::move(c));
    if (r.wait) {
        // "trying to lock" ends in locked, or in the error state when the signal is too weak.
        const auto deadline = started + r.wait_timeout;
        while (ms2000::crisp_state_of(co_await send(ctx, ms2000::crisp_state_query())) == 'K') {
            if (steady_clock::now() >= deadline)
                throw step_failed{make_error(operation_error_kind::timeout,
                                             ctx.id + ": CRISP was still trying to lock at timeout_ms",
                                             "timeout_ms")};
            co_await pause(ctx.poll);
        }
    }
    crisp_result out;
    out.state = co_await crisp_state(ctx);
    // The readings in plan order after LK X?: focus error, sum, lock offset, signal-to-noise.
    std::optional<double>* readings[] = {&out.focus_error, &out.sum, &out.lock_offset, &out.snr};
    for (std::size_t i = 1; i < plan.reads.size() && i <= std::size(readings); ++i) {
        const auto reply = co_await send(ctx, std::move(plan.reads[i]));
        *readings[i - 1] = ms2000::single_reading(reply);
    }
    out.latency = std::chrono::duration_cast<std::chrono::microseconds>(steady_clock::now() - started);
    co_return out;
}

net::awaitable<autofocus_result> run_autofocus_scan(run_context ctx, ms2000::command start,
                                                    autofocus_request r) {
    const auto started = steady_clock::now();
    const auto deadline = started + r.wait_timeout;
    co_await send(ctx, std::move(start));
    for (;;) {
        // "AF X?" -> 1 while the scan runs; "/" for the Z motion that ends it.
        const auto running = ms2000::single_reading(co_await send(ctx, ms2000::autofocus_query()));
        const auto status = co_await send(ctx, ms2000::status());
        if (running == 0.0 && !status.busy) break;
        if (steady_clock::now() >= deadline)
            throw step_failed{make_error(operation_error_kind::timeout,
                                         ctx.id + ": the focus scan did not end before timeout_ms",
                                         "timeout_ms")};
        co_await pause(ctx.poll);
    }
    const auto where = co_await send(ctx, ms2000::where("Z"));
    const auto tenths = where.number(0);
    if (!tenths) throw step_failed{unreadable(ctx, where, "WHERE")};
    autofocus_result out;
    out.z_um = *tenths / 10.0;
    out.latency = std::chrono::duration_cast<std::chrono::microseconds>(steady_clock::now() - started);
    co_return out;
}

// Runs `body` and hands its result (or the failure it threw) to `done`.
template <typename T, typename Done>
void spawn_run(const net::any_io_executor& ex, net::awaitable<T> body, Done done) {
    net::co_spawn(
        ex,
        [body = std::move(body)]() mutable -> net::awaitable<operation_result<T>> {
            try {
                co_return co_await std::move(body);
            } catch (const step_failed& f) {
                co_return f.error;
            }
        },
        [done = std::move(done)](const std::exception_ptr& e, operation_result<T> r) mutable {
            if (e) r = make_error(operation_error_kind::internal, "the operation ended unexpectedly");
            done(std::move(r));
        });
}

}  // namespace

// A request checked against the snapshot (plan()), then `run` as a coroutine with what plan() made.
template <typename T, typename Request, typename Run>
void controller_registry::run_steps(std::string id, const Request& r, std::string request_id, handler<T> h,
                                    Run run) {
    auto finish = [this, id, request_id](handler<T> h, operation_result<T> res) {
        if (!res) note_failure(res.error(), id, request_id);
        net::post(executor_, net::append(std::move(h), std::move(res)));
    };
    auto t = find(id);
    if (!t) return finish(std::move(h), t.error());
    auto planned = plan(r, t->snapshot);
    if (!planned) return finish(std::move(h), planned.error());
    run_context ctx{t->controller, std::move(id), std::move(request_id), options_.arrival_poll};
    spawn_run<T>(executor_, run(std::move(ctx), std::move(*planned), r),
                 [finish, h = std::move(h)](operation_result<T> res) mutable {
                     finish(std::move(h), std::move(res));
                 });
}

void controller_registry::run_crisp(std::string id, crisp_request r, std::string request_id,
                                    handler<crisp_result> h) {
    run_steps<crisp_result>(std::move(id), r, std::move(request_id), std::move(h), &run_crisp_plan);
}

void controller_registry::run_autofocus(std::string id, autofocus_request r, std::string request_id,
                                        handler<autofocus_result> h) {
    run_steps<autofocus_result>(std::move(id), r, std::move(request_id), std::move(h), &run_autofocus_scan);
}

}  // namespace gw
