#pragma once
// Owns the controllers (and the simulated fleet when configured), starts and stops them, keeps the
// latest snapshot of each, and runs the typed operations.
//
//   controller_registry reg(io.get_executor(), options);
//   reg.start();
//   reg.async_move("stage1", {.axes = {{'X', 1000}}, .wait = true}, request_id, handler);
//   reg.async_shutdown([] { ... });   // HALTs connected controllers unless halt_on_exit is false
//
// Snapshots: the registry observes every controller and keeps a copy, so list()/get()/ready() never
// touch a serial line. Every event is forwarded to the observers added with add_observer() (the event
// hub's bridge, the log observer), on the controller's strand.
//
// Operations: each is validated against the latest snapshot (operations.hpp) before anything is
// written; the result is a typed value or an operation_error. Completions run on the handler's
// associated executor, or the registry's executor; never inline in the initiating call. Works with
// callbacks, use_future and use_awaitable.
//
// Thread safety: list/get/ready/add_observer and the async_ operations may be called from any thread
// after start(). The registry must outlive the operations it runs (main keeps it until io.run()
// returns).

#include <chrono>
#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_completion_handler.hpp>
#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/async_result.hpp>

#include "devices/serial/controller.hpp"
#include "devices/serial/controller_observer.hpp"
#include "devices/serial/controller_settings.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/config/config.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/operations.hpp"
#include "gateway/controllers/simulated_fleet.hpp"

namespace spdlog {
class logger;
}

namespace gw {

struct registry_options {
    std::vector<devices::controller_settings> controllers;
    simulate_config simulate;  // count 0: no simulated fleet
    std::chrono::milliseconds simulated_poll_interval{100};
    bool halt_on_exit = true;
    // How long shutdown waits for the HALTs before closing the ports anyway.
    std::chrono::milliseconds halt_timeout{2000};
    // STATUS interval while a move waits for arrival.
    std::chrono::milliseconds arrival_poll{20};
};

// From the config: its controllers, its simulated fleet, shutdown.halt_on_exit.
registry_options make_registry_options(const gateway_config& config);

class controller_registry {
  public:
    template <typename T>
    using handler = boost::asio::any_completion_handler<void(operation_result<T>)>;

    controller_registry(const boost::asio::any_io_executor& executor, registry_options options);
    ~controller_registry();
    controller_registry(const controller_registry&) = delete;
    controller_registry& operator=(const controller_registry&) = delete;

    // Opens the simulated ports (throws std::system_error if one cannot be opened) and starts every
    // controller (they connect and reconnect by themselves).
    void start();
    // Stops every controller and the fleet at once, without HALT. Idempotent.
    void stop();
    // HALTs every connected controller (unless halt_on_exit is false), waits for the replies (at most
    // halt_timeout), then stop(), then calls `done` on the registry's executor.
    void async_shutdown(std::function<void()> done);

    // Forwarded every event, on the controller's strand. The strong overload keeps the observer alive
    // as long as the registry.
    void add_observer(std::weak_ptr<devices::controller_observer> observer);
    void add_observer(std::shared_ptr<devices::controller_observer> observer);

    // Configured controllers, in configuration order (simulated ones last); from the registry's copy.
    std::vector<devices::controller_snapshot> list() const;
    std::optional<devices::controller_snapshot> get(const std::string& id) const;
    std::vector<std::string> ids() const { return order_; }
    // Every configured controller connected and identified.
    bool ready() const;

    const simulated_fleet* fleet() const { return fleet_.get(); }
    std::shared_ptr<devices::controller> controller(const std::string& id) const;

    // Typed operations. `request_id` goes with every serial command they cause (traces, logs).
    template <typename Token>
    auto async_move(std::string id, move_request r, std::string request_id, Token&& token) {
        return initiate<move_result>(&controller_registry::run_move, std::move(id), std::move(r),
                                     std::move(request_id), std::forward<Token>(token));
    }
    // HALT alone, for the gateway's own stops (a job's cancel, shutdown): nothing is latched.
    template <typename Token>
    auto async_halt(std::string id, std::string request_id, Token&& token) {
        return initiate<operation_done>(&controller_registry::run_simple<halt_request>, std::move(id),
                                        halt_request{}, std::move(request_id), std::forward<Token>(token));
    }
    // The emergency stop of every transport: latches the controller as halted by `by` (its snapshot says
    // so at once, devices::halt_latch; the job manager pauses its jobs and starts none), then sends
    // HALT whenever the port is open. The latch is set before the HALT is counted (halts_accepted), so
    // whoever reads the count and then finds no latch is guarded against this HALT.
    template <typename Token>
    auto async_emergency_halt(std::string id, std::string by, std::string request_id, Token&& token) {
        return boost::asio::async_initiate<Token, void(operation_result<operation_done>)>(
            [this](auto h, std::string id, std::string by, std::string rid) {
                run_emergency_halt(std::move(id), std::move(by), std::move(rid),
                                   handler<operation_done>(std::move(h)));
            },
            token, std::move(id), std::move(by), std::move(request_id));
    }
    // The latch alone, for a HALT that goes to the controller another way (a shared port's client sends
    // its own, to get the controller's reply); nothing for an unknown id.
    void latch_halt(const std::string& id, const std::string& by, const std::string& request_id);
    // Releases the latch (someone resumed or submitted a job there); nothing when there is none.
    void release_halt_latch(const std::string& id);
    // The controller's HALTs so far (devices::controller::halts_accepted); 0 for an unknown id.
    std::uint64_t halts_accepted(const std::string& id) const;
    template <typename Token>
    auto async_home(std::string id, home_request r, std::string request_id, Token&& token) {
        return initiate<operation_done>(&controller_registry::run_simple<home_request>, std::move(id),
                                        std::move(r), std::move(request_id), std::forward<Token>(token));
    }
    template <typename Token>
    auto async_zero(std::string id, std::string request_id, Token&& token) {
        return initiate<operation_done>(&controller_registry::run_simple<zero_request>, std::move(id),
                                        zero_request{}, std::move(request_id), std::forward<Token>(token));
    }
    template <typename Token>
    auto async_here(std::string id, here_request r, std::string request_id, Token&& token) {
        return initiate<operation_done>(&controller_registry::run_simple<here_request>, std::move(id),
                                        std::move(r), std::move(request_id), std::forward<Token>(token));
    }
    template <typename Token>
    auto async_speed(std::string id, speed_request r, std::string request_id, Token&& token) {
        return initiate<operation_done>(&controller_registry::run_simple<speed_request>, std::move(id),
                                        std::move(r), std::move(request_id), std::forward<Token>(token));
    }
    template <typename Token>
    auto async_ttl(std::string id, ttl_request r, std::string request_id, Token&& token) {
        return initiate<operation_done>(&controller_registry::run_simple<ttl_request>, std::move(id), r,
                                        std::move(request_id), std::forward<Token>(token));
    }
    template <typename Token>
    auto async_dac(std::string id, dac_request r, std::string request_id, Token&& token) {
        return initiate<operation_done>(&controller_registry::run_simple<dac_request>, std::move(id), r,
                                        std::move(request_id), std::forward<Token>(token));
    }
    template <typename Token>
    auto async_led(std::string id, led_request r, std::string request_id, Token&& token) {
        return initiate<operation_done>(&controller_registry::run_simple<led_request>, std::move(id), r,
                                        std::move(request_id), std::forward<Token>(token));
    }
    // CRISP: the request's writes, then the read-out (and with wait, the end of a lock attempt).
    template <typename Token>
    auto async_crisp(std::string id, crisp_request r, std::string request_id, Token&& token) {
        return initiate<crisp_result>(&controller_registry::run_crisp, std::move(id), r,
                                      std::move(request_id), std::forward<Token>(token));
    }
    // AUTOFOCUS: a focus scan, waited for; the result is where Z stopped.
    template <typename Token>
    auto async_autofocus(std::string id, autofocus_request r, std::string request_id, Token&& token) {
        return initiate<autofocus_result>(&controller_registry::run_autofocus, std::move(id), r,
                                          std::move(request_id), std::forward<Token>(token));
    }
    // Completes with success when the controller answered at all, even ":N-<code>" (the parsed reply
    // says so): an expert wants to see the reply.
    template <typename Token>
    auto async_raw_command(std::string id, raw_command_request r, std::string request_id, Token&& token) {
        return initiate<raw_command_result>(&controller_registry::run_answered<raw_command_request>,
                                            std::move(id), std::move(r), std::move(request_id),
                                            std::forward<Token>(token));
    }

    // A command built by the gateway (a job's step), answered as async_raw_command answers.
    template <typename Token>
    auto async_command(std::string id, command_request r, std::string request_id, Token&& token) {
        return initiate<raw_command_result>(&controller_registry::run_answered<command_request>,
                                            std::move(id), std::move(r), std::move(request_id),
                                            std::forward<Token>(token));
    }

  private:
    class store;
    struct move_op;

    template <typename T, typename Request, typename Token>
    auto initiate(void (controller_registry::*run)(std::string, Request, std::string, handler<T>),
                  std::string id, Request r, std::string request_id, Token&& token) {
        return boost::asio::async_initiate<Token, void(operation_result<T>)>(
            [this, run](auto h, std::string id, Request r, std::string rid) {
                (this->*run)(std::move(id), std::move(r), std::move(rid), handler<T>(std::move(h)));
            },
            token, std::move(id), std::move(r), std::move(request_id));
    }

    template <typename Request>
    void run_simple(std::string id, Request r, std::string request_id, handler<operation_done> h);
    void run_move(std::string id, move_request r, std::string request_id, handler<move_result> h);
    void run_emergency_halt(std::string id, std::string by, std::string request_id,
                            handler<operation_done> h);
    // Publishes the controller's current snapshot again (its latch changed), from its strand.
    void republish(const std::string& id);
    // A raw line or a job's command: planned, sent, and answered with the reply as it came (":N-<code>"
    // included).
    template <typename Request>
    void run_answered(std::string id, Request r, std::string request_id, handler<raw_command_result> h);
    void send_answered(const std::shared_ptr<devices::controller>& controller, devices::ms2000::command cmd,
                       std::optional<std::uint64_t> halts_seen, const std::string& id,
                       const std::string& request_id, handler<raw_command_result> h);
    // focus_runs.cpp
    template <typename T, typename Request, typename Run>
    void run_steps(std::string id, const Request& r, std::string request_id, handler<T> h, Run run);
    void run_crisp(std::string id, crisp_request r, std::string request_id, handler<crisp_result> h);
    void run_autofocus(std::string id, autofocus_request r, std::string request_id,
                       handler<autofocus_result> h);

    // The controller and its snapshot, or unknown_controller.
    struct target {
        std::shared_ptr<devices::controller> controller;
        devices::controller_snapshot snapshot;
    };
    operation_result<target> find(const std::string& id) const;

    template <typename T>
    void deliver(handler<T> h, operation_result<T> r, const std::string& id, const std::string& request_id);
    // From a driver's completion (not the initiating call): the handler may run at once.
    template <typename T>
    void deliver_completion(handler<T> h, operation_result<T> r, const std::string& id,
                            const std::string& request_id);
    void note_failure(const operation_error& e, const std::string& id, const std::string& request_id);

    boost::asio::any_io_executor executor_;
    registry_options options_;
    std::shared_ptr<spdlog::logger> log_;
    std::unique_ptr<simulated_fleet> fleet_;
    std::shared_ptr<store> store_;
    std::vector<std::string> order_;
    std::map<std::string, std::shared_ptr<devices::controller>> controllers_;
    keyed_log_limiter failures_;
    std::mutex mutex_;  // guards stopped_ and owned_observers_
    bool started_ = false;
    bool stopped_ = false;
    std::vector<std::shared_ptr<devices::controller_observer>> owned_observers_;
};

}  // namespace gw
