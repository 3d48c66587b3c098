#pragma once
// The JSON payloads the gateway publishes over MQTT that are not event hub messages. Pure: no I/O,
// no clock (times are arguments). Every payload is one JSON object; openapi/asyncapi.yaml has their
// schemas.
//
// status (retained):
//   birth:   {"state":"online","gateway":"lab3","version":"0.1.0","protocol":"5","prefix":"asi",
//             "broker":"tcp://broker.lab:1883","url":"https://lab3.example:8443/"|null,
//             "capabilities":["state","position","reports","ttl","jobs","commands"],
//             "controllers":[{"id":"sim1","state":"connected","build":"STD_XYZ","modules":[...]}],
//             "time":"2026-11-30T08:00:00.000Z"}
//   offline: {"state":"offline","gateway":"lab3","reason":"shutdown"|"connection lost","time":...|null}
//            (the Last Will has no time: the broker sends it when the gateway is already gone)
// controllers/<id>/state, position, ttl: the event hub's message as is (gateway/events/event.hpp):
//   {"type":"event","topic":"controllers/sim1/state","seq":12,"time":...,"time_ms":...,"data":{...}}
// controllers/<id>/reports, one message per batch of encoder frames:
//   {"type":"reports","controller":"sim1","frames":[{...report data...}],"from":101,"to":140,
//    "missed":3,"time":...}   ("missed": frames that did not reach MQTT since the previous batch)
// jobs/<job>/state (retained; an empty retained message clears it):
//   {"type":"job","seq":7,"time":...,"job":{...the job as GET /api/v1/jobs/{id}...}}

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "gateway/events/event.hpp"

namespace gw::api {

struct mqtt_birth {
    std::string gateway;
    std::string version;
    std::string protocol;  // "5" or "3.1.1"
    std::string prefix;
    std::string broker;  // the broker it is connected to (one of mqtt.brokers)
    std::string url;     // http.public_url: where people reach its page; "" when not configured
    bool commands = false;
    nlohmann::json controllers = nlohmann::json::array();  // birth_controller() entries
    std::chrono::system_clock::time_point time;
};

std::string birth_payload(const mqtt_birth& b);
// `time` nullopt: the Last Will (registered at connect time, sent later by the broker).
std::string offline_payload(std::string_view gateway, std::string_view reason,
                            std::optional<std::chrono::system_clock::time_point> time);

// One entry of the birth's "controllers" from a controller state (gateway/events/event_json.hpp state_json).
nlohmann::json birth_controller(const nlohmann::json& state);

// Encoder report frames of one controller, collected between two publications.
class mqtt_report_batch {
  public:
    // A data event of topic controllers/<id>/reports (a frame, or a report_overrun_json notice whose
    // count is added), or a gap event of it (its count is added).
    void add(const event& e);
    // Frames that never reached the batch (dropped while the broker was unreachable).
    void add_missed(std::uint64_t n) { missed_ += n; }

    bool empty() const { return frames_.empty() && missed_ == 0 && controller_overruns_ == 0; }
    std::size_t frames() const { return frames_.size(); }
    std::uint64_t missed() const { return missed_; }

    // The payload of everything collected; the batch is empty afterwards.
    std::string take_payload(std::string_view controller, std::chrono::system_clock::time_point time);

  private:
    std::vector<std::shared_ptr<const std::string>> frames_;  // each one JSON value (the event data)
    std::uint64_t from_ = 0;
    std::uint64_t to_ = 0;
    std::uint64_t missed_ = 0;
    std::uint64_t controller_overruns_ = 0;  // frames the controller itself could not send (error 87)
};

// A job's retained state. apply() takes the data of an event of hub topic jobs/<id> ("state" events
// carry the whole job, "step" events its progress) and returns whether the job changed.
class mqtt_job_state {
  public:
    bool apply(const nlohmann::json& event_data);
    bool known() const { return job_.is_object(); }
    bool terminal() const;  // succeeded, failed, cancelled
    const nlohmann::json& job() const { return job_; }
    std::string payload(std::uint64_t seq, std::chrono::system_clock::time_point time) const;

  private:
    nlohmann::json job_;
};

}  // namespace gw::api
