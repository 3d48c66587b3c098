#pragma once
// The gateway's configuration: a JSON file parsed into plain structs. Constructors elsewhere take
// these structs, never JSON. Every field has a safe default; every unknown key and every bad value is
// refused with a message that names its JSON path ("controllers[1].baud: must be one of ...").
//
//   {"http": {"listen_address": "127.0.0.1", "port": 8080, "limits": {...}},
//    "controllers": [{"id": "stage1", "port": "/dev/ttyUSB0", "baud": 115200}],
//    "simulate": {"count": 0}, "storage": {"path": "...", "max_size_mb": 1024},
//    "jobs": {"restart_queued": false, "max_queued_per_controller": 1000}, "gcode": {"max_file_mb": 64},
//    "auth": {"tokens": [...]},
//    "logging": {"level": "info", "format": "text", "levels": {"ms2000": "debug"}},
//    "shutdown": {"halt_on_exit": true}, "events": {"ended_job_topic_ttl_s": 600},
//    "mqtt": {"enabled": false, ...} (see mqtt_config)}

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <boost/system/result.hpp>

#include "devices/serial/controller_settings.hpp"
#include "devices/share/share_settings.hpp"
#include "gateway/common/history_retention.hpp"
#include "gateway/config/token_secret.hpp"
#include "gateway/config/trusted_proxies.hpp"

namespace gw {

struct http_limits {
    std::size_t max_header_bytes = std::size_t{16} * 1024;
    std::size_t max_body_bytes = std::size_t{1024} * 1024;
    // A request's header must be complete this long after the connection opened or after its first
    // byte came (a keep-alive connection may idle up to read_timeout between requests).
    std::chrono::milliseconds header_timeout{5000};
    std::chrono::milliseconds read_timeout{30000};  // the body's (from the end of the header), idling
    std::size_t max_websocket_message_bytes = std::size_t{64} * 1024;
    std::size_t max_connections = 256;
    std::size_t max_connections_per_address = 64;  // and never more than 7/8 of max_connections
    // Request bodies held in memory, all connections together (G-code uploads stream to disk).
    std::size_t max_buffered_body_bytes = std::size_t{64} * 1024 * 1024;
};

// HTTPS and WSS on the HTTP port (api/http/tls_server_context.hpp): PEM files, read at start and again on
// SIGHUP. Both empty: plain HTTP.
struct http_tls_config {
    std::string cert_file;  // the certificate, then its chain
    std::string key_file;   // its private key, unencrypted
    bool enabled() const { return !cert_file.empty(); }
};

struct http_config {
    std::string listen_address = "127.0.0.1";
    std::uint16_t port = 8080;  // 0 = any free port (tests)
    http_limits limits;
    // Browser pages of other origins that may change things ("https://lab.example:8443"), besides
    // the gateway's own; and host names a gateway without tokens answers to, besides loopback.
    std::vector<std::string> allowed_origins;
    std::vector<std::string> allowed_hosts;
    http_tls_config tls;
    // Reverse proxies whose X-Forwarded-For names the client (gateway/config/trusted_proxies.hpp).
    trusted_proxies proxies;
    // Where people reach this gateway's page ("https://lab3.example:8443/"), as the MQTT birth tells
    // the fleet; empty: not told (the listen address is seldom what others can reach).
    std::string public_url;
};

struct simulate_config {
    std::size_t count = 0;  // simulated controllers "sim1".."simN" (presets cycle full, plain, planar, crisp)
    double time_scale = 1.0;  // 1 = real time
    std::string directory;    // where their port symlinks go; empty = /tmp/asi-gateway-<pid>
    bool share = true;        // each gets a shared pty next to its port, <directory>/<id>/share
};

struct storage_config {
    // A directory; the job database is <path>/jobs.sqlite3. Empty: the default of
    // gateway/storage/storage_path.hpp ($STATE_DIRECTORY, $XDG_STATE_HOME/asi-gateway, ~/.local/state/...).
    std::string path;
    std::size_t max_size_mb = 1024;  // bound on jobs.sqlite3; beyond it submissions fail (503)
    // Bound on recordings.sqlite3: a recording that reaches it fails with the reason, new ones are
    // refused (503) until recordings are deleted.
    std::size_t recordings_max_mb = 10240;
    history_retention retention;  // storage.retention: nothing deleted unless set
};

struct jobs_config {
    bool restart_queued = false;  // after a restart, start the jobs that were still queued
    std::size_t max_queued_per_controller = 1000;
};

// The event hub (gateway/events/event_hub.hpp).
struct events_config {
    // An ended job's topic (jobs/<id>) leaves the hub this long after the job ended; its history stays
    // in the job store (GET /api/v1/jobs/{id}/events). Also the default of mqtt.jobs.retain_finished_s.
    std::chrono::seconds ended_job_topic_ttl{600};
    // Memory for every topic's replay buffer together (MiB): clients that resume get what is still
    // in it, the rest as counted gaps (gateway/events/event_hub_settings.hpp max_replay_bytes).
    std::size_t replay_memory_mb = 16;
};

struct gcode_config {
    std::size_t max_file_mb = 64;  // uploaded programs and G-code request bodies (MiB)
};

enum class role : std::uint8_t { viewer, operator_, admin };
std::string_view to_string(role r);

struct auth_token {
    std::string name;
    token_digest digest{};  // SHA-256 of the token (gateway/config/token_secret.hpp): never the token
    gw::role role = role::viewer;
};

struct auth_config {
    std::vector<auth_token> tokens;  // none: the service may only listen on loopback
    // More tokens, in a file of their own (gateway/config/tokens_file.hpp); read by parse_config.
    std::string tokens_file;
    // Who may HALT (every transport, HALT ALL too). Viewer by default: like a physical emergency stop,
    // anyone who may watch a stage may stop it.
    gw::role halt_role = role::viewer;
};

enum class log_level : std::uint8_t { trace, debug, info, warn, error, critical, off };
enum class log_format : std::uint8_t { text, json };
std::string_view to_string(log_level l);

struct logging_config {
    log_level level = log_level::info;
    log_format format = log_format::text;
    // Per-logger levels: "gateway", "api", "jobs", "mqtt", "ms2000" (every controller) or
    // "ms2000.<id>" (one controller; wins over "ms2000").
    std::map<std::string, log_level> levels;
};

struct shutdown_config {
    bool halt_on_exit = true;  // HALT every connected controller before stopping
};

// The MQTT fleet interface (api/mqtt/). Off by default; command topics off even when it is on.
//   "mqtt": {"enabled": true, "brokers": ["mqtt://broker:1883"], "client_id": "", "username": "",
//            "password": "", "tls": {"ca_file": "", "cert_file": "", "key_file": "", "verify": true},
//            "keepalive_s": 30, "topic_prefix": "asi", "gateway_id": "" (the host name),
//            "protocol": "5"|"3.1.1", "qos": {"status": 1, "state": 1, "telemetry": 0, "jobs": 1,
//            "responses": 1}, "telemetry": {"position_max_hz": 10},
//            "reconnect": {"min_ms": 500, "max_ms": 2000}, "tcp_nodelay": true,
//            "jobs": {"queue_limit": 1000, "retain_finished_s": events.ended_job_topic_ttl_s},
//            "commands": {"enabled": false}}
enum class mqtt_protocol : std::uint8_t { v3_1_1, v5 };

struct mqtt_tls_config {
    std::string ca_file;    // PEM file of the CA(s) trusted for the broker; empty: the system's
    std::string cert_file;  // client certificate (PEM), together with key_file
    std::string key_file;
    bool verify = true;  // verify the broker's certificate chain and host name
};

struct mqtt_qos_config {
    int status = 1;     // <prefix>/<gateway>/status (birth, will, offline)
    int state = 1;      // controllers/<id>/state
    int telemetry = 0;  // position, reports, ttl
    int jobs = 1;       // jobs/<job>/state
    int responses = 1;  // command responses (and the command subscriptions)
};

// A key that signs MQTT commands (api/mqtt/mqtt_signature.hpp); the sender gets its role.
struct mqtt_signing_key {
    std::string name;
    gw::role role = gw::role::viewer;
    std::vector<std::uint8_t> key;  // 32..64 bytes, from 64..128 hex digits
};

struct mqtt_config {
    bool enabled = false;
    std::vector<std::string> brokers{"mqtt://127.0.0.1:1883"};  // mqtt:// tcp:// mqtts:// ssl://
    std::string client_id;                                      // empty: "asi-gateway-<gateway_id>"
    std::string username;
    std::string password;
    mqtt_tls_config tls;  // used for mqtts:// and ssl:// brokers
    std::chrono::seconds keepalive{30};
    // 0: a new session on every connect. Above: the broker keeps the gateway's session this long
    // while it is away, with the commands sent meanwhile to its QoS 1 subscriptions, and hands them
    // over when it is back (their deadlines decide whether they run). MQTT 5: the session expiry
    // interval; 3.1.1: clean_session false, kept as long as the broker keeps sessions.
    std::chrono::seconds session_expiry{0};
    std::string topic_prefix = "asi";
    std::string gateway_id;  // empty: the host name (characters outside [A-Za-z0-9_.-] become '-')
    mqtt_protocol protocol = mqtt_protocol::v5;
    mqtt_qos_config qos;
    double position_max_hz = 10;  // per controller; 0: every position event
    // Report frames of a controller gathered into one message for up to this long; 0: as they come.
    std::chrono::milliseconds reports_batch{10};
    // Nagle's algorithm off on the broker connection: a message leaves at once instead of waiting for
    // the broker's ACK of the one before (about 10 ms on loopback). Costs a TCP segment per message.
    bool tcp_nodelay = true;
    // Waits between connect attempts: from min doubling up to max, each drawn from [half, all] of it
    // (api/mqtt/reconnect_backoff.hpp). max bounds how long a broker's return goes unnoticed.
    std::chrono::milliseconds reconnect_min{500};
    std::chrono::milliseconds reconnect_max{2000};
    std::size_t job_queue_limit = 1000;  // job state changes kept while disconnected
    // Then jobs/<job>/state is cleared; when the file does not say, events.ended_job_topic_ttl_s.
    std::chrono::seconds retain_finished_jobs{600};
    bool commands_enabled = false;  // subscribe to the command topics (needs a way to authenticate)
    // Commands are signed with one of these keys (HMAC-SHA256, a short window, no replays).
    std::vector<mqtt_signing_key> command_signing_keys;
    std::chrono::seconds command_signature_window{30};
    // A signed command's deadline: its ts plus this (api/mqtt/command_deadline.hpp).
    std::chrono::seconds command_max_age{10};
    // A command's (sender, id) is remembered this long: a QoS 1 redelivery of it is not run again.
    std::chrono::seconds command_redelivery_window{600};
    // Also take a bearer token of auth.tokens in a payload ("token"); only with TLS brokers, since
    // whoever reads the command topics could use the token on REST.
    bool accept_bearer_tokens = false;
    // A larger command payload is dropped unread and unanswered (an inline G-code program of 4 MiB
    // fits with room for its JSON escapes).
    std::size_t command_max_payload_bytes = std::size_t{6} * 1024 * 1024;
};

struct gateway_config {
    http_config http;
    std::vector<devices::controller_settings> controllers;
    std::vector<devices::share::share_settings> shares;  // controllers[].share, in controller order
    simulate_config simulate;
    storage_config storage;
    jobs_config jobs;
    gcode_config gcode;
    auth_config auth;
    logging_config logging;
    shutdown_config shutdown;
    events_config events;
    mqtt_config mqtt;
};

// Limits of the values the file may hold.
inline constexpr unsigned supported_bauds[] = {9600, 19200, 28800, 38400, 57600, 115200};
inline constexpr std::size_t max_simulated_controllers = 16;
inline constexpr std::size_t max_storage_size_mb = std::size_t{1024} * 1024;  // 1 TiB
inline constexpr std::size_t max_queued_jobs_per_controller = 100000;
inline constexpr std::size_t max_gcode_file_mb = 4096;
inline constexpr std::uint64_t max_ended_job_topic_ttl_s = std::uint64_t{7} * 24 * 3600;

// The embedded default used without a file: four simulated controllers (`--simulate 4`), one of each
// preset, so that every firmware module can be tried.
gateway_config default_config();

// Parses and validates the text of a config file. Keys left out keep their default (simulate.count
// is 0 in a file: a file describes its controllers). The error is one line naming the JSON path.
// auth.tokens_file is read here, a relative path from `config_directory` (the working directory when
// empty).
boost::system::result<gateway_config, std::string> parse_config(std::string_view json_text,
                                                                std::string_view config_directory = {});
// Reads and parses a file; the error names the file when it cannot be read.
boost::system::result<gateway_config, std::string> load_config_file(const std::string& path);
// Checks what parse_config cannot see in isolation (e.g. after flags changed it): duplicate ids,
// a non-loopback listen address without tokens. Empty when fine.
std::string validate_config(const gateway_config& config);

// `asi-gateway --check-config FILE`: prints "ok" to `out` and returns 0, or prints the error to `err`
// and returns 2.
int check_config_file(const std::string& path, std::ostream& out, std::ostream& err);

// A level of an MQTT topic the gateway builds (prefix levels, gateway id): 1..64 characters of
// [A-Za-z0-9_.-], not starting with '$' (that would be a broker topic).
bool is_valid_mqtt_level(std::string_view level);
// "asi", "lab/asi": levels as above, separated by '/'.
bool is_valid_mqtt_prefix(std::string_view prefix);

// A controller id: 1..64 characters of [A-Za-z0-9_-] (it names REST paths and MQTT topic levels).
bool is_valid_controller_id(std::string_view id);

// The loopback test behind the "no tokens, loopback only" rule.
bool is_loopback_address(std::string_view address);

}  // namespace gw
