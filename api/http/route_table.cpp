#include "api/http/route_table.hpp"

#include "api/calls/call_audit.hpp"
#include "api/common/path_segments.hpp"
#include "api/http/router.hpp"
#include "gateway/audit/audit_log.hpp"

namespace gw::api {

namespace {

bool is_parameter(std::string_view segment) {
    return segment.size() > 2 && segment.front() == '{' && segment.back() == '}';
}

// The template's segments against the path's; the parameters' values when they match.
bool matches(const std::vector<std::string>& pattern, const std::vector<std::string_view>& path,
             std::vector<std::string>& params) {
    if (pattern.size() != path.size()) return false;
    std::vector<std::string> found;
    for (std::size_t i = 0; i < pattern.size(); ++i) {
        if (is_parameter(pattern[i])) {
            if (path[i].empty()) return false;
            found.emplace_back(path[i]);
        } else if (pattern[i] != path[i]) {
            return false;
        }
    }
    params = std::move(found);
    return true;
}

}  // namespace

route_table::route_table(std::vector<route> routes) {
    routes_.reserve(routes.size());
    for (auto& r : routes) {
        std::vector<std::string> segments;
        for (auto s : path_segments(r.pattern))
            segments.emplace_back(s);
        routes_.push_back({std::move(r), std::move(segments)});
    }
}

std::vector<const route_table::compiled*> route_table::find(std::string_view path,
                                                            std::vector<std::string>& params) const {
    const auto segments = path_segments(path);
    std::vector<const compiled*> out;
    for (const auto& c : routes_) {
        if (!out.empty()) {
            if (c.r.pattern == out.front()->r.pattern) out.push_back(&c);
            continue;
        }
        if (matches(c.segments, segments, params)) out.push_back(&c);
    }
    return out;
}

bool route_table::serves(std::string_view path) const {
    std::vector<std::string> params;
    return !find(path, params).empty();
}

const route* route_table::route_for(http::verb method, std::string_view path) const {
    std::vector<std::string> params;
    for (const auto* candidate : find(path, params))
        if (candidate->r.method == method) return &candidate->r;
    return nullptr;
}

route_table::decision route_table::decide(const api_context& ctx, const http::request_header<>& req,
                                          bool keep_alive, const std::string& request_id) const {
    decision d;
    const std::string path(target_path(req.target()));
    auto refuse = [&](problem p) {
        d.refusal = problem_response(std::move(p), req.version(), keep_alive, req.target(), request_id);
    };
    const auto candidates = find(path, d.params);
    if (candidates.empty()) {
        refuse(make_problem(http_error::not_found, "no route for " + path));
        return d;
    }
    d.label = candidates.front()->r.pattern;
    std::string allow;
    for (const auto* candidate : candidates) {
        if (candidate->r.method == req.method()) d.chosen = &candidate->r;
        allow += (allow.empty() ? "" : ", ") + std::string(http::to_string(candidate->r.method));
    }
    if (!d.chosen) {
        refuse(make_problem(http_error::method_not_allowed,
                            std::string(req.method_string()) + " is not allowed here; use " + allow));
        d.refusal->set(http::field::allow, allow);
        return d;
    }
    if (d.chosen->role) {
        problem p;
        d.who = identify(ctx, req, p);
        if (!d.who)
            refuse(std::move(p));
        else if (!has_role(*d.who, *d.chosen->role))
            refuse(forbidden_problem(*d.who, *d.chosen->role));
    }
    return d;
}

void route_table::audit_refusal(const api_context& ctx, const http::request_header<>& req, const decision& d,
                                const std::string& request_id, const std::string& client_address) {
    const bool changes = req.method() != http::verb::get && req.method() != http::verb::head &&
                         req.method() != http::verb::options;
    if (!ctx.audit || !changes || !d.refusal || !d.who || d.refusal->result() != http::status::forbidden)
        return;
    caller who;
    who.name = d.who->name;
    who.role = d.who->role;
    who.request_id = request_id;
    who.address = client_address;
    auto e = route_audit_entry(who, std::string(req.method_string()) + " " + d.label, "",
                               static_cast<unsigned>(http::status::forbidden));
    e.outcome = "forbidden";
    // The controller a /api/v1/controllers/{id}/... route names.
    if (d.label.starts_with("/api/v1/controllers/{id}") && !d.params.empty()) e.controller = d.params.front();
    ctx.audit->record(std::move(e));
}

void route_table::dispatch(request_context& c) const {
    auto d = decide(*c.ctx, c.req, c.req.keep_alive(), c.request_id);
    if (d.refusal) audit_refusal(*c.ctx, c.req, d, c.request_id, c.client_address);
    c.route = std::move(d.label);
    if (d.refusal) return c.reply(std::move(*d.refusal));
    c.params = std::move(d.params);
    c.who = std::move(d.who);
    d.chosen->handler(c);
}

}  // namespace gw::api
