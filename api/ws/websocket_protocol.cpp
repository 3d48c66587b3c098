#include "api/ws/websocket_protocol.hpp"

#include <charconv>
#include <cmath>
#include <initializer_list>
#include <optional>
#include <utility>

#include "api/calls/job_requests.hpp"
#include "api/calls/operation_requests.hpp"
#include "api/common/json_object.hpp"
#include "api/common/printable_text.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/events/topic.hpp"
#include "gateway/storage/gcode_files.hpp"

namespace gw::api {

using nlohmann::json;

namespace {

ws_protocol_error invalid(json id, std::string field, std::string detail) {
    auto p =
        make_problem(make_error(operation_error_kind::invalid_value, std::move(detail), std::move(field)));
    p.instance = std::string(websocket_path);
    return {std::move(id), std::move(p)};
}

// Strings in messages come from parsed JSON (valid UTF-8), but a text frame must never make dump() throw.
std::string text(const json& j) {
    return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

// A valid client id, or the reason it is not one.
std::optional<std::string> id_problem(const json& id) {
    if (id.is_number_integer()) return std::nullopt;
    if (id.is_string()) {
        const auto& s = id.get_ref<const std::string&>();
        if (s.empty() || s.size() > ws_max_client_id_bytes || !is_printable_label(s))
            return "\"id\" must be 1.." + std::to_string(ws_max_client_id_bytes) +
                   " printable ASCII characters";
        return std::nullopt;
    }
    return std::string("\"id\" must be a string or an integer, not ") + std::string(json_type_name(id));
}

// "topics": a non-empty array of valid filters.
boost::system::result<std::vector<std::string>, ws_protocol_error> read_topics(const json& msg,
                                                                               const json& id) {
    auto it = msg.find("topics");
    if (it == msg.end()) return invalid(id, "topics", "\"topics\" is required (an array of topic filters)");
    if (!it->is_array() || it->empty())
        return invalid(id, "topics", "\"topics\" must be a non-empty array of topic filters");
    if (it->size() > ws_max_topics_per_message)
        return invalid(id, "topics",
                       "at most " + std::to_string(ws_max_topics_per_message) + " topics per message");
    std::vector<std::string> topics;
    for (std::size_t i = 0; i < it->size(); ++i) {
        const auto& t = (*it)[i];
        const auto field = "topics[" + std::to_string(i) + "]";
        if (!t.is_string())
            return invalid(id, field, field + " must be a string, not " + std::string(json_type_name(t)));
        const auto& s = t.get_ref<const std::string&>();
        if (auto ec = validate_topic_filter(s))
            return invalid(id, field,
                           "invalid topic filter \"" + (is_printable_label(s) ? s : std::string("...")) +
                               "\": " + ec.message());
        topics.push_back(s);
    }
    return {boost::system::in_place_value, std::move(topics)};
}

boost::system::result<ws_client_message, ws_protocol_error> parse_subscribe(const json& msg, const json& id) {
    if (auto unknown = find_unknown_field(msg, {"op", "id", "topics", "resume", "max_rate_hz"}))
        return invalid(id, unknown->field, unknown->message);
    auto topics = read_topics(msg, id);
    if (!topics) return topics.error();
    ws_subscribe s{.id = id, .topics = std::move(*topics), .resume = {}, .max_rate_hz = 0};
    if (auto it = msg.find("max_rate_hz"); it != msg.end()) {
        if (!it->is_number())
            return invalid(id, "max_rate_hz",
                           "\"max_rate_hz\" must be a number, not " + std::string(json_type_name(*it)));
        const double hz = it->get<double>();
        if (!std::isfinite(hz) || hz < 0 || hz > ws_max_rate_hz)
            return invalid(id, "max_rate_hz", "\"max_rate_hz\" must be between 0 (no limit) and 1000");
        s.max_rate_hz = hz;
    }
    if (auto it = msg.find("resume"); it != msg.end()) {
        if (!it->is_object())
            return invalid(id, "resume", "\"resume\" must be an object {\"<topic>\": <sequence number>}");
        for (const auto& [topic, seq] : it->items()) {
            const auto field = "resume." + (is_printable_label(topic) ? topic : std::string("..."));
            if (auto ec = validate_topic_name(topic))
                return invalid(id, field,
                               "\"resume\" keys must be topic names without wildcards: " + ec.message());
            if (!seq.is_number_unsigned() && !(seq.is_number_integer() && seq.get<std::int64_t>() >= 0))
                return invalid(id, field, field + " must be a sequence number (an integer >= 0)");
            bool covered = false;
            for (const auto& f : s.topics)
                covered = covered || topic_matches(f, topic);
            if (!covered) return invalid(id, field, "\"" + topic + "\" matches none of the topics");
            s.resume.emplace(topic, seq.get<std::uint64_t>());
        }
    }
    return s;
}

boost::system::result<ws_client_message, ws_protocol_error> parse_unsubscribe(const json& msg, json id) {
    if (auto unknown = find_unknown_field(msg, {"op", "id", "topics"}))
        return invalid(id, unknown->field, unknown->message);
    auto topics = read_topics(msg, id);
    if (!topics) return topics.error();
    return ws_unsubscribe{.id = std::move(id), .topics = std::move(*topics)};
}

// "lease" / "idempotency_key": absent, or 1..128 printable characters without spaces.
boost::system::result<std::optional<std::string>, ws_protocol_error> read_key(const json& msg, const json& id,
                                                                              const char* name) {
    auto it = msg.find(name);
    if (it == msg.end() || it->is_null()) return std::optional<std::string>();
    if (!it->is_string() || !is_valid_key(it->get_ref<const std::string&>()))
        return invalid(id, name, std::string("\"") + name + "\" must be 1..128 printable ASCII characters");
    return std::optional<std::string>(it->get<std::string>());
}

boost::system::result<ws_client_message, ws_protocol_error> parse_job(const json& msg, const json& id) {
    if (auto unknown = find_unknown_field(
            msg, {"op", "id", "action", "job", "args", "lease", "idempotency_key", "dry_run"}))
        return invalid(id, unknown->field, unknown->message);
    if (id.is_null()) return invalid(id, "id", "a job message needs an \"id\" (echoed in its answer)");
    constexpr std::string_view actions = "submit, get, cancel, pause, resume, next";
    auto action = msg.find("action");
    if (action == msg.end() || !action->is_string())
        return invalid(id, "action", "\"action\" must be one of: " + std::string(actions));
    const auto& a = action->get_ref<const std::string&>();
    if (a != "submit" && a != "get" && !parse_job_command(a))
        return invalid(id, "action",
                       "unknown action \"" + (is_printable_label(a) ? a : std::string("...")) +
                           "\" (one of: " + std::string(actions) + ")");
    job_message j;
    j.id = id;
    j.action = a;
    auto lease = read_key(msg, id, "lease");
    if (!lease) return lease.error();
    j.lease = std::move(*lease);
    if (a == "submit") {
        if (msg.contains("job")) return invalid(id, "job", "\"job\" is not used by submit (the job is new)");
        auto args = msg.find("args");
        if (args == msg.end() || !args->is_object())
            return invalid(id, "args", "submit needs \"args\": {\"controller\", \"type\", \"spec\"}");
        j.args = *args;
        auto key = read_key(msg, id, "idempotency_key");
        if (!key) return key.error();
        j.idempotency_key = std::move(*key);
        if (auto it = msg.find("dry_run"); it != msg.end()) {
            if (!it->is_boolean()) return invalid(id, "dry_run", "\"dry_run\" must be true or false");
            j.dry_run = it->get<bool>();
        }
        return j;
    }
    for (const char* only_submit : {"args", "idempotency_key", "dry_run"})
        if (msg.contains(only_submit))
            return invalid(id, only_submit, std::string("\"") + only_submit + "\" is only used by submit");
    auto job = msg.find("job");
    if (job == msg.end() || !job->is_string() || !is_plausible_job_id(job->get_ref<const std::string&>()))
        return invalid(id, "job", "\"job\" must be a job id (\"j-...\")");
    j.job = job->get<std::string>();
    return j;
}

boost::system::result<ws_client_message, ws_protocol_error> parse_gcode(const json& msg, json id) {
    if (auto unknown = find_unknown_field(msg, {"op", "id", "action", "file", "options"}))
        return invalid(id, unknown->field, unknown->message);
    if (id.is_null()) return invalid(id, "id", "a gcode message needs an \"id\" (echoed in its answer)");
    auto action = msg.find("action");
    if (action == msg.end() || !action->is_string() || action->get_ref<const std::string&>() != "check")
        return invalid(id, "action", "\"action\" must be \"check\"");
    auto file = msg.find("file");
    if (file == msg.end() || !file->is_string() || !is_gcode_file_id(file->get_ref<const std::string&>()))
        return invalid(id, "file", "\"file\" must be a stored G-code file id (\"g-...\")");
    json options;
    if (auto it = msg.find("options"); it != msg.end() && !it->is_null()) {
        if (!it->is_object())
            return invalid(id, "options",
                           "\"options\" must be an object, not " + std::string(json_type_name(*it)));
        options = *it;
    }
    return gcode_message{.id = std::move(id),
                         .action = "check",
                         .file = file->get<std::string>(),
                         .options = std::move(options)};
}

boost::system::result<ws_client_message, ws_protocol_error> parse_command(const json& msg, json id) {
    if (auto unknown = find_unknown_field(msg, {"op", "id", "controller", "operation", "args", "lease"}))
        return invalid(id, unknown->field, unknown->message);
    if (id.is_null()) return invalid(id, "id", "a command needs an \"id\" (echoed in its answer)");
    auto controller = msg.find("controller");
    if (controller == msg.end() || !controller->is_string() ||
        controller->get_ref<const std::string&>().empty())
        return invalid(id, "controller", "\"controller\" must be a controller id (a non-empty string)");
    auto operation = msg.find("operation");
    if (operation == msg.end() || !operation->is_string())
        return invalid(
            id, "operation", "\"operation\" must be one of: " + [] {
                std::string list;
                for (auto n : operation_names())
                    list += (list.empty() ? "" : ", ") + std::string(n);
                return list;
            }());
    const auto& op = operation->get_ref<const std::string&>();
    if (!is_operation(op)) {
        std::string list;
        for (auto n : operation_names())
            list += (list.empty() ? "" : ", ") + std::string(n);
        return invalid(id, "operation",
                       "unknown operation \"" + (is_printable_label(op) ? op : std::string("...")) +
                           "\" (one of: " + list + ")");
    }
    json args = json::object();
    if (auto it = msg.find("args"); it != msg.end() && !it->is_null()) {
        if (!it->is_object())
            return invalid(id, "args", "\"args\" must be an object, not " + std::string(json_type_name(*it)));
        args = *it;
    }
    auto lease = read_key(msg, id, "lease");
    if (!lease) return lease.error();
    return command_message{.id = std::move(id),
                           .controller = controller->get<std::string>(),
                           .operation = op,
                           .args = std::move(args),
                           .lease = std::move(*lease)};
}

}  // namespace

boost::system::result<ws_client_message, ws_protocol_error> parse_client_message(std::string_view text) {
    json msg = json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (msg.is_discarded()) {
        auto p = make_problem(http_error::malformed_json, "the message is not valid JSON");
        p.instance = std::string(websocket_path);
        return ws_protocol_error{json(), std::move(p)};
    }
    return parse_client_json(msg);
}

boost::system::result<ws_client_message, ws_protocol_error> parse_client_json(const json& msg) {
    if (!msg.is_object()) {
        auto p = make_problem(http_error::malformed_json, "a message must be a JSON object");
        p.instance = std::string(websocket_path);
        return ws_protocol_error{json(), std::move(p)};
    }
    // The id first, so that every later error can be matched to the message.
    json id;
    if (auto it = msg.find("id"); it != msg.end() && !it->is_null()) {
        if (auto why = id_problem(*it)) return invalid(json(), "id", *why);
        id = *it;
    }
    auto op = msg.find("op");
    if (op == msg.end() || !op->is_string())
        return invalid(id, "op",
                       "\"op\" must be one of: subscribe, unsubscribe, command, job, gcode, halt_all, ping");
    const auto& name = op->get_ref<const std::string&>();
    if (name == "subscribe") return parse_subscribe(msg, id);
    if (name == "unsubscribe") return parse_unsubscribe(msg, std::move(id));
    if (name == "command") return parse_command(msg, std::move(id));
    if (name == "job") return parse_job(msg, id);
    if (name == "gcode") return parse_gcode(msg, std::move(id));
    if (name == "halt_all") {
        if (auto unknown = find_unknown_field(msg, {"op", "id"}))
            return invalid(id, unknown->field, unknown->message);
        if (id.is_null()) return invalid(id, "id", "\"id\" is required for halt_all (the answer carries it)");
        return halt_all_message{std::move(id)};
    }
    if (name == "ping") {
        if (auto unknown = find_unknown_field(msg, {"op", "id"}))
            return invalid(id, unknown->field, unknown->message);
        return ws_ping{std::move(id)};
    }
    return invalid(id, "op",
                   "unknown op \"" + (is_printable_label(name) ? name : std::string("...")) +
                       "\" (one of: subscribe, unsubscribe, command, job, gcode, halt_all, ping)");
}

ws_protocol_error binary_frame_error() {
    auto p =
        make_problem(http_error::malformed_json, "binary frames are not accepted: send JSON text frames");
    p.instance = std::string(websocket_path);
    return {json(), std::move(p)};
}

std::string ws_request_id(std::string_view connection, const json& client_id) {
    std::string id(connection);
    id += '.';
    id += client_id.is_string() ? client_id.get<std::string>() : client_id.dump();
    return id;
}

std::string ws_hello_message(std::string_view connection, std::string_view user, const json& whoami,
                             std::size_t max_message_bytes,
                             std::optional<std::chrono::milliseconds> batch_window) {
    return text(json{{"type", "hello"},
                     {"connection", connection},
                     {"user", user},
                     {"role", whoami.value("role", "viewer")},
                     {"client", whoami.value("client", json(nullptr))},
                     {"auth", whoami.value("auth", "none")},
                     {"max_message_bytes", max_message_bytes},
                     {"batch_ms", batch_window ? json(batch_window->count()) : json(nullptr)}});
}

operation_result<websocket_options> parse_websocket_options(std::string_view target) {
    auto q = parse_query(target);
    if (!q) return q.error();
    websocket_options options;
    if (auto v = query_value(*q, "batch_ms")) {
        unsigned long long n = 0;
        const auto* end = v->data() + v->size();
        auto [ptr, ec] = std::from_chars(v->data(), end, n);
        if (v->empty() || ec != std::errc() || ptr != end ||
            n > static_cast<unsigned long long>(max_batch_window.count()))
            return make_error(operation_error_kind::invalid_value,
                              "batch_ms must be an integer 0.." + std::to_string(max_batch_window.count()) +
                                  " (milliseconds between event batches)",
                              "batch_ms");
        options.batch_window = std::chrono::milliseconds(n);
    }
    return options;
}

std::string ws_batch_message(const std::vector<std::shared_ptr<const event>>& events) {
    constexpr std::string_view head = R"({"type":"batch","events":[)";
    constexpr std::string_view tail = "]}";
    std::size_t size = head.size() + tail.size();
    for (const auto& e : events)
        size += e->message->size() + 1;
    std::string out;
    out.reserve(size);
    out += head;
    for (std::size_t i = 0; i < events.size(); ++i) {
        if (i != 0) out += ',';
        out += *events[i]->message;
    }
    out += tail;
    return out;
}

std::string ws_subscribed_message(const ws_subscribe& request) {
    json resume = json::object();
    for (const auto& [topic, seq] : request.resume)
        resume[topic] = seq;
    return text(json{{"type", "subscribed"},
                     {"id", request.id},
                     {"topics", request.topics},
                     {"resume", std::move(resume)},
                     {"max_rate_hz", request.max_rate_hz}});
}

std::string ws_unsubscribed_message(const ws_unsubscribe& request) {
    return text(json{{"type", "unsubscribed"}, {"id", request.id}, {"topics", request.topics}});
}

std::string call_result_message(const json& id, const json& result, bool replayed) {
    // Written around the result's own text rather than copying the result into a new document: the
    // same bytes (keys in the order a json object keeps them), one copy less on every call's answer.
    std::string out = R"({"id":)";
    out += text(id);
    if (replayed) out += R"(,"replayed":true)";
    out += R"(,"result":)";
    out += text(result);
    out += R"(,"type":"result"})";
    return out;
}

std::string call_error_message(const json& id, const problem& error) {
    return text(json{{"type", "error"}, {"id", id}, {"problem", error.to_json()}});
}

std::string ws_pong_message(const json& id) {
    return text(json{{"type", "pong"}, {"id", id}});
}

call to_call(command_message m) {
    return operation_call{std::move(m.controller), std::move(m.operation), std::move(m.args)};
}

call to_call(job_message m) {
    if (m.action == "submit")
        return job_submit_call{std::move(m.args), m.dry_run, std::move(m.idempotency_key)};
    if (m.action == "get") return job_get_call{std::move(m.job)};
    // parse_job_command: the message parser accepted only known actions.
    return job_action_call{std::move(m.job), parse_job_command(m.action).value_or(job_command::cancel)};
}

call to_call(gcode_message m) {
    return gcode_check_call{std::move(m.file), std::move(m.options)};
}

}  // namespace gw::api
