#include "gateway/config/config.hpp"

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <limits>
#include <ostream>
#include <set>
#include <sstream>
#include <utility>

#include <boost/asio/ip/address.hpp>
#include <nlohmann/json.hpp>

#include "gateway/common/json_keys.hpp"
#include "gateway/common/json_value.hpp"
#include "gateway/config/config_files_check.hpp"
#include "gateway/config/secret_file_path.hpp"
#include "gateway/config/tokens_file.hpp"

namespace gw {

namespace {

using json = nlohmann::json;

// Thrown inside this file only; parse_config turns it into its error string.
struct config_error {
    std::string message;
};

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    throw config_error{path + ": " + what};
}

std::string join_path(const std::string& parent, std::string_view key) {
    return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

// One JSON object: refuses unknown keys at once, then hands out the known ones.
class object_reader {
  public:
    object_reader(const json& j, std::string path, std::initializer_list<std::string_view> keys)
        : j_(j), path_(std::move(path)) {
        if (!j.is_object()) fail(path_.empty() ? "(top level)" : path_, "must be an object");
        if (const auto unknown = first_unknown_key(j, keys)) fail(join_path(path_, *unknown), "unknown key");
    }

    const json* get(std::string_view key) const {
        auto it = j_.find(key);
        return it == j_.end() ? nullptr : &*it;
    }
    std::string path(std::string_view key) const { return join_path(path_, key); }

  private:
    const json& j_;
    std::string path_;
};

std::uint64_t read_uint(const json& j, const std::string& path, std::uint64_t min, std::uint64_t max) {
    auto v = read_unsigned(j, min, max);  // negative, fractional, not a number or outside: one message
    if (!v) fail(path, "must be an integer from " + std::to_string(min) + " to " + std::to_string(max));
    return *v.value;
}

double read_double(const json& j, const std::string& path, double min, double max) {
    auto v = read_number(j, min, max);
    if (!v) {
        std::ostringstream range;
        range << "must be a number from " << min << " to " << max;
        fail(path, range.str());
    }
    return *v.value;
}

std::string read_string(const json& j, const std::string& path, bool allow_empty = false) {
    auto v = read_text(j, {.allow_empty = allow_empty, .allow_control = false});
    if (v) return std::move(*v.value);
    switch (v.fault) {
        case json_fault::empty:
            fail(path, "must not be empty");
        case json_fault::control_character:
            fail(path, "must not contain control characters");
        default:
            fail(path, "must be a string");
    }
}

// An array of strings, each checked by `valid` (which says what is wrong, or nothing).
std::vector<std::string> read_string_list(const json& j, const std::string& path,
                                          const std::function<std::string(std::string_view)>& valid) {
    if (!j.is_array()) fail(path, "must be an array of strings");
    std::vector<std::string> out;
    for (std::size_t i = 0; i < j.size(); ++i) {
        const auto item_path = path + "[" + std::to_string(i) + "]";
        auto s = read_string(j[i], item_path);
        if (auto why = valid(s); !why.empty()) fail(item_path, why);
        out.push_back(std::move(s));
    }
    return out;
}

// "http(s)://host[:port]", as a browser sends it in Origin: no path, no trailing slash.
std::vector<std::string> read_allowed_origins(const json& j, const std::string& path) {
    return read_string_list(j, path, [](std::string_view o) -> std::string {
        const bool scheme = o.starts_with("http://") || o.starts_with("https://");
        const auto rest = o.substr(o.find("//") == std::string_view::npos ? 0 : o.find("//") + 2);
        if (!scheme || rest.empty() || rest.find('/') != std::string_view::npos)
            return "must be an origin such as \"https://lab.example:8443\" (scheme, host, port; no path)";
        return {};
    });
}

// Host names without a port ("gateway.lab.example").
std::vector<std::string> read_allowed_hosts(const json& j, const std::string& path) {
    return read_string_list(j, path, [](std::string_view h) -> std::string {
        if (h.find_first_of(":/ []") != std::string_view::npos)
            return "must be a host name without a port, such as \"gateway.lab.example\"";
        return {};
    });
}

bool read_bool(const json& j, const std::string& path) {
    if (!j.is_boolean()) fail(path, "must be true or false");
    return j.get<bool>();
}

template <typename E>
E read_enum(const json& j, const std::string& path,
            std::initializer_list<std::pair<std::string_view, E>> table) {
    std::string names;
    for (const auto& [name, value] : table)
        names += (names.empty() ? "" : ", ") + std::string(name);
    if (!j.is_string()) fail(path, "must be one of " + names);
    const auto s = j.get<std::string>();
    for (const auto& [name, value] : table)
        if (name == s) return value;
    fail(path, "must be one of " + names);
}

const std::initializer_list<std::pair<std::string_view, role>> role_table = {
    {"viewer", role::viewer}, {"operator", role::operator_}, {"admin", role::admin}};

const std::initializer_list<std::pair<std::string_view, log_level>> level_table = {
    {"trace", log_level::trace}, {"debug", log_level::debug}, {"info", log_level::info},
    {"warn", log_level::warn},   {"error", log_level::error}, {"critical", log_level::critical},
    {"off", log_level::off}};

bool valid_logger_name(std::string_view name) {
    if (name == "gateway" || name == "api" || name == "jobs" || name == "mqtt" || name == "ms2000")
        return true;
    constexpr std::string_view prefix = "ms2000.";
    return name.starts_with(prefix) && is_valid_controller_id(name.substr(prefix.size()));
}

// storage.retention: {"max_age_days", "max_ended_jobs", "max_audit_entries", "sweep_interval_s"}.
void read_retention(const json& j, history_retention& out) {
    object_reader r(j, "storage.retention",
                    {"max_age_days", "max_ended_jobs", "max_audit_entries", "sweep_interval_s"});
    if (auto* v = r.get("max_age_days"))
        out.max_age = std::chrono::hours(24 * read_uint(*v, r.path("max_age_days"), 1, 36500));
    if (auto* v = r.get("max_ended_jobs"))
        out.max_ended_jobs = read_uint(*v, r.path("max_ended_jobs"), 1, 100'000'000);
    if (auto* v = r.get("max_audit_entries"))
        out.max_audit_entries = read_uint(*v, r.path("max_audit_entries"), 1, 1'000'000'000);
    if (auto* v = r.get("sweep_interval_s"))
        out.sweep_interval = std::chrono::seconds(read_uint(*v, r.path("sweep_interval_s"), 1, 86400));
}

void read_http(const json& j, http_config& out) {
    object_reader r(j, "http",
                    {"listen_address", "port", "limits", "allowed_origins", "allowed_hosts", "tls",
                     "trusted_proxies", "public_url"});
    if (auto* v = r.get("public_url")) {
        out.public_url = read_string(*v, r.path("public_url"));
        const bool web = out.public_url.starts_with("http://") || out.public_url.starts_with("https://");
        const bool plain = std::all_of(out.public_url.begin(), out.public_url.end(),
                                       [](unsigned char ch) { return ch > 0x20 && ch < 0x7f; });
        if (!web || !plain || out.public_url.size() > 512)
            fail(r.path("public_url"),
                 "must be an http:// or https:// URL of at most 512 printable characters without spaces");
    }
    if (auto* v = r.get("trusted_proxies")) {
        const auto entries = read_string_list(*v, r.path("trusted_proxies"), [](std::string_view e) {
            auto one = trusted_proxies::parse({std::string(e)});
            return one ? std::string() : one.error();
        });
        out.proxies = *trusted_proxies::parse(entries);  // each entry is valid by now
    }
    if (auto* v = r.get("tls")) {
        object_reader t(*v, "http.tls", {"cert_file", "key_file"});
        auto* cert = t.get("cert_file");
        auto* key = t.get("key_file");
        if (!cert || !key) fail("http.tls", "needs both cert_file and key_file (PEM files)");
        out.tls.cert_file = read_string(*cert, t.path("cert_file"));
        out.tls.key_file = read_string(*key, t.path("key_file"));
    }
    if (auto* v = r.get("allowed_origins"))
        out.allowed_origins = read_allowed_origins(*v, r.path("allowed_origins"));
    if (auto* v = r.get("allowed_hosts")) out.allowed_hosts = read_allowed_hosts(*v, r.path("allowed_hosts"));
    if (auto* v = r.get("listen_address")) {
        out.listen_address = read_string(*v, r.path("listen_address"));
        boost::system::error_code ec;
        boost::asio::ip::make_address(out.listen_address, ec);
        if (ec) fail(r.path("listen_address"), "must be an IPv4 or IPv6 address");
    }
    if (auto* v = r.get("port"))
        out.port = static_cast<std::uint16_t>(read_uint(*v, r.path("port"), 0, 65535));
    if (auto* lj = r.get("limits")) {
        object_reader l(*lj, "http.limits",
                        {"max_header_bytes", "max_body_bytes", "header_timeout_ms", "read_timeout_ms",
                         "max_websocket_message_bytes", "max_connections", "max_connections_per_address",
                         "max_buffered_body_mb"});
        auto& lim = out.limits;
        if (auto* v = l.get("max_header_bytes"))
            lim.max_header_bytes =
                read_uint(*v, l.path("max_header_bytes"), 1024, std::uint64_t{1024} * 1024);
        if (auto* v = l.get("max_body_bytes"))
            lim.max_body_bytes = read_uint(*v, l.path("max_body_bytes"), 1, std::uint64_t{64} * 1024 * 1024);
        if (auto* v = l.get("header_timeout_ms"))
            lim.header_timeout =
                std::chrono::milliseconds(read_uint(*v, l.path("header_timeout_ms"), 100, 600000));
        if (auto* v = l.get("read_timeout_ms"))
            lim.read_timeout =
                std::chrono::milliseconds(read_uint(*v, l.path("read_timeout_ms"), 100, 600000));
        if (auto* v = l.get("max_websocket_message_bytes"))
            lim.max_websocket_message_bytes =
                read_uint(*v, l.path("max_websocket_message_bytes"), 128, std::uint64_t{16} * 1024 * 1024);
        if (auto* v = l.get("max_connections"))
            lim.max_connections = read_uint(*v, l.path("max_connections"), 1, 10000);
        if (auto* v = l.get("max_connections_per_address"))
            lim.max_connections_per_address = read_uint(*v, l.path("max_connections_per_address"), 1, 10000);
        if (auto* v = l.get("max_buffered_body_mb"))
            lim.max_buffered_body_bytes =
                read_uint(*v, l.path("max_buffered_body_mb"), 1, 4096) * std::size_t{1024} * 1024;
        if (lim.max_buffered_body_bytes < lim.max_body_bytes)
            fail(l.path(l.get("max_buffered_body_mb") ? "max_buffered_body_mb" : "max_body_bytes"),
                 "max_buffered_body_mb must hold at least one body of max_body_bytes");
    }
}

// "HOST:PORT" with an IP address ("[::1]:7001" for IPv6). RFC 2217 and a raw TCP port have no
// authentication: a non-loopback address must be meant (allow_network).
void read_host_port(const json& j, const std::string& path, bool allow_network, std::string& host,
                    std::uint16_t& port) {
    const auto text = read_string(j, path);
    const auto colon = text.rfind(':');
    std::string h = colon == std::string::npos ? "" : text.substr(0, colon);
    if (h.size() >= 2 && h.front() == '[' && h.back() == ']') h = h.substr(1, h.size() - 2);
    unsigned number = 0;
    const auto digits =
        colon == std::string::npos ? std::string_view{} : std::string_view(text).substr(colon + 1);
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), number);
    boost::system::error_code bad;
    const auto address = boost::asio::ip::make_address(h, bad);
    if (bad || ec != std::errc{} || end != digits.data() + digits.size() || number == 0 || number > 65535)
        fail(path, "must be \"HOST:PORT\" with an IP address, e.g. \"127.0.0.1:7001\"");
    if (!address.is_loopback() && !allow_network)
        fail(path,
             "is not a loopback address: anyone who reaches it controls the stage with share.role and "
             "no token; set \"allow_network\": true to mean it");
    host = h;
    port = static_cast<std::uint16_t>(number);
}

// controllers[].share: {"pty": PATH, "pty_mode": "0660", "pty_group": "dialout", "tcp": "HOST:PORT",
// "report_pty": PATH, "report_tcp": "HOST:PORT", "role": "operator", "lease": false, "max_clients": 4,
// "allow_network": false}.
devices::share::share_settings read_share(const json& j, const std::string& path,
                                          const devices::controller_settings& controller) {
    object_reader r(j, path,
                    {"pty", "pty_mode", "pty_group", "tcp", "report_pty", "report_tcp", "role", "lease",
                     "max_clients", "allow_network"});
    devices::share::share_settings s;
    s.controller = controller.id;
    s.line_baud = controller.baud;
    if (auto* v = r.get("pty")) {
        s.pty = read_string(*v, r.path("pty"));
        if (!s.pty.starts_with('/')) fail(r.path("pty"), "must be an absolute path");
    }
    if (auto* v = r.get("pty_mode")) {
        const auto text = read_string(*v, r.path("pty_mode"));
        unsigned mode = 0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), mode, 8);
        if (ec != std::errc{} || end != text.data() + text.size() || text.size() < 3 || mode > 0666)
            fail(r.path("pty_mode"), "must be an octal mode such as \"0660\" (no execute bits)");
        s.pty_mode = static_cast<mode_t>(mode);
    }
    if (auto* v = r.get("pty_group")) s.pty_group = read_string(*v, r.path("pty_group"));
    bool allow_network = false;
    if (auto* v = r.get("allow_network")) allow_network = read_bool(*v, r.path("allow_network"));
    if (auto* v = r.get("tcp")) read_host_port(*v, r.path("tcp"), allow_network, s.tcp_host, s.tcp_port);
    if (auto* v = r.get("report_pty")) {
        s.report_pty = read_string(*v, r.path("report_pty"));
        if (!s.report_pty.starts_with('/')) fail(r.path("report_pty"), "must be an absolute path");
    }
    if (auto* v = r.get("report_tcp"))
        read_host_port(*v, r.path("report_tcp"), allow_network, s.report_tcp_host, s.report_tcp_port);
    if (s.shares_reports() && controller.report_port.empty())
        fail(r.path(s.report_pty.empty() ? "report_tcp" : "report_pty"),
             "needs the controller's report_port");
    if (auto* v = r.get("role"))
        s.role = read_enum<devices::share::share_role>(*v, r.path("role"),
                                                       {{"viewer", devices::share::share_role::viewer},
                                                        {"operator", devices::share::share_role::operator_},
                                                        {"admin", devices::share::share_role::admin}});
    if (auto* v = r.get("lease")) s.lease = read_bool(*v, r.path("lease"));
    if (auto* v = r.get("max_clients")) s.max_clients = read_uint(*v, r.path("max_clients"), 1, 64);
    if (!s.enabled()) fail(path, "needs \"pty\", \"tcp\", \"report_pty\" or \"report_tcp\"");
    return s;
}

devices::controller_settings read_controller(const json& j, const std::string& path,
                                             std::vector<devices::share::share_settings>& shares) {
    object_reader r(j, path,
                    {"id", "port", "baud", "report_port", "poll_ms", "idle_poll_ms", "error_log_ms",
                     "command_timeout_ms", "share"});
    devices::controller_settings s;
    auto* id = r.get("id");
    if (!id) fail(r.path("id"), "required");
    s.id = read_string(*id, r.path("id"));
    if (!is_valid_controller_id(s.id))
        fail(r.path("id"), "must be 1-64 characters of letters, digits, '-' or '_'");
    auto* port = r.get("port");
    if (!port) fail(r.path("port"), "required");
    s.port = read_string(*port, r.path("port"));
    if (auto* v = r.get("baud")) {
        const bool integral = v->is_number_unsigned();
        const auto baud = integral ? v->get<std::uint64_t>() : 0;
        if (std::find(std::begin(supported_bauds), std::end(supported_bauds), baud) ==
            std::end(supported_bauds))
            fail(r.path("baud"), "must be one of 9600, 19200, 28800, 38400, 57600, 115200");
        s.baud = static_cast<unsigned>(baud);
    }
    if (auto* v = r.get("report_port")) s.report_port = read_string(*v, r.path("report_port"), true);
    if (auto* v = r.get("poll_ms"))
        s.poll_interval = std::chrono::milliseconds(read_uint(*v, r.path("poll_ms"), 0, 60000));
    if (auto* v = r.get("idle_poll_ms"))
        s.idle_poll_interval = std::chrono::milliseconds(read_uint(*v, r.path("idle_poll_ms"), 0, 60000));
    if (auto* v = r.get("error_log_ms"))
        s.error_log_interval = std::chrono::milliseconds(read_uint(*v, r.path("error_log_ms"), 0, 3600000));
    if (auto* v = r.get("command_timeout_ms"))
        s.command_timeout = std::chrono::milliseconds(read_uint(*v, r.path("command_timeout_ms"), 10, 60000));
    if (auto* v = r.get("share")) shares.push_back(read_share(*v, r.path("share"), s));
    return s;
}

void read_simulate(const json& j, simulate_config& out) {
    object_reader r(j, "simulate", {"count", "time_scale", "directory", "share"});
    if (auto* v = r.get("share")) out.share = read_bool(*v, r.path("share"));
    if (auto* v = r.get("count")) out.count = read_uint(*v, r.path("count"), 0, max_simulated_controllers);
    if (auto* v = r.get("time_scale")) out.time_scale = read_double(*v, r.path("time_scale"), 0.01, 1000);
    if (auto* v = r.get("directory")) out.directory = read_string(*v, r.path("directory"));
}

// A list of token entries ({"name", "role", "token" or "token_sha256"}), from auth.tokens or from
// the tokens file; `path` names the list in error messages. Duplicates among all of `out` refused.
void read_tokens(const json& tokens, const std::string& path, std::vector<auth_token>& out) {
    if (!tokens.is_array()) fail(path, "must be an array");
    for (std::size_t i = 0; i < tokens.size(); ++i) {
        object_reader t(tokens[i], path + "[" + std::to_string(i) + "]",
                        {"name", "token", "token_sha256", "role"});
        auth_token tok;
        auto* name = t.get("name");
        if (!name) fail(t.path("name"), "required");
        tok.name = read_string(*name, t.path("name"));
        auto* secret = t.get("token");
        auto* hashed = t.get("token_sha256");
        if (!secret && !hashed) fail(t.path("token_sha256"), "required (or \"token\")");
        if (secret && hashed) fail(t.path("token"), "give \"token\" or \"token_sha256\", not both");
        if (secret) {
            const auto token = read_string(*secret, t.path("token"));
            if (std::any_of(token.begin(), token.end(),
                            [](unsigned char c) { return c <= 0x20 || c >= 0x7f; }))
                fail(t.path("token"), "must be printable ASCII without spaces");
            if (token.size() > 1024) fail(t.path("token"), "must be at most 1024 characters");
            if (auto why = weak_token_reason(token); !why.empty()) fail(t.path("token"), why);
            tok.digest = hash_token(token);
        } else {
            auto digest = parse_token_digest(read_string(*hashed, t.path("token_sha256")));
            if (!digest)
                fail(t.path("token_sha256"), "must be 64 hexadecimal digits (asi-gateway token new)");
            tok.digest = *digest;
        }
        if (auto* v = t.get("role")) tok.role = read_enum<role>(*v, t.path("role"), role_table);
        for (const auto& other : out) {
            if (other.name == tok.name) fail(t.path("name"), "duplicate name \"" + tok.name + "\"");
            if (other.digest == tok.digest)
                fail(t.path(secret ? "token" : "token_sha256"), "the same token is given twice");
        }
        out.push_back(std::move(tok));
    }
}

void read_auth(const json& j, auth_config& out) {
    object_reader r(j, "auth", {"tokens", "tokens_file", "halt_role"});
    if (auto* v = r.get("halt_role")) out.halt_role = read_enum<role>(*v, r.path("halt_role"), role_table);
    if (auto* v = r.get("tokens_file")) {
        out.tokens_file = read_string(*v, r.path("tokens_file"));
        if (out.tokens_file.empty()) fail(r.path("tokens_file"), "must not be empty");
    }
    if (auto* tokens = r.get("tokens")) read_tokens(*tokens, "auth.tokens", out.tokens);
}

void read_logging(const json& j, logging_config& out) {
    object_reader r(j, "logging", {"level", "format", "levels"});
    if (auto* v = r.get("level")) out.level = read_enum<log_level>(*v, r.path("level"), level_table);
    if (auto* v = r.get("format"))
        out.format = read_enum<log_format>(*v, r.path("format"),
                                           {{"text", log_format::text}, {"json", log_format::json}});
    if (auto* levels = r.get("levels")) {
        if (!levels->is_object()) fail("logging.levels", "must be an object");
        for (const auto& item : levels->items()) {
            const auto path = "logging.levels." + item.key();
            if (!valid_logger_name(item.key()))
                fail(path, "unknown logger (gateway, api, jobs, mqtt, ms2000 or ms2000.<id>)");
            out.levels[item.key()] = read_enum<log_level>(item.value(), path, level_table);
        }
    }
}

int read_qos(const json& j, const std::string& path) {
    return static_cast<int>(read_uint(j, path, 0, 2));
}

// "mqtt://host[:port]" and the like: a known scheme, a host, an optional port.
// mqtt.commands.signing_keys: [{"name", "role", "key": "<64..128 hex digits>"}].
void read_signing_keys(const json& keys, const std::string& path, std::vector<mqtt_signing_key>& out) {
    if (!keys.is_array()) fail(path, "must be an array");
    for (std::size_t i = 0; i < keys.size(); ++i) {
        object_reader k(keys[i], path + "[" + std::to_string(i) + "]", {"name", "role", "key"});
        mqtt_signing_key entry;
        auto* name = k.get("name");
        if (!name) fail(k.path("name"), "required");
        entry.name = read_string(*name, k.path("name"));
        if (entry.name.empty() || entry.name.size() > 64) fail(k.path("name"), "must be 1..64 characters");
        if (auto* v = k.get("role")) entry.role = read_enum<role>(*v, k.path("role"), role_table);
        auto* key = k.get("key");
        if (!key) fail(k.path("key"), "required (openssl rand -hex 32)");
        const auto hex = read_string(*key, k.path("key"));
        const bool is_hex = std::all_of(hex.begin(), hex.end(), [](char c) {
            return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
        });
        if (!is_hex || hex.size() % 2 != 0 || hex.size() < 64 || hex.size() > 128)
            fail(k.path("key"),
                 "must be 64..128 hexadecimal digits, 256 bits or more (openssl rand -hex 32)");
        if (std::set<char>(hex.begin(), hex.end()).size() < 8)
            fail(k.path("key"), "is too easy to guess (fewer than 8 different digits): openssl rand -hex 32");
        for (std::size_t at = 0; at < hex.size(); at += 2)
            entry.key.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(at, 2), nullptr, 16)));
        for (const auto& other : out)
            if (other.name == entry.name) fail(k.path("name"), "duplicate name \"" + entry.name + "\"");
        out.push_back(std::move(entry));
    }
}

void check_broker_uri(const std::string& uri, const std::string& path) {
    const auto sep = uri.find("://");
    const auto scheme = sep == std::string::npos ? std::string() : uri.substr(0, sep);
    if (scheme != "mqtt" && scheme != "tcp" && scheme != "mqtts" && scheme != "ssl")
        fail(path, "must start with mqtt://, tcp://, mqtts:// or ssl://");
    auto rest = std::string_view(uri).substr(sep + 3);
    if (rest.empty() || rest.find_first_of("/ ?#@") != std::string_view::npos)
        fail(path, "must be <scheme>://host[:port]");
    const auto colon = rest.rfind(':');
    if (colon != std::string_view::npos && rest.back() != ']') {
        const auto port = rest.substr(colon + 1);
        if (colon == 0 || port.empty() || port.size() > 5 ||
            !std::all_of(port.begin(), port.end(), [](char c) { return c >= '0' && c <= '9'; }) ||
            std::stoul(std::string(port)) == 0 || std::stoul(std::string(port)) > 65535)
            fail(path, "the port must be 1..65535");
    }
}

void read_mqtt(const json& j, mqtt_config& out) {
    object_reader r(j, "mqtt",
                    {"enabled", "brokers", "client_id", "username", "password", "tls", "keepalive_s",
                     "topic_prefix", "gateway_id", "protocol", "qos", "telemetry", "reconnect", "jobs",
                     "commands", "tcp_nodelay", "session_expiry_s"});
    if (auto* v = r.get("enabled")) out.enabled = read_bool(*v, r.path("enabled"));
    if (auto* v = r.get("tcp_nodelay")) out.tcp_nodelay = read_bool(*v, r.path("tcp_nodelay"));
    if (auto* v = r.get("brokers")) {
        if (!v->is_array() || v->empty() || v->size() > 16)
            fail(r.path("brokers"), "must be an array of 1..16 broker URIs");
        out.brokers.clear();
        for (std::size_t i = 0; i < v->size(); ++i) {
            const auto path = r.path("brokers") + "[" + std::to_string(i) + "]";
            auto uri = read_string((*v)[i], path);
            check_broker_uri(uri, path);
            out.brokers.push_back(std::move(uri));
        }
    }
    if (auto* v = r.get("client_id")) {
        out.client_id = read_string(*v, r.path("client_id"));
        if (out.client_id.size() > 128) fail(r.path("client_id"), "must be at most 128 characters");
    }
    if (auto* v = r.get("username")) out.username = read_string(*v, r.path("username"));
    if (auto* v = r.get("password")) out.password = read_string(*v, r.path("password"));
    if (auto* tj = r.get("tls")) {
        object_reader t(*tj, "mqtt.tls", {"ca_file", "cert_file", "key_file", "verify"});
        if (auto* v = t.get("ca_file")) out.tls.ca_file = read_string(*v, t.path("ca_file"));
        if (auto* v = t.get("cert_file")) out.tls.cert_file = read_string(*v, t.path("cert_file"));
        if (auto* v = t.get("key_file")) out.tls.key_file = read_string(*v, t.path("key_file"));
        if (auto* v = t.get("verify")) out.tls.verify = read_bool(*v, t.path("verify"));
        if (out.tls.cert_file.empty() != out.tls.key_file.empty())
            fail(t.path(out.tls.cert_file.empty() ? "cert_file" : "key_file"),
                 "cert_file and key_file go together");
    }
    if (auto* v = r.get("keepalive_s"))
        out.keepalive = std::chrono::seconds(read_uint(*v, r.path("keepalive_s"), 5, 3600));
    if (auto* v = r.get("session_expiry_s"))
        out.session_expiry = std::chrono::seconds(read_uint(*v, r.path("session_expiry_s"), 0, 604800));
    if (auto* v = r.get("topic_prefix")) {
        out.topic_prefix = read_string(*v, r.path("topic_prefix"));
        if (!is_valid_mqtt_prefix(out.topic_prefix))
            fail(r.path("topic_prefix"),
                 "must be levels of 1-64 characters of letters, digits, '_', '.' or '-' separated by '/'");
    }
    if (auto* v = r.get("gateway_id")) {
        out.gateway_id = read_string(*v, r.path("gateway_id"));
        if (!is_valid_mqtt_level(out.gateway_id))
            fail(r.path("gateway_id"), "must be 1-64 characters of letters, digits, '_', '.' or '-'");
    }
    if (auto* v = r.get("protocol"))
        out.protocol = read_enum<mqtt_protocol>(*v, r.path("protocol"),
                                                {{"5", mqtt_protocol::v5}, {"3.1.1", mqtt_protocol::v3_1_1}});
    if (auto* qj = r.get("qos")) {
        object_reader q(*qj, "mqtt.qos", {"status", "state", "telemetry", "jobs", "responses"});
        if (auto* v = q.get("status")) out.qos.status = read_qos(*v, q.path("status"));
        if (auto* v = q.get("state")) out.qos.state = read_qos(*v, q.path("state"));
        if (auto* v = q.get("telemetry")) out.qos.telemetry = read_qos(*v, q.path("telemetry"));
        if (auto* v = q.get("jobs")) out.qos.jobs = read_qos(*v, q.path("jobs"));
        if (auto* v = q.get("responses")) out.qos.responses = read_qos(*v, q.path("responses"));
    }
    if (auto* tj = r.get("telemetry")) {
        object_reader t(*tj, "mqtt.telemetry", {"position_max_hz", "reports_batch_ms"});
        if (auto* v = t.get("position_max_hz"))
            out.position_max_hz = read_double(*v, t.path("position_max_hz"), 0, 1000);
        if (auto* v = t.get("reports_batch_ms"))
            out.reports_batch = std::chrono::milliseconds(read_uint(*v, t.path("reports_batch_ms"), 0, 1000));
    }
    if (auto* rj = r.get("reconnect")) {
        object_reader t(*rj, "mqtt.reconnect", {"min_ms", "max_ms"});
        if (auto* v = t.get("min_ms"))
            out.reconnect_min = std::chrono::milliseconds(read_uint(*v, t.path("min_ms"), 10, 60000));
        if (auto* v = t.get("max_ms"))
            out.reconnect_max = std::chrono::milliseconds(read_uint(*v, t.path("max_ms"), 10, 600000));
        if (out.reconnect_max < out.reconnect_min) fail(t.path("max_ms"), "must be at least min_ms");
    }
    if (auto* jj = r.get("jobs")) {
        object_reader t(*jj, "mqtt.jobs", {"queue_limit", "retain_finished_s"});
        if (auto* v = t.get("queue_limit"))
            out.job_queue_limit = read_uint(*v, t.path("queue_limit"), 1, 100000);
        if (auto* v = t.get("retain_finished_s"))
            out.retain_finished_jobs =
                std::chrono::seconds(read_uint(*v, t.path("retain_finished_s"), 0, 604800));
    }
    if (auto* cj = r.get("commands")) {
        object_reader t(*cj, "mqtt.commands",
                        {"enabled", "max_payload_bytes", "signing_keys", "signature_window_s",
                         "accept_bearer_tokens", "max_age_s", "redelivery_window_s"});
        if (auto* v = t.get("enabled")) out.commands_enabled = read_bool(*v, t.path("enabled"));
        if (auto* v = t.get("max_payload_bytes"))
            out.command_max_payload_bytes =
                read_uint(*v, t.path("max_payload_bytes"), 1024, std::uint64_t{64} * 1024 * 1024);
        if (auto* v = t.get("signing_keys"))
            read_signing_keys(*v, t.path("signing_keys"), out.command_signing_keys);
        if (auto* v = t.get("signature_window_s"))
            out.command_signature_window =
                std::chrono::seconds(read_uint(*v, t.path("signature_window_s"), 1, 600));
        if (auto* v = t.get("accept_bearer_tokens"))
            out.accept_bearer_tokens = read_bool(*v, t.path("accept_bearer_tokens"));
        if (auto* v = t.get("max_age_s"))
            out.command_max_age = std::chrono::seconds(read_uint(*v, t.path("max_age_s"), 1, 600));
        if (auto* v = t.get("redelivery_window_s"))
            out.command_redelivery_window =
                std::chrono::seconds(read_uint(*v, t.path("redelivery_window_s"), 1, 86400));
    }
}

void read_events(const json& j, events_config& out) {
    object_reader r(j, "events", {"ended_job_topic_ttl_s", "replay_memory_mb"});
    if (auto* v = r.get("ended_job_topic_ttl_s"))
        out.ended_job_topic_ttl = std::chrono::seconds(
            read_uint(*v, r.path("ended_job_topic_ttl_s"), 0, max_ended_job_topic_ttl_s));
    if (auto* v = r.get("replay_memory_mb"))
        out.replay_memory_mb = read_uint(*v, r.path("replay_memory_mb"), 1, 4096);
}

// mqtt.jobs.retain_finished_s given in the file.
bool retain_finished_given(const json& j) {
    const auto mqtt = j.find("mqtt");
    if (mqtt == j.end() || !mqtt->is_object()) return false;
    const auto jobs = mqtt->find("jobs");
    return jobs != mqtt->end() && jobs->is_object() && jobs->contains("retain_finished_s");
}

gateway_config read_config(const json& j) {
    gateway_config c;
    object_reader r(j, "",
                    {"http", "controllers", "simulate", "storage", "jobs", "gcode", "auth", "logging",
                     "shutdown", "events", "mqtt"});
    if (auto* v = r.get("http")) read_http(*v, c.http);
    if (auto* v = r.get("controllers")) {
        if (!v->is_array()) fail("controllers", "must be an array");
        for (std::size_t i = 0; i < v->size(); ++i)
            c.controllers.push_back(
                read_controller((*v)[i], "controllers[" + std::to_string(i) + "]", c.shares));
    }
    if (auto* v = r.get("simulate")) read_simulate(*v, c.simulate);
    if (auto* v = r.get("storage")) {
        object_reader s(*v, "storage", {"path", "max_size_mb", "recordings_max_mb", "retention"});
        if (auto* p = s.get("path")) c.storage.path = read_string(*p, s.path("path"));
        if (auto* m = s.get("max_size_mb"))
            c.storage.max_size_mb = read_uint(*m, s.path("max_size_mb"), 1, max_storage_size_mb);
        if (auto* m = s.get("recordings_max_mb"))
            c.storage.recordings_max_mb = read_uint(*m, s.path("recordings_max_mb"), 1, max_storage_size_mb);
        if (auto* k = s.get("retention")) read_retention(*k, c.storage.retention);
    }
    if (auto* v = r.get("jobs")) {
        object_reader s(*v, "jobs", {"restart_queued", "max_queued_per_controller"});
        if (auto* b = s.get("restart_queued"))
            c.jobs.restart_queued = read_bool(*b, s.path("restart_queued"));
        if (auto* m = s.get("max_queued_per_controller"))
            c.jobs.max_queued_per_controller =
                read_uint(*m, s.path("max_queued_per_controller"), 1, max_queued_jobs_per_controller);
    }
    if (auto* v = r.get("gcode")) {
        object_reader s(*v, "gcode", {"max_file_mb"});
        if (auto* m = s.get("max_file_mb"))
            c.gcode.max_file_mb = read_uint(*m, s.path("max_file_mb"), 1, max_gcode_file_mb);
    }
    if (auto* v = r.get("auth")) read_auth(*v, c.auth);
    if (auto* v = r.get("logging")) read_logging(*v, c.logging);
    if (auto* v = r.get("shutdown")) {
        object_reader s(*v, "shutdown", {"halt_on_exit"});
        if (auto* h = s.get("halt_on_exit")) c.shutdown.halt_on_exit = read_bool(*h, s.path("halt_on_exit"));
    }
    if (auto* v = r.get("events")) read_events(*v, c.events);
    if (auto* v = r.get("mqtt")) read_mqtt(*v, c.mqtt);
    // A job's retained MQTT state goes when its hub topic does, unless the file says otherwise.
    if (!retain_finished_given(j)) c.mqtt.retain_finished_jobs = c.events.ended_job_topic_ttl;
    return c;
}

}  // namespace

std::string_view to_string(role r) {
    switch (r) {
        case role::viewer:
            return "viewer";
        case role::operator_:
            return "operator";
        case role::admin:
            return "admin";
    }
    return "viewer";
}

std::string_view to_string(log_level l) {
    for (const auto& [name, value] : level_table)
        if (value == l) return name;
    return "info";
}

gateway_config default_config() {
    gateway_config c;
    c.simulate.count = 4;
    return c;
}

bool is_valid_mqtt_level(std::string_view level) {
    if (level.empty() || level.size() > 64 || level.front() == '$') return false;
    return std::all_of(level.begin(), level.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
               c == '_' || c == '.';
    });
}

bool is_valid_mqtt_prefix(std::string_view prefix) {
    if (prefix.empty() || prefix.size() > 128) return false;
    while (true) {
        const auto slash = prefix.find('/');
        if (!is_valid_mqtt_level(prefix.substr(0, slash))) return false;
        if (slash == std::string_view::npos) return true;
        prefix.remove_prefix(slash + 1);
    }
}

bool is_valid_controller_id(std::string_view id) {
    if (id.empty() || id.size() > 64) return false;
    return std::all_of(id.begin(), id.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
               c == '_';
    });
}

bool is_loopback_address(std::string_view address) {
    boost::system::error_code ec;
    const auto a = boost::asio::ip::make_address(std::string(address), ec);
    return !ec && a.is_loopback();
}

std::string validate_config(const gateway_config& config) {
    std::set<std::string> simulated;
    for (std::size_t i = 0; i < config.simulate.count; ++i)
        simulated.insert("sim" + std::to_string(i + 1));
    std::set<std::string> ids;
    for (std::size_t i = 0; i < config.controllers.size(); ++i) {
        const auto& id = config.controllers[i].id;
        auto where = "controllers[" + std::to_string(i) + "].id: duplicate id \"" + id + "\"";
        if (simulated.contains(id)) return where + " (simulated controllers are named sim1..simN)";
        if (!ids.insert(id).second) return where;
    }
    std::set<std::string> share_places;
    for (const auto& share : config.shares) {
        const auto tcp = share.tcp_host + ":" + std::to_string(share.tcp_port);
        if (!share.pty.empty() && !share_places.insert(share.pty).second)
            return "controllers[].share.pty: " + share.pty + " is given twice";
        if (share.tcp_port != 0 && !share_places.insert(tcp).second)
            return "controllers[].share.tcp: " + tcp + " is given twice";
        const auto report_tcp = share.report_tcp_host + ":" + std::to_string(share.report_tcp_port);
        if (!share.report_pty.empty() && !share_places.insert(share.report_pty).second)
            return "controllers[].share.report_pty: " + share.report_pty + " is given twice";
        if (share.report_tcp_port != 0 && !share_places.insert(report_tcp).second)
            return "controllers[].share.report_tcp: " + report_tcp + " is given twice";
    }
    boost::system::error_code ec;
    boost::asio::ip::make_address(config.http.listen_address, ec);
    if (ec)  // the file's value is checked when read; this catches --listen
        return "http.listen_address (--listen): \"" + config.http.listen_address +
               "\" is not an IPv4 or IPv6 address";
    if (config.auth.tokens.empty() && !is_loopback_address(config.http.listen_address))
        return "http.listen_address (--listen): " + config.http.listen_address +
               " is not a loopback address, which needs auth.tokens (no tokens: loopback only)";
    // Every MQTT command proves its sender: without a way to, anyone on the broker would be admin.
    const auto& mqtt = config.mqtt;
    if (mqtt.enabled && mqtt.commands_enabled && mqtt.command_signing_keys.empty() &&
        !(mqtt.accept_bearer_tokens && !config.auth.tokens.empty()))
        return "mqtt.commands.enabled: needs mqtt.commands.signing_keys (signed commands), or "
               "accept_bearer_tokens with auth.tokens";
    // A token in a payload is readable by whoever reads the topic; on a plain connection, by the wire too.
    if (mqtt.accept_bearer_tokens)
        for (const auto& broker : mqtt.brokers)
            if (!broker.starts_with("mqtts://") && !broker.starts_with("ssl://"))
                return "mqtt.commands.accept_bearer_tokens: bearer tokens are never taken over a plain "
                       "connection (" +
                       broker + "): use mqtts:// brokers, or signed commands (mqtt.commands.signing_keys)";
    return {};
}

namespace {

std::optional<std::string> credentials_directory() {
    const char* credentials = std::getenv("CREDENTIALS_DIRECTORY");
    return credentials ? std::optional<std::string>(credentials) : std::nullopt;
}

// Adds auth.tokens_file's entries to auth.tokens; an error message, or empty.
std::string add_file_tokens(auth_config& auth, std::string_view config_directory) {
    auto path = resolve_secret_file_path("auth.tokens_file", auth.tokens_file, config_directory,
                                         credentials_directory());
    if (!path) return path.error().message;
    auto text = read_tokens_file(*path);
    if (!text) return "auth.tokens_file: " + text.error().message;
    const auto j = json::parse(*text, nullptr, false);
    if (j.is_discarded()) return "auth.tokens_file: " + *path + ": not valid JSON";
    try {
        read_tokens(j, "auth.tokens_file (" + *path + ")", auth.tokens);
    } catch (const config_error& e) {
        return e.message;
    }
    return {};
}

}  // namespace

boost::system::result<gateway_config, std::string> parse_config(std::string_view json_text,
                                                                std::string_view config_directory) {
    json j;
    try {
        j = json::parse(json_text);
    } catch (const json::parse_error& e) {
        std::string what = e.what();
        if (auto pos = what.find("] "); pos != std::string::npos) what = what.substr(pos + 2);
        return "not valid JSON: " + what;
    }
    gateway_config c;
    try {
        c = read_config(j);
    } catch (const config_error& e) {
        return e.message;
    }
    if (!c.auth.tokens_file.empty()) {
        if (auto problem = add_file_tokens(c.auth, config_directory); !problem.empty()) return problem;
    }
    if (c.http.tls.enabled()) {
        for (auto [key, file] : {std::pair{"http.tls.cert_file", &c.http.tls.cert_file},
                                 std::pair{"http.tls.key_file", &c.http.tls.key_file}}) {
            auto path = resolve_secret_file_path(key, *file, config_directory, credentials_directory());
            if (!path) return path.error().message;
            *file = std::move(*path);
        }
    }
    if (auto problem = validate_config(c); !problem.empty()) return problem;
    return c;
}

boost::system::result<gateway_config, std::string> load_config_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return path + ": cannot be read";
    std::ostringstream text;
    text << in.rdbuf();
    auto parsed = parse_config(text.str(), std::filesystem::path(path).parent_path().string());
    if (!parsed) return path + ": " + parsed.error();
    return parsed;
}

// Also checks the files the config names (gateway/config/config_files_check.hpp): an unusable TLS file is
// an error (2), a serial port that does not exist now a warning on `err` (still 0).
int check_config_file(const std::string& path, std::ostream& out, std::ostream& err) {
    auto parsed = load_config_file(path);
    if (!parsed) {
        err << parsed.error() << '\n';
        return 2;
    }
    // The files it names: a TLS file that cannot be used is an error, a serial port not there now a
    // warning (it may be plugged in later).
    bool failed = false;
    for (const auto& f : check_config_files(*parsed)) {
        err << path << ": " << (f.error ? "" : "warning: ") << f.message << '\n';
        failed = failed || f.error;
    }
    if (failed) return 2;
    out << "ok\n";
    return 0;
}

}  // namespace gw
