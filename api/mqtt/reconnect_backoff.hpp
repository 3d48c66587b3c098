#pragma once
// How long the MQTT client waits before its next connect attempt: capped exponential backoff with
// jitter. The base wait starts at `min` and doubles after every failed attempt up to `max`; each wait
// is drawn at random from [base / 2, base] ("equal jitter"), so a fleet of gateways that lost the same
// broker does not come back in lockstep, and no wait is ever longer than `max`. That bound is what
// matters after a long outage: the broker's return is noticed at most `max` later (plus the connect).
// Pure apart from its random generator (seeded by the caller in tests).

#include <chrono>
#include <cstdint>
#include <random>

namespace gw::api {

class reconnect_backoff {
  public:
    // `max` below `min` counts as `min`; `min` below 1 ms counts as 1 ms.
    reconnect_backoff(std::chrono::milliseconds min, std::chrono::milliseconds max, std::uint64_t seed);

    // The wait before the next attempt; the base doubles for the one after.
    std::chrono::milliseconds next();
    // Connected: the next loss starts again from `min`.
    void reset();

  private:
    std::chrono::milliseconds min_;
    std::chrono::milliseconds max_;
    std::chrono::milliseconds base_;
    std::mt19937_64 random_;
};

}  // namespace gw::api
