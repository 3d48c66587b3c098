#pragma once
// Rate limit for a repeating log message: within one interval the 1st, 2nd, 4th, 8th ... occurrence
// passes, the others are counted and reported with the next one that passes. Not thread-safe: each
// controller keeps its own on its strand.

#include <chrono>
#include <cstdint>

namespace gw::devices {

class log_limiter {
  public:
    explicit log_limiter(std::chrono::steady_clock::duration interval = std::chrono::seconds(10))
        : interval_(interval) {}

    // True if this occurrence should be logged; `suppressed` is then how many were dropped before it.
    bool allow(std::chrono::steady_clock::time_point now, std::uint64_t& suppressed) {
        if (count_ == 0 || now - window_start_ >= interval_) {
            window_start_ = now;
            count_ = 0;
        }
        ++count_;
        if ((count_ & (count_ - 1)) == 0) {  // a power of two
            suppressed = dropped_;
            dropped_ = 0;
            return true;
        }
        ++dropped_;
        return false;
    }

  private:
    std::chrono::steady_clock::duration interval_;
    std::chrono::steady_clock::time_point window_start_{};
    std::uint64_t count_ = 0;
    std::uint64_t dropped_ = 0;
};

}  // namespace gw::devices
