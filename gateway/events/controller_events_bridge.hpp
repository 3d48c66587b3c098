#pragma once
// Turns what controllers report into hub events:
//   every snapshot                      -> "controllers/<id>/state"    (state_json)
//   a snapshot whose positions/busy differ from the last published ones
//                                       -> "controllers/<id>/position" (position_json)
//   every report_event                  -> "controllers/<id>/reports"  (report_json_text)
//   every ttl_event                     -> "controllers/<id>/ttl"      (ttl_json)
//   every error_log_event               -> "controllers/<id>/errors"   (error_log_json), and if it
//                                          has 87s, "controllers/<id>/reports" (report_overrun_json)
// Event times: the snapshot's `updated` and the events' system_time (when the gateway received the
// bytes), so a client can line encoder frames and TTL reports up on one clock.
// Called on each controller's strand (several at once); serialises to JSON there and posts to the
// hub. One bridge serves every controller; the registry owns it and holds it by shared_ptr.
// Each state text is also kept in controller_state_texts (for GET /api/v1/controllers/{id}), and
// each controller's identity JSON is built once per identification, not per snapshot.

#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "devices/serial/controller_observer.hpp"

namespace gw {

class controller_state_texts;
class event_hub;

// "controllers/<id>/<leaf>"
std::string controller_topic(std::string_view id, std::string_view leaf);

class controller_events_bridge final : public devices::controller_observer {
  public:
    explicit controller_events_bridge(std::shared_ptr<event_hub> hub,
                                      std::shared_ptr<controller_state_texts> state_texts = nullptr);

    void on_snapshot(const devices::controller_snapshot& snapshot) override;
    void on_report(const devices::report_event& event) override;
    void on_ttl(const devices::ttl_event& event) override;
    void on_error_log(const devices::error_log_event& event) override;

    // The controller was removed; a controller with this id later starts with a fresh position.
    void forget(const std::string& id);

  private:
    struct known_identity {
        devices::controller_identity identity;
        nlohmann::json json;
    };
    // The identity's JSON, rebuilt only when the controller was identified differently.
    nlohmann::json identity_of(const devices::controller_snapshot& s);

    std::shared_ptr<event_hub> hub_;
    std::shared_ptr<controller_state_texts> state_texts_;
    // Guards the maps (several controller strands call in); held to compare and copy only.
    std::mutex mutex_;
    std::unordered_map<std::string, nlohmann::json> last_position_;
    std::unordered_map<std::string, known_identity> identities_;
};

}  // namespace gw
