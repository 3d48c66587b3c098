#pragma once
// What was taken within a time window, so that it is taken once: a signed command's (key, nonce)
// (api/mqtt/mqtt_signature.hpp), a command's (sender, id) against QoS 1 redelivery
// (api/mqtt/mqtt_commands.hpp). Pure.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <set>
#include <string>
#include <utility>

namespace gw::api {

// Remembers the (key, value) pairs admitted while their ts is within the window, so that a pair is
// refused when it comes again (a captured command published again, a redelivered one). Bounded: with
// max_entries remembered and none expired, a new pair is refused (full); the senders are known, so
// this is no anonymous cost.
class replay_window {
  public:
    enum class verdict : std::uint8_t { fresh, stale, replayed, full };

    replay_window(std::chrono::milliseconds window, std::size_t max_entries)
        : window_(window), max_entries_(max_entries) {}

    // `now_ms`: the gateway's clock, ms since the epoch. Remembers the pair when fresh.
    verdict admit(const std::string& key, const std::string& nonce, std::int64_t ts_ms, std::int64_t now_ms);
    std::size_t remembered() const { return seen_.size(); }

  private:
    void forget_before(std::int64_t cutoff_ms);

    std::chrono::milliseconds window_;
    std::size_t max_entries_;
    std::set<std::pair<std::string, std::string>> seen_;
    std::deque<std::pair<std::int64_t, std::pair<std::string, std::string>>> by_expiry_;  // admit order
};

}  // namespace gw::api
