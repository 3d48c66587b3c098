#include "api/calls/job_requests.hpp"

#include <array>
#include <cctype>
#include <charconv>
#include <chrono>
#include <memory>

#include <boost/asio/append.hpp>
#include <boost/asio/bind_executor.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>

#include "api/common/json_object.hpp"
#include "api/common/printable_text.hpp"
#include "gateway/jobs/job_json.hpp"

namespace gw::api {

namespace net = boost::asio;
using nlohmann::json;

namespace {

constexpr std::size_t max_list_limit = 500;

int hex_digit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

std::optional<std::string> percent_decode(std::string_view s) {
    std::string out;
    out.reserve(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (s[i] != '%') {
            out += s[i];
            continue;
        }
        if (i + 2 >= s.size()) return std::nullopt;  // "%" or "%4" at the end
        const int hi = hex_digit(s[i + 1]);
        const int lo = hex_digit(s[i + 2]);
        if (hi < 0 || lo < 0) return std::nullopt;
        out += static_cast<char>(hi * 16 + lo);
        i += 2;
    }
    return out;
}

template <typename Names>
std::string joined(const Names& names) {
    std::string list;
    for (auto n : names)
        list += (list.empty() ? "" : ", ") + std::string(n);
    return list;
}

constexpr std::array<std::string_view, 5> job_type_names = {"array", "scan", "ring_buffer",
                                                            "planar_correction", "gcode"};
constexpr std::array<std::string_view, 7> job_state_names = {"queued", "running",   "paused",     "succeeded",
                                                             "failed", "cancelled", "interrupted"};
constexpr std::array<std::string_view, 4> command_names = {"cancel", "pause", "resume", "next"};

problem no_jobs_problem() {
    return make_problem(make_error(operation_error_kind::storage_unavailable,
                                   "jobs are not available: the gateway runs without a job store"));
}

}  // namespace

operation_result<query_params> parse_query(std::string_view target) {
    query_params out;
    auto q = target.find('?');
    if (q == std::string_view::npos) return out;
    std::string_view rest = target.substr(q + 1);
    while (!rest.empty()) {
        auto amp = rest.find('&');
        std::string_view part = rest.substr(0, amp);
        rest = amp == std::string_view::npos ? std::string_view{} : rest.substr(amp + 1);
        if (part.empty()) continue;
        auto eq = part.find('=');
        auto name = percent_decode(part.substr(0, eq));
        if (!name)
            return invalid_field(shown_in_message(part.substr(0, eq)),
                                 "malformed percent escape in a parameter name");
        std::optional<std::string> value = std::string();
        if (eq != std::string_view::npos) value = percent_decode(part.substr(eq + 1));
        if (!value)
            return invalid_field(*name,
                                 "malformed percent escape in the value of " + shown_in_message(*name));
        for (const auto& [n, _] : out)
            if (n == *name)
                return invalid_field(*name, "parameter " + shown_in_message(*name) + " is given twice");
        out.emplace_back(std::move(*name), std::move(*value));
    }
    return out;
}

operation_result<void> check_known_parameters(const query_params& q,
                                              std::initializer_list<std::string_view> known) {
    for (const auto& [name, _] : q) {
        bool ok = false;
        for (auto k : known)
            ok = ok || k == name;
        if (!ok) {
            std::string list;
            for (auto k : known)
                list += (list.empty() ? "" : ", ") + std::string(k);
            return invalid_field(shown_in_message(name),
                                 "unknown parameter \"" + shown_in_message(name) + "\"" +
                                     (list.empty() ? " (this route takes none)" : " (known: " + list + ")"));
        }
    }
    return {};
}

std::optional<std::size_t> parse_count(std::string_view s) {
    std::size_t n = 0;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), n);
    if (ec != std::errc{} || end != s.data() + s.size() || s.empty()) return std::nullopt;
    return n;
}

std::optional<std::string> query_value(const query_params& q, std::string_view name) {
    for (const auto& [n, v] : q)
        if (n == name) return v;
    return std::nullopt;
}

operation_result<bool> query_flag(const query_params& q, std::string_view name, bool fallback) {
    auto v = query_value(q, name);
    if (!v) return fallback;
    if (*v == "true" || *v == "1" || v->empty()) return true;
    if (*v == "false" || *v == "0") return false;
    return invalid_field(std::string(name),
                         std::string(name) + " must be true or false, not \"" + shown_in_message(*v) + "\"");
}

operation_result<jobs::job_filter> parse_job_filter(const query_params& q) {
    if (auto known = check_known_parameters(q, {"controller", "type", "state", "limit", "before"}); !known)
        return known.error();
    jobs::job_filter f;
    if (auto v = query_value(q, "controller")) {
        if (v->empty() || v->size() > 64 || !is_printable_word(*v))
            return invalid_field("controller", "controller must be a controller id");
        f.controller = *v;
    }
    if (auto v = query_value(q, "type")) {
        f.type = jobs::parse_job_type(*v);
        if (!f.type)
            return invalid_field("type", "unknown job type \"" + shown_in_message(*v) +
                                             "\" (one of: " + joined(job_type_names) + ")");
    }
    if (auto v = query_value(q, "state")) {
        f.state = jobs::parse_job_state(*v);
        if (!f.state)
            return invalid_field("state", "unknown job state \"" + shown_in_message(*v) +
                                              "\" (one of: " + joined(job_state_names) + ")");
    }
    if (auto v = query_value(q, "limit")) {
        auto n = parse_count(*v);
        if (!n || *n < 1 || *n > max_list_limit)
            return invalid_field("limit", "limit must be an integer 1.." + std::to_string(max_list_limit));
        f.limit = *n;
    }
    if (auto v = query_value(q, "before")) {
        if (!is_plausible_job_id(*v))
            return invalid_field("before", "before must be a job id (the \"next\" of a page)");
        f.before = *v;
    }
    return f;
}

operation_result<std::size_t> parse_event_limit(const query_params& q) {
    if (auto known = check_known_parameters(q, {"limit"}); !known) return known.error();
    auto v = query_value(q, "limit");
    if (!v) return default_event_limit;
    auto n = parse_count(*v);
    if (!n || *n < 1 || *n > max_event_limit)
        return invalid_field("limit", "limit must be an integer 1.." + std::to_string(max_event_limit));
    return *n;
}

operation_result<job_submission> parse_job_submission(const json& body_in) {
    static const json empty = json::object();
    const json& body = body_in.is_null() ? empty : body_in;
    if (!body.is_object())
        return invalid_field("", "the body must be a JSON object {\"controller\", \"type\", \"spec\"}");
    if (auto unknown = find_unknown_field(body, {"controller", "type", "spec"}))
        return invalid_field(unknown->field, unknown->message);
    job_submission s;
    auto c = body.find("controller");
    if (c == body.end()) return invalid_field("controller", "controller is required (a controller id)");
    if (!c->is_string() || c->get_ref<const std::string&>().empty())
        return invalid_field("controller", "controller must be a controller id (a non-empty string), not " +
                                               std::string(json_type_name(*c)));
    s.controller = c->get<std::string>();
    auto t = body.find("type");
    if (t == body.end())
        return invalid_field("type", "type is required (one of: " + joined(job_type_names) + ")");
    if (!t->is_string())
        return invalid_field("type", "type must be a string, not " + std::string(json_type_name(*t)));
    auto type = jobs::parse_job_type(t->get_ref<const std::string&>());
    if (!type)
        return invalid_field("type", "unknown job type \"" +
                                         shown_in_message(t->get_ref<const std::string&>()) +
                                         "\" (one of: " + joined(job_type_names) + ")");
    s.type = *type;
    auto sp = body.find("spec");
    if (sp == body.end())
        return invalid_field("spec", "spec is required (an object; {} takes every default)");
    if (!sp->is_object())
        return invalid_field("spec", "spec must be an object, not " + std::string(json_type_name(*sp)));
    s.spec = *sp;
    return s;
}

bool is_valid_key(std::string_view key) {
    return !key.empty() && key.size() <= max_key_bytes && is_printable_word(key);
}

std::optional<job_command> parse_job_command(std::string_view name) {
    for (std::size_t i = 0; i < command_names.size(); ++i)
        if (command_names[i] == name) return static_cast<job_command>(i);
    return std::nullopt;
}

std::string_view to_string(job_command c) {
    return command_names[static_cast<std::size_t>(c)];
}

bool is_plausible_job_id(std::string_view id) {
    if (id.empty() || id.size() > 64) return false;
    for (unsigned char c : id)
        if (!std::isalnum(c) && c != '-' && c != '_') return false;
    return true;
}

void submit_job(api_context& ctx, const json& body, submit_options options, api_handler handler) {
    const std::string request_id = options.request_id;
    auto finish_now = [&](api_outcome out) {
        net::post(ctx.executor, net::append(std::move(handler), std::move(out)));
    };
    if (!ctx.jobs) return finish_now(failed(no_jobs_problem(), request_id));
    auto parsed = parse_job_submission(body);
    if (!parsed) return finish_now(failed(parsed.error(), request_id));
    if (options.idempotency_key && options.dry_run)
        return finish_now(
            failed(invalid_field("Idempotency-Key", "a dry run stores nothing: leave out Idempotency-Key"),
                   request_id));

    jobs::submit_request r;
    r.controller = std::move(parsed->controller);
    r.type = parsed->type;
    r.spec = std::move(parsed->spec);
    r.idempotency_key = std::move(options.idempotency_key);
    r.lease_id = std::move(options.lease_id);
    r.principal = std::move(options.principal);
    r.request_id = request_id;
    r.dry_run = options.dry_run;
    const bool dry_run = options.dry_run;

    // The manager completes on its executor; from there the handler goes to its own.
    auto shared = std::make_shared<api_handler>(std::move(handler));
    auto ex = ctx.executor;
    ctx.jobs->async_submit(
        std::move(r),
        net::bind_executor(ex, [shared, ex, request_id, dry_run](operation_result<jobs::submit_result> res) {
            api_outcome out;
            if (!res) {
                out = failed(res.error(), request_id);
            } else if (dry_run) {
                out.body = jobs::dry_run_json(res->job.controller, res->job.type, res->plan);
            } else {
                out.body = jobs::to_json(res->job, jobs::job_clock::now());
                out.replayed = res->replayed;
                out.status = res->replayed ? 200 : 201;
                out.location = "/api/v1/jobs/" + res->job.id;
            }
            net::dispatch(ex, net::append(std::move(*shared), std::move(out)));
        }));
}

void control_job(api_context& ctx, job_command command, jobs::job_action action, api_handler handler) {
    const std::string request_id = action.request_id;
    if (!ctx.jobs)
        return net::post(ctx.executor,
                         net::append(std::move(handler), failed(no_jobs_problem(), request_id)));
    auto shared = std::make_shared<api_handler>(std::move(handler));
    auto ex = ctx.executor;
    auto done = net::bind_executor(ex, [shared, ex, request_id](operation_result<jobs::job_record> res) {
        api_outcome out;
        if (!res)
            out = failed(res.error(), request_id);
        else
            out.body = jobs::to_json(*res, jobs::job_clock::now());
        net::dispatch(ex, net::append(std::move(*shared), std::move(out)));
    });
    auto& m = *ctx.jobs;
    switch (command) {
        case job_command::cancel:
            return m.async_cancel(std::move(action), std::move(done));
        case job_command::pause:
            return m.async_pause(std::move(action), std::move(done));
        case job_command::resume:
            return m.async_resume(std::move(action), std::move(done));
        case job_command::next:
            return m.async_next(std::move(action), std::move(done));
    }
}

namespace {

// The job manager's handler for one of its history reads: the result made an outcome by `to_body`
// and handed to `handler` on its executor.
template <typename T, typename ToBody>
auto history_reply(api_context& ctx, const std::string& request_id, api_handler handler, ToBody to_body) {
    auto shared = std::make_shared<api_handler>(std::move(handler));
    auto ex = ctx.executor;
    return net::bind_executor(
        ex, [shared, ex, request_id, to_body = std::move(to_body)](operation_result<T> res) mutable {
            api_outcome out;
            if (!res)
                out = failed(res.error(), request_id);
            else
                out.body = to_body(std::move(*res));
            net::dispatch(ex, net::append(std::move(*shared), std::move(out)));
        });
}

void no_jobs(api_context& ctx, const std::string& request_id, api_handler& handler) {
    net::post(ctx.executor, net::append(std::move(handler), failed(no_jobs_problem(), request_id)));
}

}  // namespace

void get_job(api_context& ctx, std::string id, const std::string& request_id, api_handler handler) {
    if (!ctx.jobs) return no_jobs(ctx, request_id, handler);
    ctx.jobs->async_get(
        std::move(id),
        history_reply<jobs::job_record>(ctx, request_id, std::move(handler), [](const jobs::job_record& job) {
            return jobs::to_json(job, jobs::job_clock::now());
        }));
}

void list_jobs(api_context& ctx, jobs::job_filter filter, const std::string& request_id,
               api_handler handler) {
    if (!ctx.jobs) return no_jobs(ctx, request_id, handler);
    ctx.jobs->async_list(
        std::move(filter),
        history_reply<jobs::job_page>(ctx, request_id, std::move(handler), [](jobs::job_page page) {
            const auto now = jobs::job_clock::now();
            json list = json::array();
            for (const auto& j : page.jobs)
                list.push_back(jobs::to_json(j, now));
            return json{{"jobs", std::move(list)}, {"next", page.next ? json(*page.next) : json(nullptr)}};
        }));
}

void job_events(api_context& ctx, std::string id, std::size_t limit, const std::string& request_id,
                api_handler handler) {
    if (!ctx.jobs) return no_jobs(ctx, request_id, handler);
    ctx.jobs->async_events(
        std::move(id), limit,
        history_reply<std::vector<json>>(ctx, request_id, std::move(handler), [](std::vector<json> events) {
            return json{{"events", json(std::move(events))}};
        }));
}

}  // namespace gw::api
