#include "gateway/jobs/manager/job_manager.hpp"

#include "gateway/jobs/manager/job_coordinator.hpp"
#include "gateway/jobs/manager/job_history.hpp"
#include "gateway/jobs/store/job_store.hpp"

namespace gw::jobs {

namespace net = boost::asio;

// ---------------------------------------------------------------------------------------------
// job_manager

struct job_manager::impl {
    std::shared_ptr<job_coordinator> coordinator;
};

operation_result<std::shared_ptr<job_manager>> job_manager::create(net::any_io_executor executor,
                                                                   controller_registry& registry,
                                                                   std::shared_ptr<event_hub> hub,
                                                                   std::shared_ptr<lease_manager> leases,
                                                                   job_manager_settings settings) {
    const auto work_executor = executor;  // a copy: `executor` is moved below
    return create(std::move(executor), work_executor, registry, std::move(hub), std::move(leases),
                  std::move(settings));
}

operation_result<std::shared_ptr<job_manager>> job_manager::create(
    net::any_io_executor executor, const net::any_io_executor& work_executor, controller_registry& registry,
    std::shared_ptr<event_hub> hub, std::shared_ptr<lease_manager> leases, job_manager_settings settings) {
    job_store_options options;
    options.max_size_mb = settings.storage_max_size_mb;
    auto store = job_store::open(settings.storage_path, options);
    if (!store) return store.error();
    return std::shared_ptr<job_manager>(new job_manager(std::move(executor), work_executor, registry,
                                                        std::move(hub), std::move(leases),
                                                        std::move(settings), std::move(*store)));
}

job_manager::job_manager(net::any_io_executor executor, const net::any_io_executor& work_executor,
                         controller_registry& registry, std::shared_ptr<event_hub> hub,
                         std::shared_ptr<lease_manager> leases, job_manager_settings settings,
                         std::unique_ptr<job_store> store)
    : impl_(std::make_unique<impl>()) {
    impl_->coordinator =
        std::make_shared<job_coordinator>(std::move(executor), work_executor, registry, std::move(hub),
                                          std::move(leases), std::move(settings), std::move(store));
    impl_->coordinator->attach();
}

job_manager::~job_manager() {
    impl_->coordinator->abandon();
}

void job_manager::start() {
    impl_->coordinator->start();
}

void job_manager::async_shutdown(std::function<void()> done) {
    impl_->coordinator->shutdown(std::move(done));
}

void job_manager::async_submit(submit_request request, handler<submit_result> h) {
    impl_->coordinator->submit(std::move(request), std::move(h));
}

operation_result<job_record> job_manager::get(const std::string& id) const {
    return impl_->coordinator->history().get(id);
}

std::optional<job_hold> job_manager::holding(const std::string& controller) const {
    return impl_->coordinator->holds().find(controller);
}

std::optional<double> job_manager::store_fill_ratio() const {
    return impl_->coordinator->history().fill_ratio();
}

operation_result<job_page> job_manager::list(const job_filter& filter) const {
    return impl_->coordinator->history().list(filter);
}

operation_result<std::vector<nlohmann::json>> job_manager::events(const std::string& id,
                                                                  std::size_t limit) const {
    return impl_->coordinator->history().events(id, limit);
}

void job_manager::async_get(std::string id, handler<job_record> h) {
    impl_->coordinator->history().async_get(std::move(id), std::move(h));
}

void job_manager::async_list(job_filter filter, handler<job_page> h) {
    impl_->coordinator->history().async_list(std::move(filter), std::move(h));
}

void job_manager::async_events(std::string id, std::size_t limit, handler<std::vector<nlohmann::json>> h) {
    impl_->coordinator->history().async_events(std::move(id), limit, std::move(h));
}

void job_manager::async_cancel(job_action a, handler<job_record> h) {
    impl_->coordinator->cancel(std::move(a), std::move(h));
}

void job_manager::async_pause(job_action a, handler<job_record> h) {
    impl_->coordinator->pause(std::move(a), std::move(h));
}

void job_manager::async_resume(job_action a, handler<job_record> h) {
    impl_->coordinator->resume(std::move(a), std::move(h));
}

void job_manager::async_next(job_action a, handler<job_record> h) {
    impl_->coordinator->next(std::move(a), std::move(h));
}

void job_manager::async_acquire_lease(std::string controller, std::string holder, std::chrono::seconds ttl,
                                      handler<lease> h) {
    impl_->coordinator->acquire_lease(std::move(controller), std::move(holder), ttl, std::move(h));
}

}  // namespace gw::jobs
