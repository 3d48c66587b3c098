#include "api/static/static_assets.hpp"

#include <algorithm>
#include <optional>

#include "api/common/problem_response.hpp"
#include "api/common/response_headers.hpp"
#include "api/static/dashboard_files.hpp"
#include "devices/ms2000/ascii.hpp"

namespace gw::api {

namespace {

constexpr std::string_view dashboard_prefix = "/dashboard/";

// "/dashboard" and "/dashboard/" name the page itself, which is served at "/".
bool names_the_page_folder(std::string_view path) {
    return path == "/dashboard" || path == dashboard_prefix;
}

// Only this origin; no inline script or style, no plugins, not framed. 'self' covers ws:/wss: to the
// same host in CSP Level 3 browsers. connect-src also allows ws: and wss: anywhere (WebSockets only,
// no fetch to other origins): the fleet view (#/fleet) opens the MQTT broker's WebSocket listener,
// whose host and port the person types in and cannot be known here.
constexpr std::string_view content_security_policy =
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "connect-src 'self' ws: wss:; object-src 'none'; base-uri 'none'; frame-ancestors 'none'; form-action "
    "'self'";

std::string_view content_type_of(std::string_view name) {
    auto ends = [&](std::string_view ext) { return name.ends_with(ext); };
    if (ends(".html")) return "text/html; charset=utf-8";
    if (ends(".js")) return "text/javascript; charset=utf-8";
    if (ends(".css")) return "text/css; charset=utf-8";
    if (ends(".svg")) return "image/svg+xml";
    return "application/octet-stream";
}

const embedded_file* find_file(std::string_view name) {
    auto files = dashboard_files();
    auto it =
        std::find_if(files.begin(), files.end(), [&](const embedded_file& f) { return f.name == name; });
    return it == files.end() ? nullptr : &*it;
}

// The file a path names ("" when it names none).
std::string_view file_name_of(std::string_view path) {
    if (path == "/") return "index.html";
    if (path.starts_with(dashboard_prefix)) return path.substr(dashboard_prefix.size());
    return {};
}

// True when Accept-Encoding accepts gzip: named with a non-zero weight, or not named and "*" accepted
// (an explicit "gzip;q=0" wins over "*", RFC 9110 12.5.3).
bool accepts_gzip(std::string_view header) {
    std::optional<bool> gzip;
    std::optional<bool> any;
    while (!header.empty()) {
        const auto comma = header.find(',');
        auto item = devices::ms2000::trim_blanks(header.substr(0, comma));
        const auto semicolon = item.find(';');
        const auto coding = devices::ms2000::trim_blanks(item.substr(0, semicolon));
        const auto params = devices::ms2000::trim_blanks(
            semicolon == std::string_view::npos ? std::string_view{} : item.substr(semicolon + 1));
        // "q=0", "q=0.0", "q=0.000": refused.
        const bool refused =
            params.starts_with("q=0") && params.substr(3).find_first_not_of(".0") == std::string_view::npos;
        if (beast::iequals(coding, "gzip")) gzip = !refused;
        if (coding == "*") any = !refused;
        if (comma == std::string_view::npos) break;
        header.remove_prefix(comma + 1);
    }
    return gzip.value_or(any.value_or(false));
}

// If-None-Match uses the weak comparison (RFC 9110 13.1.2): W/"x" matches "x"; "*" matches anything.
bool none_match_hits(std::string_view header, std::string_view etag) {
    while (!header.empty()) {
        auto comma = header.find(',');
        auto tag = devices::ms2000::trim_blanks(header.substr(0, comma));
        if (tag == "*") return true;
        if (tag.starts_with("W/")) tag.remove_prefix(2);
        if (tag == etag) return true;
        if (comma == std::string_view::npos) break;
        header.remove_prefix(comma + 1);
    }
    return false;
}

}  // namespace

bool is_static_asset_path(std::string_view path) {
    return path == "/" || path == "/dashboard" || path.starts_with(dashboard_prefix);
}

std::string static_asset_route(std::string_view path) {
    if (path == "/") return "/";
    return names_the_page_folder(path) ? "/dashboard/" : "/dashboard/{file}";
}

string_response static_asset_response(const string_request& req, const std::string& request_id) {
    const auto method = req.method();
    if (method != http::verb::get && method != http::verb::head) {
        auto res = problem_response(
            make_problem(http_error::method_not_allowed,
                         std::string(req.method_string()) + " is not allowed here; use GET, HEAD"),
            req, request_id);
        res.set(http::field::allow, "GET, HEAD");
        return res;
    }
    const auto path = target_path(req.target());
    if (names_the_page_folder(path)) {
        string_response res{http::status::moved_permanently, req.version()};
        set_common_headers(res, request_id, req.keep_alive(), "no-cache");
        res.set(http::field::location, "/");
        res.prepare_payload();
        return res;
    }
    const auto name = file_name_of(path);
    const auto* file = find_file(name);  // an exact name of the table: no path walks
    if (!file)
        return problem_response(make_problem(http_error::not_found, "no dashboard file " + std::string(path)),
                                req, request_id);

    auto encoding_it = req.find(http::field::accept_encoding);
    const bool gzipped =
        !file->gzip.empty() && encoding_it != req.end() && accepts_gzip(encoding_it->value());
    // Each representation has its own strong ETag (RFC 9110 8.8.3).
    const std::string etag = "\"" + std::string(file->sha256.substr(0, 32)) + (gzipped ? "-gz\"" : "\"");
    auto it = req.find(http::field::if_none_match);
    const bool not_modified = it != req.end() && none_match_hits(it->value(), etag);

    string_response res{not_modified ? http::status::not_modified : http::status::ok, req.version()};
    set_common_headers(res, request_id, req.keep_alive(), "no-cache");  // revalidated by ETag
    res.set(http::field::etag, etag);
    res.set("Content-Security-Policy", content_security_policy);
    res.set("X-Content-Type-Options", "nosniff");
    res.set("Referrer-Policy", "no-referrer");
    if (!file->gzip.empty()) res.set(http::field::vary, "Accept-Encoding");
    if (not_modified) return res;  // no body, no Content-Length (RFC 9110 15.4.5)
    res.set(http::field::content_type, content_type_of(file->name));
    const auto body = gzipped ? file->gzip : file->data;
    if (gzipped) res.set(http::field::content_encoding, "gzip");
    if (method == http::verb::head) {
        res.content_length(body.size());  // what GET would send, without the body
        return res;
    }
    res.body() = std::string(body);
    res.prepare_payload();
    return res;
}

}  // namespace gw::api
