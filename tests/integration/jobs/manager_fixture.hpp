#pragma once
// A job_manager over in-process simulators (real ptys, time_scale 20), a real controller_registry,
// a real event hub and a real SQLite store in a temporary directory. For the manager_*_test.cpp files
// (other job tests may use it too).
//
//   add_sim("sim3", "planar");  start();        // registry ready, manager started
//   auto job = submit("sim3", job_type::planar_correction, {{"action","clear"}});
//   wait_state(job->job.id, job_state::succeeded);
//   restart_manager();                          // crash: destroy without shutdown, open again
//   restart_gateway();                          // the same with new drivers: controllers identified again

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/use_future.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/sim/sim_config.hpp"
#include "devices/sim/simulator.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/events/event_sink.hpp"
#include "gateway/jobs/manager/job_manager.hpp"
#include "gateway/leases/lease_manager.hpp"
#include "tests/support/drv_recording_observer.hpp"
#include "tests/support/io_thread.hpp"
#include "tests/support/sim_controller_settings.hpp"

namespace gw::jobs::test {

namespace net = boost::asio;
namespace sim = devices::sim;
using namespace std::chrono_literals;
using gw::test::await;
using gw::test::io_thread;

// Records every event of the hub's "jobs/#" topics, as parsed JSON messages, in arrival order.
class recording_sink : public event_sink, public std::enable_shared_from_this<recording_sink> {
  public:
    void attach(const std::shared_ptr<event_hub>& hub) {
        hub_ = hub;
        id_ = hub->add_subscriber(weak_from_this());
        hub->subscribe(id_, "jobs/#");
    }
    void deliver(std::vector<std::shared_ptr<const event>> batch) override {
        {
            std::lock_guard lock(mutex_);
            for (const auto& e : batch)
                messages_.push_back(nlohmann::json::parse(*e->message));
        }
        if (auto hub = hub_.lock()) hub->request_more(id_);
    }
    void close(std::string) override {}

    // The "data" of the events of one job, in order.
    std::vector<nlohmann::json> of(const std::string& job_id) {
        std::lock_guard lock(mutex_);
        std::vector<nlohmann::json> out;
        for (const auto& m : messages_)
            if (m.value("topic", "") == "jobs/" + job_id) out.push_back(m.contains("data") ? m["data"] : m);
        return out;
    }
    std::vector<nlohmann::json> all() {
        std::lock_guard lock(mutex_);
        return messages_;
    }

  private:
    std::weak_ptr<event_hub> hub_;
    subscriber_id id_ = 0;
    std::mutex mutex_;
    std::vector<nlohmann::json> messages_;
};

class manager_fixture : public ::testing::Test {
  protected:
    std::shared_ptr<sim::simulator> add_sim(const std::string& id, const std::string& preset,
                                            double time_scale = 20) {
        auto config = sim::preset(preset).value();
        config.name = id;
        config.time_scale = time_scale;
        config.link_path = dir_ + "/ports/" + id + "/port";
        config.report_link_path = dir_ + "/ports/" + id + "/report";
        auto s = std::make_shared<sim::simulator>(sim_io_.io.get_executor(), config);
        s->start();
        sims_[id] = s;
        options_.controllers.push_back(gw::test::sim_controller_settings(id, *s, config.baud));
        return s;
    }

    job_manager_settings settings() const {
        job_manager_settings s;
        s.storage_path = dir_ + "/store";
        s.restart_queued = restart_queued_;
        s.max_queued_per_controller = max_queued_;
        s.storage_max_size_mb = storage_max_size_mb_;
        s.max_unstored_writes_per_job = max_unstored_writes_;
        s.ended_job_topic_ttl = ended_job_topic_ttl_;
        s.on_plan_started = on_plan_started_;
        s.store_fill_check = store_fill_check_;
        return s;
    }

    // Registry (ready), hub, leases, manager (started).
    void start() {
        registry_ = std::make_unique<controller_registry>(gw_io_.io.get_executor(), options_);
        registry_->add_observer(std::weak_ptr<devices::controller_observer>(observer_));
        hub_ = event_hub::create(gw_io_.io.get_executor());
        sink_->attach(hub_);
        registry_->start();
        ASSERT_TRUE(wait_until([&] { return registry_->ready(); })) << "controllers not ready";
        open_manager();
    }

    void open_manager() {
        // The manager works on a thread of its own, as in the gateway.
        auto m = job_manager::create(gw_io_.io.get_executor(), jobs_io_.io.get_executor(), *registry_, hub_,
                                     leases_, settings());
        ASSERT_TRUE(m) << m.error().message;
        manager_ = std::move(*m);
        manager_->start();
    }

    // Like kill -9 for the manager: destroyed without shutdown, then a new one on the same directory.
    void restart_manager() {
        manager_.reset();
        open_manager();
    }

    // Like kill -9 of the whole gateway: the manager destroyed without shutdown and the controllers'
    // ports closed without HALT; then a new registry, which identifies the controllers again (their
    // snapshot shows the settings as the crashed run left them), and a new manager on the same store.
    // `ready`: waits until every controller is connected again.
    void restart_gateway(bool ready = true) {
        manager_.reset();
        registry_->stop();
        // The old manager's last coroutines may still hold the old registry: it lives until TearDown.
        retired_registries_.push_back(std::move(registry_));
        // The simulators answer the old drivers' last commands first: the new drivers flush their input
        // when they open the ports, and would otherwise take such a late reply for their first one.
        std::this_thread::sleep_for(200ms);
        registry_ = std::make_unique<controller_registry>(gw_io_.io.get_executor(), options_);
        registry_->add_observer(std::weak_ptr<devices::controller_observer>(observer_));
        registry_->start();
        if (ready) {
            ASSERT_TRUE(wait_until([&] { return registry_->ready(); })) << "controllers not ready";
        }
        open_manager();
    }

    void shutdown_manager() {
        std::promise<void> done;
        manager_->async_shutdown([&] { done.set_value(); });
        ASSERT_EQ(done.get_future().wait_for(30s), std::future_status::ready) << "shutdown did not finish";
        expect_wal_checkpointed();
    }

    // A clean shutdown checkpoints the WAL into the database file: the -wal file is gone or empty.
    void expect_wal_checkpointed() {
        const auto wal = std::filesystem::path(settings().storage_path) / "jobs.sqlite3-wal";
        std::error_code ec;
        const auto size = std::filesystem::file_size(wal, ec);
        EXPECT_TRUE(ec || size == 0) << wal << " holds " << size << " bytes after a clean shutdown";
    }

    operation_result<submit_result> submit(const std::string& controller, job_type type, nlohmann::json spec,
                                           std::optional<std::string> key = std::nullopt,
                                           std::optional<std::string> lease = std::nullopt,
                                           bool dry_run = false, std::string principal = "anonymous") {
        submit_request r;
        r.principal = std::move(principal);
        r.controller = controller;
        r.type = type;
        r.spec = std::move(spec);
        r.idempotency_key = std::move(key);
        r.lease_id = std::move(lease);
        r.request_id = "test-submit";
        r.dry_run = dry_run;
        return await(
            call<submit_result>([&](auto h) { manager_->async_submit(std::move(r), std::move(h)); }));
    }

    operation_result<job_record> act(void (job_manager::*f)(job_action, job_manager::handler<job_record>),
                                     const std::string& id, std::optional<std::string> lease = std::nullopt) {
        job_action a;
        a.job_id = id;
        a.lease_id = std::move(lease);
        a.request_id = "test-action";
        return await(call<job_record>([&](auto h) { ((*manager_).*f)(std::move(a), std::move(h)); }));
    }
    operation_result<job_record> cancel(const std::string& id) { return act(&job_manager::async_cancel, id); }
    operation_result<job_record> pause(const std::string& id) { return act(&job_manager::async_pause, id); }
    operation_result<job_record> resume(const std::string& id) { return act(&job_manager::async_resume, id); }
    operation_result<job_record> next(const std::string& id) { return act(&job_manager::async_next, id); }

    operation_result<lease> acquire_lease(const std::string& controller, const std::string& holder) {
        return await(call<lease>([&](auto h) {
            manager_->async_acquire_lease(controller, holder, std::chrono::seconds(60), std::move(h));
        }));
    }

    template <typename T, typename F>
    std::future<operation_result<T>> call(F&& start) {
        auto p = std::make_shared<std::promise<operation_result<T>>>();
        auto f = p->get_future();
        start(job_manager::handler<T>([p](operation_result<T> r) { p->set_value(std::move(r)); }));
        return f;
    }

    template <typename Pred>
    bool wait_until(Pred pred, std::chrono::milliseconds timeout = 60s) {
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        while (std::chrono::steady_clock::now() < deadline) {
            if (pred()) return true;
            std::this_thread::sleep_for(10ms);
        }
        return pred();
    }

    std::optional<job_record> job(const std::string& id) {
        auto r = manager_->get(id);
        if (!r) return std::nullopt;
        return *r;
    }

    bool wait_state(const std::string& id, job_state s, std::chrono::milliseconds timeout = 60s) {
        const bool ok = wait_until(
            [&] {
                auto j = job(id);
                return j && j->state == s;
            },
            timeout);
        if (!ok) {
            auto j = job(id);
            ADD_FAILURE() << "job " << id << " never became " << to_string(s) << "; it is "
                          << (j ? std::string(to_string(j->state)) + " (" + j->reason + ")" : "unknown");
        }
        return ok;
    }

    nlohmann::json sim_state(const std::string& id) {
        return nlohmann::json::parse(sims_.at(id)->state_json());
    }

    std::optional<double> position(const std::string& id, char axis) {
        auto s = registry_->get(id);
        if (!s) return std::nullopt;
        const auto* a = s->axis(axis);
        return a ? a->position_um : std::nullopt;
    }

    // Serial commands sent for a job ("job-<id>"), in order (wire text without CR).
    std::vector<std::string> commands_of(const std::string& job_id) {
        return observer_->locked([&] {
            std::vector<std::string> out;
            for (const auto& t : observer_->traces)
                if (t.request_id == "job-" + job_id) {
                    auto w = t.wire;  // escaped: "W X Y Z\\r"
                    if (w.ends_with("\\r")) w.resize(w.size() - 2);
                    out.push_back(w);
                }
            return out;
        });
    }

    void TearDown() override {
        if (manager_ && !manager_shut_) {
            std::promise<void> done;
            manager_->async_shutdown([&] { done.set_value(); });
            if (done.get_future().wait_for(30s) == std::future_status::ready) expect_wal_checkpointed();
        }
        if (registry_) registry_->stop();
        if (hub_) hub_->stop();
        gw_io_.join();
        jobs_io_.join();
        manager_.reset();
        registry_.reset();
        retired_registries_.clear();
        for (auto& [id, s] : sims_)
            s->stop();
        sim_io_.join();
        std::filesystem::remove_all(dir_);
    }

    io_thread sim_io_;
    io_thread gw_io_;
    io_thread jobs_io_;  // the job manager's own thread
    std::string dir_ = "/tmp/gw-jobs-" +
                       std::string(testing::UnitTest::GetInstance()->current_test_info()->name()) + "-" +
                       std::to_string(::getpid());
    registry_options options_;
    std::map<std::string, std::shared_ptr<sim::simulator>> sims_;
    std::shared_ptr<gw::test::drv_recording_observer> observer_ =
        std::make_shared<gw::test::drv_recording_observer>();
    std::unique_ptr<controller_registry> registry_;
    std::vector<std::unique_ptr<controller_registry>> retired_registries_;  // restart_gateway()
    std::shared_ptr<event_hub> hub_;
    std::shared_ptr<recording_sink> sink_ = std::make_shared<recording_sink>();
    std::shared_ptr<lease_manager> leases_ = std::make_shared<lease_manager>();
    std::shared_ptr<job_manager> manager_;
    bool restart_queued_ = false;
    bool manager_shut_ = false;
    std::size_t max_queued_ = 1000;
    std::size_t storage_max_size_mb_ = 64;
    std::size_t max_unstored_writes_ = 10000;
    std::function<void(const std::string&)> on_plan_started_;  // settings().on_plan_started
    std::chrono::milliseconds store_fill_check_{5000};         // settings().store_fill_check
    std::chrono::milliseconds ended_job_topic_ttl_{600'000};
};

}  // namespace gw::jobs::test
