#include "api/mqtt/mqtt_payloads.hpp"

#include <utility>

#include "gateway/common/timestamp.hpp"
#include "gateway/events/event_json.hpp"

namespace gw::api {

using nlohmann::json;

namespace {

// Payload text: never throws on odd strings (they come from parsed JSON or our own values).
std::string text(const json& j) {
    return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

json capabilities(bool commands) {
    json c = json::array({"state", "position", "reports", "ttl", "jobs"});
    if (commands) c.push_back("commands");
    return c;
}

}  // namespace

std::string birth_payload(const mqtt_birth& b) {
    json j = json::object();
    j["state"] = "online";
    j["gateway"] = b.gateway;
    j["version"] = b.version;
    j["protocol"] = b.protocol;
    j["prefix"] = b.prefix;
    j["broker"] = b.broker;
    j["url"] = b.url.empty() ? json(nullptr) : json(b.url);
    j["capabilities"] = capabilities(b.commands);
    j["controllers"] = b.controllers.is_array() ? b.controllers : json::array();
    j["time"] = format_timestamp(b.time);
    return text(j);
}

std::string offline_payload(std::string_view gateway, std::string_view reason,
                            std::optional<std::chrono::system_clock::time_point> time) {
    json j = json::object();
    j["state"] = "offline";
    j["gateway"] = gateway;
    j["reason"] = reason;
    j["time"] = time ? json(format_timestamp(*time)) : json(nullptr);
    return text(j);
}

json birth_controller(const json& state) {
    json c = json::object();
    c["id"] = state.value("id", "");
    c["state"] = state.value("state", "unknown");
    c["build"] = nullptr;
    c["modules"] = json::array();
    if (auto it = state.find("identity"); it != state.end() && it->is_object()) {
        if (auto b = it->find("build"); b != it->end() && b->is_string()) c["build"] = *b;
        if (auto m = it->find("modules"); m != it->end() && m->is_array()) c["modules"] = *m;
    }
    return c;
}

void mqtt_report_batch::add(const event& e) {
    if (e.kind == event_kind::gap) {
        missed_ += e.missed();
        return;
    }
    if (!e.data) return;
    if (const auto n = report_overruns(*e.data)) {
        controller_overruns_ += *n;
        return;
    }
    if (frames_.empty()) from_ = e.sequence;
    to_ = e.sequence;
    frames_.push_back(e.data);
}

std::string mqtt_report_batch::take_payload(std::string_view controller,
                                            std::chrono::system_clock::time_point time) {
    // The frames are embedded as the JSON text the hub serialised once: no parse, no copy of values.
    std::string out = R"({"type":"reports","controller":)";
    out += text(json(controller));
    out += R"(,"frames":[)";
    for (std::size_t i = 0; i < frames_.size(); ++i) {
        if (i != 0) out += ',';
        out += *frames_[i];
    }
    out += R"(],"from":)";
    out += frames_.empty() ? "null" : std::to_string(from_);
    out += R"(,"to":)";
    out += frames_.empty() ? "null" : std::to_string(to_);
    out += R"(,"missed":)";
    out += std::to_string(missed_);
    out += R"(,"controller_overruns":)";
    out += std::to_string(controller_overruns_);
    out += R"(,"time":")";
    out += format_timestamp(time);
    out += "\"}";
    frames_.clear();
    from_ = to_ = missed_ = controller_overruns_ = 0;
    return out;
}

bool mqtt_job_state::apply(const json& data) {
    if (!data.is_object()) return false;
    const auto type = data.value("type", "");
    if (type == "state") {
        auto it = data.find("job");
        if (it == data.end() || !it->is_object()) return false;
        job_ = *it;
        return true;
    }
    if (type == "step" && job_.is_object()) {
        auto& p = job_["progress"];
        if (!p.is_object()) p = json::object();
        for (const char* key :
             {"steps_done", "steps_total", "percent", "remaining_s", "elapsed_s", "waiting_for", "eta"})
            if (auto it = data.find(key); it != data.end()) p[key] = *it;
        if (auto it = data.find("name"); it != data.end()) p["current_step"] = *it;
        return true;
    }
    return false;
}

bool mqtt_job_state::terminal() const {
    if (!job_.is_object()) return false;
    const auto s = job_.value("state", "");
    return s == "succeeded" || s == "failed" || s == "cancelled";
}

std::string mqtt_job_state::payload(std::uint64_t seq, std::chrono::system_clock::time_point time) const {
    json j = json::object();
    j["type"] = "job";
    j["seq"] = seq;
    j["time"] = format_timestamp(time);
    j["job"] = job_;
    return text(j);
}

}  // namespace gw::api
