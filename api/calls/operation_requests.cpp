#include "api/calls/operation_requests.hpp"

#include <array>
#include <cmath>
#include <fmt/format.h>
#include <utility>
#include <variant>

#include <boost/asio/append.hpp>
#include <boost/asio/bind_executor.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>

#include "api/calls/call_kinds.hpp"
#include "api/common/json_object.hpp"
#include "devices/ms2000/crisp.hpp"
#include "devices/ms2000/error.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/controllers/operations.hpp"
#include "gateway/events/event_json.hpp"
#include "gateway/jobs/manager/job_manager.hpp"
#include "gateway/leases/lease_manager.hpp"

namespace gw::api {

namespace net = boost::asio;
using nlohmann::json;

namespace {

// Reads one JSON object strictly: every key must be known, every value of the expected type.
class body_reader {
  public:
    body_reader(const json& body, std::initializer_list<std::string_view> known) : body_(body) {
        if (!body_.is_object()) {
            error_ = invalid_field("", "the body must be a JSON object");
            return;
        }
        if (auto unknown = find_unknown_field(body_, known, "this operation takes none"))
            fail(unknown->field, unknown->message);
    }

    const json* get(const char* key) const {
        if (error_ || !body_.is_object()) return nullptr;
        auto it = body_.find(key);
        return it == body_.end() ? nullptr : &*it;
    }

    std::optional<double> number(const char* key, const json& v) {
        if (!v.is_number() || !std::isfinite(v.get<double>())) {
            fail(key, std::string(key) + " must be a finite number, not " + std::string(json_type_name(v)));
            return std::nullopt;
        }
        return v.get<double>();
    }
    std::optional<std::int64_t> integer(const char* key, const json& v) {
        if (!v.is_number_integer()) {
            fail(key, std::string(key) + " must be an integer, not " + std::string(json_type_name(v)));
            return std::nullopt;
        }
        return v.get<std::int64_t>();
    }
    std::optional<bool> boolean(const char* key, const json& v) {
        if (!v.is_boolean()) {
            fail(key, std::string(key) + " must be true or false, not " + std::string(json_type_name(v)));
            return std::nullopt;
        }
        return v.get<bool>();
    }
    std::optional<std::string> string(const char* key, const json& v) {
        if (!v.is_string()) {
            fail(key, std::string(key) + " must be a string, not " + std::string(json_type_name(v)));
            return std::nullopt;
        }
        return v.get<std::string>();
    }
    std::optional<char> axis_letter(const std::string& field, std::string_view text) {
        if (text.size() != 1 || !std::isalpha(static_cast<unsigned char>(text[0]))) {
            fail(field, "\"" + std::string(text) + "\" is not an axis letter");
            return std::nullopt;
        }
        return static_cast<char>(std::toupper(static_cast<unsigned char>(text[0])));
    }

    // {"X": 1.5, "Y": -2}: at least one axis, each once.
    std::vector<std::pair<char, double>> axis_numbers(const char* key, const json& v) {
        std::vector<std::pair<char, double>> out;
        if (!v.is_object() || v.empty()) {
            fail(key, std::string(key) + " must be a non-empty object of axis letter -> number");
            return out;
        }
        for (const auto& [name, value] : v.items()) {
            std::string field = std::string(key) + "." + name;
            auto letter = axis_letter(field, name);
            if (!letter) return {};
            for (const auto& [l, _] : out)
                if (l == *letter) {
                    fail(field, "axis " + std::string(1, *letter) + " is given twice");
                    return {};
                }
            if (!value.is_number() || !std::isfinite(value.get<double>())) {
                fail(field, field + " must be a finite number, not " + std::string(json_type_name(value)));
                return {};
            }
            out.emplace_back(*letter, value.get<double>());
        }
        return out;
    }

    void fail(std::string field, std::string message) {
        if (!error_) error_ = invalid_field(std::move(field), std::move(message));
    }
    const std::optional<operation_error>& error() const { return error_; }

  private:
    const json& body_;
    std::optional<operation_error> error_;
};

using any_request = std::variant<move_request, halt_request, home_request, zero_request, here_request,
                                 speed_request, ttl_request, dac_request, led_request, crisp_request,
                                 autofocus_request, raw_command_request>;

// "timeout_ms": 1..max_wait_timeout.
void read_timeout(body_reader& r, std::chrono::milliseconds& out) {
    if (auto* v = r.get("timeout_ms")) {
        if (auto ms = r.integer("timeout_ms", *v)) {
            if (*ms < 1 || *ms > max_wait_timeout.count())
                r.fail("timeout_ms", "timeout_ms must be 1.." + std::to_string(max_wait_timeout.count()));
            else
                out = std::chrono::milliseconds(*ms);
        }
    }
}

operation_result<any_request> parse_move(const json& body) {
    body_reader r(body, {"axes", "mode", "wait", "timeout_ms"});
    move_request m;
    if (auto* v = r.get("axes"))
        for (auto [axis, um] : r.axis_numbers("axes", *v))
            m.axes.push_back({axis, um});
    else
        r.fail("axes", "axes is required: {\"X\": micrometres, ...}");
    if (auto* v = r.get("mode")) {
        auto s = r.string("mode", *v);
        if (s == "absolute")
            m.kind = move_request::mode::absolute;
        else if (s == "relative")
            m.kind = move_request::mode::relative;
        else if (s)
            r.fail("mode", "mode must be \"absolute\" or \"relative\"");
    }
    if (auto* v = r.get("wait"))
        if (auto b = r.boolean("wait", *v)) m.wait = *b;
    read_timeout(r, m.wait_timeout);
    if (r.error()) return *r.error();
    return any_request(std::move(m));
}

template <typename Request>
operation_result<any_request> parse_empty(const json& body) {
    body_reader r(body, {});
    if (r.error()) return *r.error();
    return any_request(Request{});
}

operation_result<any_request> parse_home(const json& body) {
    body_reader r(body, {"axes"});
    home_request h;
    if (auto* v = r.get("axes")) {
        if (!v->is_array() || v->empty()) {
            r.fail("axes", "axes must be a non-empty array of axis letters");
        } else {
            for (std::size_t i = 0; i < v->size() && !r.error(); ++i) {
                std::string field = "axes[" + std::to_string(i) + "]";
                const auto& a = (*v)[i];
                if (!a.is_string()) {
                    r.fail(field, field + " must be an axis letter");
                    break;
                }
                auto letter = r.axis_letter(field, a.get_ref<const std::string&>());
                if (!letter) break;
                if (h.axes.find(*letter) != std::string::npos)
                    r.fail(field, "axis " + std::string(1, *letter) + " is given twice");
                else
                    h.axes += *letter;
            }
        }
    }
    if (r.error()) return *r.error();
    return any_request(std::move(h));
}

operation_result<any_request> parse_here(const json& body) {
    body_reader r(body, {"axes"});
    here_request h;
    if (auto* v = r.get("axes"))
        for (auto [axis, um] : r.axis_numbers("axes", *v))
            h.axes.push_back({axis, um});
    else
        r.fail("axes", "axes is required: {\"X\": micrometres, ...}");
    if (r.error()) return *r.error();
    return any_request(std::move(h));
}

operation_result<any_request> parse_speed(const json& body) {
    body_reader r(body, {"axes"});
    speed_request s;
    if (auto* v = r.get("axes"))
        for (auto [axis, mm_s] : r.axis_numbers("axes", *v))
            s.axes.push_back({axis, mm_s});
    else
        r.fail("axes", "axes is required: {\"X\": mm/s, ...}");
    if (r.error()) return *r.error();
    return any_request(std::move(s));
}

operation_result<any_request> parse_ttl(const json& body) {
    body_reader r(body, {"in0_mode", "out0_mode", "output_high"});
    ttl_request t;
    auto small_int = [&](const char* key, const json& v) -> std::optional<int> {
        auto i = r.integer(key, v);
        if (!i) return std::nullopt;
        if (*i < 0 || *i > 127) {
            r.fail(key, std::string(key) + " must be 0..127");
            return std::nullopt;
        }
        return static_cast<int>(*i);
    };
    if (auto* v = r.get("in0_mode")) t.in0_mode = small_int("in0_mode", *v);
    if (auto* v = r.get("out0_mode")) t.out0_mode = small_int("out0_mode", *v);
    if (auto* v = r.get("output_high")) t.output_high = r.boolean("output_high", *v);
    if (!r.error() && !t.in0_mode && !t.out0_mode && !t.output_high)
        r.fail("", "give at least one of in0_mode, out0_mode, output_high");
    if (r.error()) return *r.error();
    return any_request(t);
}

operation_result<any_request> parse_dac(const json& body) {
    body_reader r(body, {"volts"});
    dac_request d;
    if (auto* v = r.get("volts")) {
        if (auto n = r.number("volts", *v)) d.volts = *n;
    } else {
        r.fail("volts", "volts is required");
    }
    if (r.error()) return *r.error();
    return any_request(d);
}

operation_result<any_request> parse_led(const json& body) {
    body_reader r(body, {"percent", "channel"});
    led_request l;
    if (auto* v = r.get("percent")) {
        if (auto n = r.number("percent", *v)) l.percent = *n;
    } else {
        r.fail("percent", "percent is required");
    }
    if (auto* v = r.get("channel")) {
        if (auto s = r.string("channel", *v)) {
            if (auto c = r.axis_letter("channel", *s)) l.channel = *c;
        }
    }
    if (r.error()) return *r.error();
    return any_request(l);
}

operation_result<any_request> parse_crisp(const json& body) {
    body_reader r(body, {"action", "lock_offset", "save", "wait", "timeout_ms"});
    crisp_request c;
    if (auto* v = r.get("action")) {
        auto a = r.string("action", *v);
        if (a == "lock")
            c.what = crisp_request::action::lock;
        else if (a == "unlock")
            c.what = crisp_request::action::unlock;
        else if (a == "off")
            c.what = crisp_request::action::off;
        else if (a)
            r.fail("action", "action must be \"lock\", \"unlock\" or \"off\"");
    }
    if (auto* v = r.get("lock_offset")) c.lock_offset = r.number("lock_offset", *v);
    if (auto* v = r.get("save"))
        if (auto b = r.boolean("save", *v)) c.save = *b;
    if (auto* v = r.get("wait"))
        if (auto b = r.boolean("wait", *v)) c.wait = *b;
    read_timeout(r, c.wait_timeout);
    if (r.error()) return *r.error();
    return any_request(c);
}

operation_result<any_request> parse_autofocus(const json& body) {
    body_reader r(body, {"timeout_ms"});
    autofocus_request a;
    read_timeout(r, a.wait_timeout);
    if (r.error()) return *r.error();
    return any_request(a);
}

operation_result<any_request> parse_command(const json& body) {
    body_reader r(body, {"command", "force"});
    raw_command_request c;
    if (auto* v = r.get("command")) {
        if (auto s = r.string("command", *v)) c.command = std::move(*s);
    } else {
        r.fail("command", "command is required: {\"command\": \"W X Y\"}");
    }
    if (auto* v = r.get("force")) {
        if (auto b = r.boolean("force", *v)) c.force = *b;
    }
    if (r.error()) return *r.error();
    return any_request(std::move(c));
}

operation_result<any_request> parse_request(std::string_view op, const json& body_in) {
    static const json empty = json::object();
    const json& body = body_in.is_null() ? empty : body_in;
    if (op == "move") return parse_move(body);
    if (op == "halt") return parse_empty<halt_request>(body);
    if (op == "home") return parse_home(body);
    if (op == "zero") return parse_empty<zero_request>(body);
    if (op == "here") return parse_here(body);
    if (op == "speed") return parse_speed(body);
    if (op == "ttl") return parse_ttl(body);
    if (op == "dac") return parse_dac(body);
    if (op == "led") return parse_led(body);
    if (op == "crisp") return parse_crisp(body);
    if (op == "autofocus") return parse_autofocus(body);
    if (op == "command") return parse_command(body);
    return make_error(operation_error_kind::invalid_value, "unknown operation \"" + std::string(op) + "\"",
                      "op");
}

json or_null(const std::optional<double>& v) {
    return v ? json(*v) : json(nullptr);
}

json crisp_reading_json(const crisp_result& c) {
    return {{"state", std::string(1, c.state)},
            {"name", std::string(devices::ms2000::crisp_state_name(c.state))},
            {"focus_error", or_null(c.focus_error)},
            {"sum", or_null(c.sum)},
            {"lock_offset", or_null(c.lock_offset)},
            {"snr", or_null(c.snr)}};
}

// Whether a request may change what a job holding the controller relies on: everything but HALT, a
// CRISP read-out ({} only reads) and a raw command that only reads (devices::ms2000::only_reads).
bool may_change_controller(const any_request& r) {
    if (std::holds_alternative<halt_request>(r)) return false;
    if (const auto* crisp = std::get_if<crisp_request>(&r))
        return crisp->what != crisp_request::action::none || crisp->lock_offset || crisp->save;
    if (const auto* raw = std::get_if<raw_command_request>(&r)) {
        auto cmd = devices::ms2000::raw_command(raw->command);
        return !cmd || !devices::ms2000::only_reads(*cmd);
    }
    return true;
}

}  // namespace

std::optional<problem> job_hold_refusal(api_context& ctx, const std::string& controller,
                                        const std::optional<std::string>& lease_id) {
    if (!ctx.jobs) return std::nullopt;
    auto hold = ctx.jobs->holding(controller);
    if (!hold || (lease_id && hold->lease_id == lease_id)) return std::nullopt;
    return make_problem(make_error(
        operation_error_kind::job_active,
        fmt::format(
            "job {} is {} on {}: only the holder of the lease it runs under may change the controller "
            "now; reads and HALT are open to all (pause or cancel the job first)",
            hold->job_id, jobs::to_string(hold->state), controller)));
}

namespace {

json base_result(std::string_view id, std::string_view op, const std::string& request_id) {
    return {{"id", id}, {"operation", op}, {"request_id", request_id}};
}

}  // namespace

const std::vector<std::string_view>& operation_names() {
    static const std::vector<std::string_view> names = [] {
        std::vector<std::string_view> out;
        for (const auto& d : operation_descriptors())
            out.push_back(d.name);
        return out;
    }();
    return names;
}

bool is_operation(std::string_view name) {
    return operation_descriptor(name) != nullptr;
}

bool needs_lease(std::string_view operation) {
    const auto* d = operation_descriptor(operation);
    return !d || d->lease != lease_rule::none;
}

void run_operation(api_context& ctx, const caller& who, std::string_view controller_id,
                   std::string_view operation, const json& body, api_handler handler) {
    const std::string& request_id = who.request_id;
    const auto& lease_id = who.lease_id;
    // Never inline: post through the handler's associated executor (default ctx.executor).
    auto finish_now = [&](problem p) {
        net::post(ctx.executor, net::append(std::move(handler), failed(std::move(p), request_id)));
    };
    if (!is_operation(operation)) {
        return finish_now(
            make_problem(http_error::not_found, "no operation \"" + std::string(operation) + "\""));
    }
    auto parsed = parse_request(operation, body);
    if (!parsed) return finish_now(make_problem(parsed.error()));
    if (ctx.leases && needs_lease(operation)) {
        auto allowed = ctx.leases->check(
            std::string(controller_id), lease_id ? std::optional<std::string_view>(*lease_id) : std::nullopt);
        if (!allowed) return finish_now(make_problem(allowed.error()));
    }
    if (may_change_controller(*parsed))
        if (auto refused = job_hold_refusal(ctx, std::string(controller_id), lease_id))
            return finish_now(std::move(*refused));

    // The registry completes on its executor; from there the handler is dispatched to its own.
    auto shared = std::make_shared<api_handler>(std::move(handler));
    auto ex = ctx.executor;
    auto base = std::make_shared<json>(base_result(controller_id, operation, request_id));
    auto complete = [shared, base, request_id, ex](auto&& result, auto&& to_json) {
        api_outcome out;
        if (!result) {
            out = failed(result.error(), request_id);
        } else {
            out.body = std::move(*base);
            to_json(*result, out.body);
        }
        net::dispatch(ex, net::append(std::move(*shared), std::move(out)));
    };
    auto done_json = [](const operation_done& d, json& j) { j["latency_us"] = d.latency.count(); };
    std::string id(controller_id);
    auto& reg = ctx.registry;

    std::visit(
        [&](auto& r) {
            using R = std::decay_t<decltype(r)>;
            if constexpr (std::is_same_v<R, move_request>) {
                reg.async_move(id, std::move(r), request_id,
                               net::bind_executor(ex, [complete](const operation_result<move_result>& res) {
                                   complete(res, [](const move_result& m, json& j) {
                                       j["waited"] = m.waited;
                                       json pos = json::array();
                                       for (const auto& a : m.positions)
                                           pos.push_back({{"axis", std::string(1, a.axis)},
                                                          {"position_um", a.micrometres}});
                                       j["positions"] = std::move(pos);
                                   });
                               }));
            } else if constexpr (std::is_same_v<R, crisp_request>) {
                reg.async_crisp(id, r, request_id,
                                net::bind_executor(ex, [complete](const operation_result<crisp_result>& res) {
                                    complete(res, [](const crisp_result& c, json& j) {
                                        j["crisp"] = crisp_reading_json(c);
                                        j["latency_us"] = c.latency.count();
                                    });
                                }));
            } else if constexpr (std::is_same_v<R, autofocus_request>) {
                reg.async_autofocus(
                    id, r, request_id,
                    net::bind_executor(ex, [complete](const operation_result<autofocus_result>& res) {
                        complete(res, [](const autofocus_result& a, json& j) {
                            j["z_um"] = a.z_um;
                            j["latency_us"] = a.latency.count();
                        });
                    }));
            } else if constexpr (std::is_same_v<R, raw_command_request>) {
                auto command = r.command;
                reg.async_raw_command(
                    id, std::move(r), request_id,
                    net::bind_executor(ex,
                                       [complete, command](const operation_result<raw_command_result>& res) {
                                           complete(res, [&](const raw_command_result& c, json& j) {
                                               j["command"] = command;
                                               j["raw_reply"] = c.raw_reply;
                                               j["reply"] = reply_json(c.reply);
                                               j["latency_us"] = c.latency.count();
                                           });
                                       }));
            } else {
                auto h = net::bind_executor(ex, [complete, done_json](operation_result<operation_done> res) {
                    complete(res, done_json);
                });
                if constexpr (std::is_same_v<R, halt_request>)
                    reg.async_emergency_halt(id, who.name, request_id, std::move(h));
                else if constexpr (std::is_same_v<R, zero_request>)
                    reg.async_zero(id, request_id, std::move(h));
                else if constexpr (std::is_same_v<R, home_request>)
                    reg.async_home(id, std::move(r), request_id, std::move(h));
                else if constexpr (std::is_same_v<R, here_request>)
                    reg.async_here(id, std::move(r), request_id, std::move(h));
                else if constexpr (std::is_same_v<R, speed_request>)
                    reg.async_speed(id, std::move(r), request_id, std::move(h));
                else if constexpr (std::is_same_v<R, ttl_request>)
                    reg.async_ttl(id, std::move(r), request_id, std::move(h));
                else if constexpr (std::is_same_v<R, dac_request>)
                    reg.async_dac(id, std::move(r), request_id, std::move(h));
                else if constexpr (std::is_same_v<R, led_request>)
                    reg.async_led(id, std::move(r), request_id, std::move(h));
            }
        },
        *parsed);  // each alternative is moved into its registry call above
}

}  // namespace gw::api
