#include "api/route_table.hpp"

#include "api/path_segments.hpp"

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

void route_table::dispatch(request_context& c) const {
    const std::string path(target_path(c.req.target()));
    std::vector<std::string> params;
    const auto candidates = find(path, params);
    if (candidates.empty()) {
        c.route = "unmatched";
        return c.fail(make_problem(http_error::not_found, "no route for " + path));
    }
    c.route = candidates.front()->r.pattern;
    const compiled* chosen = nullptr;
    std::string allow;
    for (const auto* candidate : candidates) {
        if (candidate->r.method == c.req.method()) chosen = candidate;
        allow += (allow.empty() ? "" : ", ") + std::string(http::to_string(candidate->r.method));
    }
    if (!chosen) {
        auto res = problem_response(
            make_problem(http_error::method_not_allowed,
                         std::string(c.req.method_string()) + " is not allowed here; use " + allow),
            c.req, c.request_id);
        res.set(http::field::allow, allow);
        return c.reply(std::move(res));
    }
    c.params = std::move(params);
    if (chosen->r.role) {
        problem p;
        auto who = identify(*c.ctx, c.req, p);
        if (!who) return c.fail(std::move(p));
        if (!has_role(*who, *chosen->r.role)) return c.fail(forbidden_problem(*who, *chosen->r.role));
        c.who = std::move(who);
    }
    chosen->r.handler(c);
}

}  // namespace gw::api
