#pragma once
// What the MQTT bridge tells of its link to the broker, for GET /api/v1/health: written on the
// bridge's strand, read by HTTP sessions on the I/O threads (thread-safe).

#include <cstdint>
#include <mutex>
#include <string>

#include <nlohmann/json.hpp>

namespace gw::api {

class mqtt_link_state {
  public:
    // session: "clean" (a new one at every connect), "kept" (the broker had kept it) or "new" (it had
    // not: the first connect, or it lost what it held).
    void connected(std::string broker, std::string protocol, std::string session) {
        std::lock_guard lock(mutex_);
        broker_ = std::move(broker);
        protocol_ = std::move(protocol);
        session_ = std::move(session);
        ++connects_;
    }
    void disconnected() {
        std::lock_guard lock(mutex_);
        broker_.clear();
    }
    // {"connected", "broker", "protocol" and "session" (null while disconnected), "connects"}
    nlohmann::json to_json() const {
        std::lock_guard lock(mutex_);
        return {{"connected", !broker_.empty()},
                {"broker", broker_.empty() ? nlohmann::json(nullptr) : nlohmann::json(broker_)},
                {"protocol", broker_.empty() ? nlohmann::json(nullptr) : nlohmann::json(protocol_)},
                {"session", broker_.empty() ? nlohmann::json(nullptr) : nlohmann::json(session_)},
                {"connects", connects_}};
    }

  private:
    mutable std::mutex mutex_;
    std::string broker_;    // the broker connected to; empty while disconnected
    std::string protocol_;  // "5" or "3.1.1": what the connection speaks
    std::string session_;   // "clean", "kept" or "new"
    std::uint64_t connects_ = 0;
};

}  // namespace gw::api
