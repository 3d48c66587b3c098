#pragma once
// The thread GET /api/v1/ports probes serial ports on: a scan blocks for about a second and a half
// (devices/serial/port_scan.hpp), and the I/O threads serve every client meanwhile. One scan at a
// time: a second request while one runs is refused (the route answers 503 port-scan-busy with
// Retry-After), so clients cannot pile up threads or probe a port twice at once. Thread-safe; owned
// by api_context; stop() waits for the running scan (its answer still goes out).

#include <atomic>
#include <memory>

#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>

namespace gw::api {

class port_scan_worker {
  public:
    port_scan_worker() = default;
    port_scan_worker(const port_scan_worker&) = delete;
    port_scan_worker& operator=(const port_scan_worker&) = delete;
    ~port_scan_worker() { stop(); }

    // Runs `task` on the worker unless a scan is already running (false).
    template <typename Task>
    bool try_post(Task task) {
        if (running_->exchange(true)) return false;
        boost::asio::post(pool_, [running = running_, task = std::move(task)]() mutable {
            struct done_flag {
                std::shared_ptr<std::atomic<bool>> flag;
                ~done_flag() { flag->store(false); }
            } reset{running};
            task();
        });
        return true;
    }

    void stop() { pool_.join(); }

  private:
    std::shared_ptr<std::atomic<bool>> running_ = std::make_shared<std::atomic<bool>>(false);
    boost::asio::thread_pool pool_{1};
};

}  // namespace gw::api
