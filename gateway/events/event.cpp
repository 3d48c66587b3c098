#include "gateway/events/event.hpp"

#include <nlohmann/json.hpp>

#include "gateway/common/timestamp.hpp"

namespace gw {

namespace {

void append_time(std::string& out, std::chrono::system_clock::time_point time) {
    out += R"(,"time":")";
    out += format_timestamp(time);
    out += R"(","time_ms":)";
    out += std::to_string(epoch_ms(time));
}

// The event's topic, its address and its message, which ends here.
std::shared_ptr<const event> sealed(std::shared_ptr<event> e, std::string topic, std::string message) {
    message += '}';
    e->address = address_of(topic);
    e->topic = std::move(topic);
    e->message = std::make_shared<const std::string>(std::move(message));
    return e;
}

}  // namespace

std::shared_ptr<const event> make_data_event(std::string topic, std::uint64_t sequence,
                                             std::chrono::system_clock::time_point time,
                                             std::shared_ptr<const std::string> data,
                                             std::shared_ptr<const nlohmann::json> document) {
    auto e = std::make_shared<event>();
    e->document = std::move(document);
    e->kind = event_kind::data;
    e->sequence = sequence;
    e->time = time;
    // Built by hand so the payload text is embedded, not parsed and dumped again.
    std::string message;
    message.reserve(data->size() + topic.size() + 120);
    message += R"({"type":"event","topic":)";
    message += nlohmann::json(topic).dump();
    message += R"(,"seq":)";
    message += std::to_string(sequence);
    append_time(message, time);
    message += R"(,"data":)";
    message += *data;
    e->data = std::move(data);
    return sealed(std::move(e), std::move(topic), std::move(message));
}

std::shared_ptr<const event> make_gap_event(std::string topic, std::uint64_t from, std::uint64_t to,
                                            std::chrono::system_clock::time_point time) {
    auto e = std::make_shared<event>();
    e->kind = event_kind::gap;
    e->gap_from = from;
    e->gap_to = to;
    e->time = time;
    std::string message = R"({"type":"gap","topic":)";
    message += nlohmann::json(topic).dump();
    message += R"(,"missed":)";
    message += std::to_string(to - from + 1);
    message += R"(,"from":)";
    message += std::to_string(from);
    message += R"(,"to":)";
    message += std::to_string(to);
    append_time(message, time);
    return sealed(std::move(e), std::move(topic), std::move(message));
}

std::shared_ptr<const event> make_retired_event(std::string topic, std::uint64_t last_sequence,
                                                std::chrono::system_clock::time_point time) {
    auto e = std::make_shared<event>();
    e->kind = event_kind::retired;
    e->sequence = last_sequence;
    e->time = time;
    std::string message = R"({"type":"retired","topic":)";
    message += nlohmann::json(topic).dump();
    message += R"(,"last_seq":)";
    message += std::to_string(last_sequence);
    append_time(message, time);
    return sealed(std::move(e), std::move(topic), std::move(message));
}

}  // namespace gw
