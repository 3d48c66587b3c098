#pragma once
// One thread for the G-code routes' blocking work (planning a program of millions of lines takes
// seconds; storing an upload syncs tens of megabytes), so the I/O threads never wait for it. At most
// `max_pending` requests hold a slot (their body on its way, their task waiting or running); beyond
// that try_reserve() and try_post() refuse (the route answers 503 planner-busy). A request that
// carries a program takes its slot from its header, before the body is read, so the refusal comes
// before the client sends the body.
// A second thread writes the uploads' bodies to disk as they arrive (post_io): file writes can block
// and the I/O thread serves every client; a plan that runs for seconds must not stall them either.
// Tasks must not own the worker (its destructor joins the threads). Thread-safe; owned by api_context.

#include <atomic>
#include <cstddef>
#include <memory>
#include <optional>
#include <utility>

#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>

namespace gw::api {

class gcode_worker {
  public:
    // One of the `max_pending` places; given back when destroyed.
    class slot {
      public:
        slot(slot&& o) noexcept : pending_(std::move(o.pending_)) {}
        slot& operator=(slot&& o) noexcept {
            if (this != &o) {
                release();
                pending_ = std::move(o.pending_);
            }
            return *this;
        }
        slot(const slot&) = delete;
        slot& operator=(const slot&) = delete;
        ~slot() { release(); }

      private:
        friend class gcode_worker;
        explicit slot(std::shared_ptr<std::atomic<std::size_t>> pending) : pending_(std::move(pending)) {}
        void release() {
            if (pending_) pending_->fetch_sub(1);
            pending_.reset();
        }
        std::shared_ptr<std::atomic<std::size_t>> pending_;
    };

    explicit gcode_worker(std::size_t max_pending = 8) : max_pending_(max_pending) {}
    gcode_worker(const gcode_worker&) = delete;
    gcode_worker& operator=(const gcode_worker&) = delete;
    ~gcode_worker() { stop(); }

    std::optional<slot> try_reserve() {
        if (pending_->fetch_add(1) >= max_pending_) {
            pending_->fetch_sub(1);
            return std::nullopt;
        }
        return slot(pending_);
    }

    // Runs `task` on the planner thread in the place of `s` (freed once the task has run).
    template <typename Task>
    void post(slot s, Task task) {
        boost::asio::post(pool_, [s = std::move(s), task = std::move(task)]() mutable {
            task();
            s.release();
        });
    }

    template <typename Task>
    bool try_post(Task task) {
        auto s = try_reserve();
        if (!s) return false;
        post(std::move(*s), std::move(task));
        return true;
    }

    // Runs `task` on the upload writer thread (not counted: each upload has one write at a time).
    template <typename Task>
    void post_io(Task task) {
        boost::asio::post(io_pool_, std::move(task));
    }

    // Drops the planner tasks not started and waits for the running one (its answer still goes out);
    // lets the upload writes finish (each is one chunk, and its session waits for it).
    void stop() {
        pool_.stop();
        pool_.join();
        io_pool_.join();
    }

    std::size_t max_pending() const { return max_pending_; }

  private:
    std::size_t max_pending_;
    std::shared_ptr<std::atomic<std::size_t>> pending_ = std::make_shared<std::atomic<std::size_t>>(0);
    boost::asio::thread_pool pool_{1};
    boost::asio::thread_pool io_pool_{1};
};

}  // namespace gw::api
