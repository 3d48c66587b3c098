#include "gateway/jobs/manager/job_manager.hpp"

#include "gateway/jobs/manager/job_manager_core.hpp"

namespace gw::jobs {

namespace {

// Forwards the registry's events to the core's strand; holds the core weakly.
class core_observer final : public devices::controller_observer {
  public:
    explicit core_observer(std::weak_ptr<manager_core> core) : core_(std::move(core)) {}
    void on_snapshot(const devices::controller_snapshot& s) override {
        const bool ready = s.state == devices::connection_state::connected && s.identity.has_value();
        bool came_back = false;
        bool came_up = false;  // the first snapshot seen, or came back
        {
            std::lock_guard lock(mutex_);  // controllers call from their own strands
            auto [it, added] = ready_.try_emplace(s.id, ready);
            came_back = ready && !added && !it->second;
            came_up = ready && (added || came_back);
            it->second = ready;
        }
        auto c = core_.lock();
        if (!c) return;
        if (came_up) c->controller_came_up(s.id);
        if (came_back) c->controller_reconnected(s.id);
        bool latch_changed = false;
        {
            std::lock_guard lock(mutex_);
            auto [it, added] = halted_.try_emplace(s.id, false);
            latch_changed = it->second != s.halted.has_value();
            it->second = s.halted.has_value();
        }
        if (latch_changed)
            c->controller_halt_latch_changed(s.id, s.halted ? std::optional(s.halted->by) : std::nullopt);
        if (s.state == devices::connection_state::connected) return;  // otherwise only departures matter
        c->controller_snapshot_changed(s);
    }
    void on_report(const devices::report_event& e) override {
        auto c = core_.lock();
        if (c && c->counts_ttl_edges(e.controller_id)) c->controller_ttl_edge(e.controller_id);
    }

  private:
    std::weak_ptr<manager_core> core_;
    std::mutex mutex_;
    std::map<std::string, bool> ready_;   // controller id -> connected and identified
    std::map<std::string, bool> halted_;  // controller id -> its HALT latch is set
};

}  // namespace

void manager_core::attach() {
    history_->set_owner(weak_from_this());
    observer_ = std::make_shared<core_observer>(weak_from_this());
    registry_.add_observer(std::weak_ptr<devices::controller_observer>(observer_));
}

// ---------------------------------------------------------------------------------------------
// job_manager

struct job_manager::impl {
    std::shared_ptr<manager_core> core;
};

operation_result<std::shared_ptr<job_manager>> job_manager::create(net::any_io_executor executor,
                                                                   controller_registry& registry,
                                                                   std::shared_ptr<event_hub> hub,
                                                                   std::shared_ptr<lease_manager> leases,
                                                                   job_manager_settings settings) {
    auto work_executor = executor;
    return create(std::move(executor), std::move(work_executor), registry, std::move(hub), std::move(leases),
                  std::move(settings));
}

operation_result<std::shared_ptr<job_manager>> job_manager::create(
    net::any_io_executor executor, net::any_io_executor work_executor, controller_registry& registry,
    std::shared_ptr<event_hub> hub, std::shared_ptr<lease_manager> leases, job_manager_settings settings) {
    job_store_options options;
    options.max_size_mb = settings.storage_max_size_mb;
    auto store = job_store::open(settings.storage_path, options);
    if (!store) return store.error();
    return std::shared_ptr<job_manager>(new job_manager(std::move(executor), std::move(work_executor),
                                                        registry, std::move(hub), std::move(leases),
                                                        std::move(settings), std::move(*store)));
}

job_manager::job_manager(net::any_io_executor executor, net::any_io_executor work_executor,
                         controller_registry& registry, std::shared_ptr<event_hub> hub,
                         std::shared_ptr<lease_manager> leases, job_manager_settings settings,
                         std::unique_ptr<job_store> store)
    : impl_(std::make_unique<impl>()) {
    impl_->core = std::make_shared<manager_core>(std::move(executor), std::move(work_executor), registry,
                                                 std::move(hub), std::move(leases), std::move(settings),
                                                 std::move(store));
    impl_->core->attach();
}

job_manager::~job_manager() {
    impl_->core->abandon();
}

void job_manager::start() {
    impl_->core->start();
}

void job_manager::async_shutdown(std::function<void()> done) {
    impl_->core->shutdown(std::move(done));
}

void job_manager::async_submit(submit_request request, handler<submit_result> h) {
    impl_->core->submit(std::move(request), std::move(h));
}

operation_result<job_record> job_manager::get(const std::string& id) const {
    return impl_->core->history().get(id);
}

std::optional<job_hold> job_manager::holding(const std::string& controller) const {
    return impl_->core->holds().find(controller);
}

std::optional<double> job_manager::store_fill_ratio() const {
    return impl_->core->store_fill_ratio();
}

operation_result<job_page> job_manager::list(const job_filter& filter) const {
    return impl_->core->history().list(filter);
}

operation_result<std::vector<nlohmann::json>> job_manager::events(const std::string& id,
                                                                  std::size_t limit) const {
    return impl_->core->history().events(id, limit);
}

void job_manager::async_get(std::string id, handler<job_record> h) {
    impl_->core->history().async_get(std::move(id), std::move(h));
}

void job_manager::async_list(job_filter filter, handler<job_page> h) {
    impl_->core->history().async_list(std::move(filter), std::move(h));
}

void job_manager::async_events(std::string id, std::size_t limit, handler<std::vector<nlohmann::json>> h) {
    impl_->core->history().async_events(std::move(id), limit, std::move(h));
}

void job_manager::async_cancel(job_action a, handler<job_record> h) {
    impl_->core->cancel(std::move(a), std::move(h));
}

void job_manager::async_pause(job_action a, handler<job_record> h) {
    impl_->core->pause(std::move(a), std::move(h));
}

void job_manager::async_resume(job_action a, handler<job_record> h) {
    impl_->core->resume(std::move(a), std::move(h));
}

void job_manager::async_next(job_action a, handler<job_record> h) {
    impl_->core->next(std::move(a), std::move(h));
}

void job_manager::async_acquire_lease(std::string controller, std::string holder, std::chrono::seconds ttl,
                                      handler<lease> h) {
    impl_->core->acquire_lease(std::move(controller), std::move(holder), ttl, std::move(h));
}

}  // namespace gw::jobs
