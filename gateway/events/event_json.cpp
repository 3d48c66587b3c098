#include "gateway/events/event_json.hpp"

#include <charconv>
#include <cmath>
#include <iterator>
#include <optional>
#include <string>

#include "devices/ms2000/build_info.hpp"
#include "devices/ms2000/crisp.hpp"
#include "devices/ms2000/error.hpp"
#include "devices/ms2000/error_log.hpp"
#include "gateway/common/json_text.hpp"
#include "gateway/common/timestamp.hpp"

namespace gw {

namespace {

// Nanometre resolution: enough for any stage, and "1234.5" stays "1234.5" in the output.
double round_um(double um) {
    return std::round(um * 1000.0) / 1000.0;
}

nlohmann::json um_or_null(const std::optional<double>& um) {
    return um ? nlohmann::json(round_um(*um)) : nlohmann::json(nullptr);
}

nlohmann::json mm_to_um_or_null(const std::optional<double>& mm) {
    return mm ? nlohmann::json(round_um(*mm * 1000.0)) : nlohmann::json(nullptr);
}

template <typename T>
nlohmann::json or_null(const std::optional<T>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

nlohmann::json time_or_null(const std::optional<std::chrono::system_clock::time_point>& t) {
    return t ? nlohmann::json(format_timestamp(*t)) : nlohmann::json(nullptr);
}

template <typename Integer>
void append_integer(std::string& out, Integer value) {
    char digits[24];
    const auto [end, ec] = std::to_chars(std::begin(digits), std::end(digits), value);
    out.append(digits, end);
}

// The shortest text that reads back as the same double, with ".0" on a whole number (as nlohmann
// writes it: a client's parser keeps it a float). Not finite: null, as nlohmann writes it.
void append_double(std::string& out, double value) {
    if (!std::isfinite(value)) {
        out += "null";
        return;
    }
    char digits[32];
    const auto [end, ec] = std::to_chars(std::begin(digits), std::end(digits), value);
    const std::string_view text(digits, static_cast<std::size_t>(end - digits));
    out += text;
    if (text.find_first_of(".e") == std::string_view::npos) out += ".0";
}

std::string axis_name(char letter) {
    return std::string(1, letter);
}

std::string_view kind_name(devices::ms2000::reply::kind k) {
    using kind = devices::ms2000::reply::kind;
    switch (k) {
        case kind::ack:
            return "ack";
        case kind::error:
            return "error";
        case kind::status:
            return "status";
        case kind::text:
            return "text";
    }
    return "text";
}

}  // namespace

nlohmann::json identity_json(const devices::controller_identity& id) {
    namespace ms2000 = devices::ms2000;
    auto modules = nlohmann::json::array();
    for (std::size_t i = 0; i < static_cast<std::size_t>(ms2000::module::count_); ++i) {
        auto m = static_cast<ms2000::module>(i);
        if (id.build.has(m)) modules.push_back(std::string(ms2000::module_id(m)));
    }
    return {{"version", id.version},
            {"version_raw", id.version_raw},
            {"build", id.build.name},
            {"motor_axes", id.build.motor_axes},
            {"modules", std::move(modules)},
            {"module_lines", id.build.module_lines},
            {"ring_buffer_size", id.build.ring_buffer_size}};
}

nlohmann::json state_json(const devices::controller_snapshot& s) {
    return state_json(s, s.identity ? identity_json(*s.identity) : nlohmann::json(nullptr));
}

namespace {

// null for a controller without CRISP (or before its first poll).
nlohmann::json crisp_json(std::optional<char> state) {
    if (!state) return nullptr;
    return {{"state", std::string(1, *state)},
            {"name", std::string(devices::ms2000::crisp_state_name(*state))}};
}

nlohmann::json error_log_codes_json(const std::vector<int>& codes) {
    auto out = nlohmann::json::array();
    for (const int code : codes)
        out.push_back({{"code", code}, {"name", std::string(devices::ms2000::error_log_name(code))}});
    return out;
}

constexpr std::string_view overruns_prefix = R"({"controller_overruns":)";

}  // namespace

nlohmann::json report_overrun_json(const devices::error_log_event& e, std::uint64_t overruns) {
    return {{"controller_overruns", overruns},
            {"id", e.controller_id},
            {"time", format_timestamp(e.system_time)}};
}

std::optional<std::uint64_t> report_overruns(std::string_view text) {
    if (!text.starts_with(overruns_prefix)) return std::nullopt;
    text.remove_prefix(overruns_prefix.size());
    std::uint64_t n = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
    if (ec != std::errc()) return std::nullopt;
    return n;
}

nlohmann::json error_log_json(const devices::error_log_event& e) {
    return {{"id", e.controller_id},
            {"codes", error_log_codes_json(e.codes)},
            {"time", format_timestamp(e.system_time)}};
}

nlohmann::json state_json(const devices::controller_snapshot& s, nlohmann::json identity) {
    auto axes = nlohmann::json::array();
    for (const auto& a : s.axes) {
        axes.push_back({{"axis", axis_name(a.axis)},
                        {"position_um", um_or_null(a.position_um)},
                        {"busy", a.busy},
                        {"counts_per_mm", or_null(a.counts_per_mm)},
                        {"soft_limits_um",
                         {{"lower", mm_to_um_or_null(a.lower_limit_mm)},
                          {"upper", mm_to_um_or_null(a.upper_limit_mm)}}}});
    }
    nlohmann::json last_error = nullptr;
    if (s.last_error) {
        last_error = {{"code", s.last_error->code},
                      {"name", s.last_error->name},
                      {"text", s.last_error->text},
                      {"hint", s.last_error->hint.empty() ? nlohmann::json(nullptr)
                                                          : nlohmann::json(s.last_error->hint)},
                      {"time", format_timestamp(s.last_error->when)}};
    }
    return {
        {"id", s.id},
        {"state", std::string(devices::to_string(s.state))},
        {"port", s.port},
        {"busy", s.busy},
        {"identity", std::move(identity)},
        {"axes", std::move(axes)},
        {"ttl", {{"in0_mode", or_null(s.ttl_in0_mode)}, {"out0_mode", or_null(s.ttl_out0_mode)}}},
        {"crisp", crisp_json(s.crisp_state)},
        {"last_error", std::move(last_error)},
        {"error_log", {{"recent", error_log_codes_json(s.error_log_recent)}, {"count", s.error_log_count}}},
        {"report_port", std::string(devices::to_string(s.report))},
        {"last_attempt", time_or_null(s.last_attempt)},
        {"next_retry", time_or_null(s.next_retry)},
        {"halted", s.halted ? nlohmann::json{{"by", s.halted->by}, {"at", format_timestamp(s.halted->at)}}
                            : nlohmann::json(nullptr)},
        {"updated", format_timestamp(s.updated)}};
}

nlohmann::json position_json(const devices::controller_snapshot& s) {
    auto axes = nlohmann::json::array();
    for (const auto& a : s.axes)
        axes.push_back(
            {{"axis", axis_name(a.axis)}, {"position_um", um_or_null(a.position_um)}, {"busy", a.busy}});
    return {{"id", s.id}, {"busy", s.busy}, {"axes", std::move(axes)}};
}

std::string report_json_text(const devices::report_event& e) {
    // Written directly, not through a DOM: every frame of every report stream comes here (500 frames/s
    // per controller). Keys in the order nlohmann writes them (sorted), like every other event.
    std::string out;
    out.reserve(96 + e.controller_id.size() + e.axes.size() * 56);
    out += R"({"axes":[)";
    for (std::size_t i = 0; i < e.axes.size(); ++i) {
        const auto& a = e.axes[i];
        out += i == 0 ? R"({"axis":")" : R"(,{"axis":")";
        // A letter of the decoder's axis table; anything else would need escaping, and is no axis name.
        const bool letter = (a.letter >= 'A' && a.letter <= 'Z') || (a.letter >= 'a' && a.letter <= 'z');
        out += letter ? a.letter : '?';
        out += R"(","counts":)";
        append_integer(out, a.counts);
        out += R"(,"position_um":)";
        if (a.position_um)
            append_double(out, round_um(*a.position_um));
        else
            out += "null";
        out += '}';
    }
    out += R"(],"bytes_skipped":)";
    append_integer(out, e.bytes_skipped);
    out += R"(,"controller_seq":)";
    append_integer(out, e.sequence);
    out += R"(,"id":)";
    out += to_json_text(e.controller_id);
    out += R"(,"time":")";
    out += format_timestamp(e.system_time);
    out += R"("})";
    return out;
}

nlohmann::json ttl_json(const devices::ttl_event& e) {
    auto axes = nlohmann::json::array();
    for (const auto& a : e.axes)
        axes.push_back({{"axis", axis_name(a.letter)}, {"position_um", round_um(a.position_um)}});
    return {{"id", e.controller_id},
            {"controller_seq", e.sequence},
            {"time", format_timestamp(e.system_time)},
            {"controller_ms", e.controller_ms},
            {"axes", std::move(axes)}};
}

nlohmann::json reply_json(const devices::ms2000::reply& r) {
    nlohmann::json j = {{"kind", kind_name(r.what)}};
    if (r.what == devices::ms2000::reply::kind::error) {
        j["error_code"] = r.error_code;
        j["error_name"] = devices::ms2000::controller_error_name(r.error_code);
    }
    if (r.what == devices::ms2000::reply::kind::status) j["busy"] = r.busy;
    j["values"] = r.values;
    nlohmann::json axes = nlohmann::json::array();
    for (const auto& a : r.axes) {
        nlohmann::json aj = {{"axis", std::string(1, a.axis)}, {"text", a.text}};
        aj["number"] = a.number ? nlohmann::json(*a.number) : nlohmann::json(nullptr);
        axes.push_back(std::move(aj));
    }
    j["axes"] = std::move(axes);
    j["lines"] = r.lines;
    return j;
}

}  // namespace gw
