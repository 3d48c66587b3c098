#include "api/http/browser_guard.hpp"

#include <algorithm>
#include <cctype>

#include "api/calls/halt_requests.hpp"
#include "api/http/router.hpp"

namespace gw::api {

namespace {

std::string lower(std::string_view s) {
    std::string out(s);
    std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return std::tolower(c); });
    return out;
}

// "http://host:port" -> "host:port" (lower case), for a comparison with the Host header; "" when the
// origin is not a plain http(s) scheme and authority ("null", a path, another scheme).
std::string authority_of(std::string_view origin) {
    const std::string o = lower(origin);
    for (std::string_view scheme : {"http://", "https://"}) {
        if (!std::string_view(o).starts_with(scheme)) continue;
        auto rest = o.substr(scheme.size());
        if (rest.empty() || rest.find('/') != std::string::npos) return {};
        return rest;
    }
    return {};
}

bool changes_something(http::verb method) {
    return method != http::verb::get && method != http::verb::head && method != http::verb::options;
}

}  // namespace

std::string host_name_of(std::string_view host) {
    if (host.starts_with('[')) {
        const auto end = host.find(']');
        return end == std::string_view::npos ? std::string() : lower(host.substr(1, end - 1));
    }
    return lower(host.substr(0, host.find(':')));
}

bool is_loopback_host(std::string_view host) {
    if (host == "localhost") return true;
    beast::error_code ec;
    const auto address = net::ip::make_address(std::string(host), ec);
    return !ec && address.is_loopback();
}

bool is_json_content_type(std::string_view type) {
    auto media = type.substr(0, type.find(';'));
    while (!media.empty() && media.back() == ' ')
        media.remove_suffix(1);
    return beast::iequals(beast::string_view(media.data(), media.size()), "application/json");
}

problem unsupported_media_type_problem() {
    return make_problem(http_error::unsupported_media_type,
                        "a JSON body needs Content-Type: application/json (curl: --json '{...}')");
}

std::optional<problem> browser_refusal(const http::request_header<>& req, const browser_rules& rules,
                                       bool upgrade) {
    if (req.method() == http::verb::post && is_halt_target(target_path(req.target()))) return std::nullopt;
    const std::string_view host = req[http::field::host];
    if (rules.without_tokens) {
        const auto name = host_name_of(host);
        const bool allowed =
            is_loopback_host(name) || std::any_of(rules.allowed_hosts.begin(), rules.allowed_hosts.end(),
                                                  [&](const std::string& h) { return lower(h) == name; });
        if (!allowed)
            return make_problem(
                http_error::misdirected_request,
                "a gateway without tokens answers only to a loopback Host (or http.allowed_hosts), "
                "not \"" +
                    std::string(name.empty() ? host : std::string_view(name)) + "\"");
    }
    const auto origin = req.find(http::field::origin);
    if (origin == req.end() || !(upgrade || changes_something(req.method()))) return std::nullopt;
    const std::string_view value = origin->value();
    const bool own = !authority_of(value).empty() && authority_of(value) == lower(host);
    const bool allowed = own || std::find_if(rules.allowed_origins.begin(), rules.allowed_origins.end(),
                                             [&](const std::string& o) {
                                                 return lower(o) == lower(value);
                                             }) != rules.allowed_origins.end();
    if (allowed) return std::nullopt;
    return make_problem(http_error::cross_origin,
                        "a page from " + std::string(value.substr(0, 200)) +
                            " may not change anything here: only this gateway's own page and "
                            "http.allowed_origins may (a HALT excepted)");
}

}  // namespace gw::api
