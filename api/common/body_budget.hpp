#pragma once
// The bytes of request bodies held in memory by all HTTP sessions together
// (http.limits.max_buffered_body_mb). A session reserves a body's size from its header, before the
// body is read (the declared Content-Length, or the route's limit for a chunked body; a streamed
// G-code upload reserves the one chunk it holds at a time) and keeps the reservation until its
// response is ready. A reservation the budget cannot cover is refused (the session answers 503
// body-budget-exhausted): many parallel bodies can no longer take the process's memory.
//
//   auto budget = std::make_shared<body_budget>(64 << 20);
//   auto r = budget->try_reserve(content_length);   // nullopt: over budget
//   ...                                              // ~reservation (or reset()) gives it back
//
// Thread-safe; reservations may outlive the budget's owner.

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>

namespace gw::api {

class body_budget {
  public:
    class reservation {
      public:
        reservation() = default;
        reservation(reservation&& o) noexcept : used_(std::move(o.used_)), bytes_(o.bytes_) { o.bytes_ = 0; }
        reservation& operator=(reservation&& o) noexcept {
            if (this != &o) {
                reset();
                used_ = std::move(o.used_);
                bytes_ = o.bytes_;
                o.bytes_ = 0;
            }
            return *this;
        }
        reservation(const reservation&) = delete;
        reservation& operator=(const reservation&) = delete;
        ~reservation() { reset(); }

        void reset() {
            if (used_ && bytes_ > 0) used_->fetch_sub(bytes_);
            used_.reset();
            bytes_ = 0;
        }
        std::uint64_t bytes() const { return bytes_; }

      private:
        friend class body_budget;
        reservation(std::shared_ptr<std::atomic<std::uint64_t>> used, std::uint64_t bytes)
            : used_(std::move(used)), bytes_(bytes) {}
        std::shared_ptr<std::atomic<std::uint64_t>> used_;
        std::uint64_t bytes_ = 0;
    };

    explicit body_budget(std::uint64_t capacity) : capacity_(capacity) {}

    std::optional<reservation> try_reserve(std::uint64_t bytes) {
        auto used = used_->load();
        do {
            if (bytes > capacity_ - std::min(used, capacity_)) return std::nullopt;
        } while (!used_->compare_exchange_weak(used, used + bytes));
        return reservation(used_, bytes);
    }

    std::uint64_t capacity() const { return capacity_; }
    std::uint64_t in_use() const { return used_->load(); }

  private:
    std::uint64_t capacity_;
    std::shared_ptr<std::atomic<std::uint64_t>> used_ = std::make_shared<std::atomic<std::uint64_t>>(0);
};

}  // namespace gw::api
