#include "gateway/config/config.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

namespace gw {
namespace {

using namespace std::chrono_literals;

TEST(config, empty_object_gives_the_safe_defaults) {
    auto c = parse_config("{}");
    ASSERT_TRUE(c) << c.error();
    EXPECT_EQ(c->http.listen_address, "127.0.0.1");
    EXPECT_EQ(c->http.port, 8080);
    EXPECT_EQ(c->http.limits.max_header_bytes, 16u * 1024);
    EXPECT_EQ(c->http.limits.max_body_bytes, 1024u * 1024);
    EXPECT_EQ(c->http.limits.read_timeout, 30000ms);
    EXPECT_EQ(c->http.limits.max_websocket_message_bytes, 64u * 1024);
    EXPECT_EQ(c->http.limits.max_connections, 256u);
    EXPECT_EQ(c->http.limits.header_timeout, 5000ms);
    EXPECT_EQ(c->http.limits.max_connections_per_address, 64u);
    EXPECT_EQ(c->http.limits.max_buffered_body_bytes, 64u * 1024 * 1024);
    EXPECT_TRUE(c->controllers.empty());
    EXPECT_EQ(c->simulate.count, 0u);
    EXPECT_EQ(c->simulate.time_scale, 1.0);
    EXPECT_EQ(c->storage.path, "");  // the default location is resolved by main
    EXPECT_EQ(c->storage.max_size_mb, 1024u);
    EXPECT_EQ(c->storage.recordings_max_mb, 10240u);
    EXPECT_FALSE(c->jobs.restart_queued);
    EXPECT_EQ(c->jobs.max_queued_per_controller, 1000u);
    EXPECT_EQ(c->gcode.max_file_mb, 64u);
    EXPECT_TRUE(c->auth.tokens.empty());
    EXPECT_EQ(c->logging.level, log_level::info);
    EXPECT_EQ(c->logging.format, log_format::text);
    EXPECT_TRUE(c->logging.levels.empty());
    EXPECT_TRUE(c->shutdown.halt_on_exit);
}

TEST(config, embedded_default_simulates_one_controller_of_each_preset) {
    const auto c = default_config();
    EXPECT_EQ(c.simulate.count, 4u);  // full, plain, planar, crisp
    EXPECT_TRUE(c.controllers.empty());
    EXPECT_EQ(c.http.listen_address, "127.0.0.1");
    EXPECT_TRUE(validate_config(c).empty());
}

TEST(config, reads_every_key) {
    auto c = parse_config(R"({
      "http": {"listen_address": "0.0.0.0", "port": 9000, "public_url": "https://lab3.example:8443/",
               "limits": {"max_header_bytes": 8192, "max_body_bytes": 4096, "read_timeout_ms": 5000,
                          "max_websocket_message_bytes": 2048, "max_connections": 10,
                          "header_timeout_ms": 1500, "max_connections_per_address": 4,
                          "max_buffered_body_mb": 3}},
      "controllers": [
        {"id": "stage1", "port": "/dev/ttyUSB0", "baud": 115200, "report_port": "/dev/ttyUSB1",
         "poll_ms": 50, "error_log_ms": 0, "command_timeout_ms": 700},
        {"id": "stage-2_b", "port": "/dev/serial/by-id/x"}
      ],
      "simulate": {"count": 2, "time_scale": 10.5, "directory": "/tmp/sims"},
      "storage": {"path": "/var/lib/asi", "max_size_mb": 64, "recordings_max_mb": 500},
      "jobs": {"restart_queued": true, "max_queued_per_controller": 20},
      "auth": {"tokens": [{"name": "dash", "token": "Tok-0123456789abcdef", "role": "viewer"},
                          {"name": "ops", "token": "Tok-0123456789abcdeX", "role": "operator"},
                          {"name": "root", "token": "Tok-0123456789abcdeY", "role": "admin"},
                          {"name": "def", "token": "Tok-0123456789abcdeZ"}]},
      "logging": {"level": "debug", "format": "json",
                  "levels": {"api": "warn", "ms2000": "trace", "ms2000.stage1": "error"}},
      "shutdown": {"halt_on_exit": false}
    })");
    ASSERT_TRUE(c) << c.error();
    EXPECT_EQ(c->http.listen_address, "0.0.0.0");
    EXPECT_EQ(c->http.port, 9000);
    EXPECT_EQ(c->http.public_url, "https://lab3.example:8443/");
    EXPECT_EQ(c->http.limits.max_header_bytes, 8192u);
    EXPECT_EQ(c->http.limits.max_body_bytes, 4096u);
    EXPECT_EQ(c->http.limits.read_timeout, 5000ms);
    EXPECT_EQ(c->http.limits.max_websocket_message_bytes, 2048u);
    EXPECT_EQ(c->http.limits.max_connections, 10u);
    EXPECT_EQ(c->http.limits.header_timeout, 1500ms);
    EXPECT_EQ(c->http.limits.max_connections_per_address, 4u);
    EXPECT_EQ(c->http.limits.max_buffered_body_bytes, 3u * 1024 * 1024);
    ASSERT_EQ(c->controllers.size(), 2u);
    const auto& s = c->controllers[0];
    EXPECT_EQ(s.id, "stage1");
    EXPECT_EQ(s.port, "/dev/ttyUSB0");
    EXPECT_EQ(s.baud, 115200u);
    EXPECT_EQ(s.report_port, "/dev/ttyUSB1");
    EXPECT_EQ(s.poll_interval, 50ms);
    EXPECT_EQ(s.command_timeout, 700ms);
    EXPECT_EQ(s.error_log_interval, 0ms);
    const auto& d = c->controllers[1];
    EXPECT_EQ(d.id, "stage-2_b");
    EXPECT_EQ(d.baud, 9600u);  // the controller's factory default
    EXPECT_EQ(d.report_port, "");
    EXPECT_EQ(d.poll_interval, 100ms);
    EXPECT_EQ(d.command_timeout, 1000ms);
    EXPECT_EQ(d.error_log_interval, 10000ms);
    EXPECT_EQ(c->simulate.count, 2u);
    EXPECT_EQ(c->simulate.time_scale, 10.5);
    EXPECT_EQ(c->simulate.directory, "/tmp/sims");
    EXPECT_EQ(c->storage.path, "/var/lib/asi");
    EXPECT_EQ(c->storage.max_size_mb, 64u);
    EXPECT_EQ(c->storage.recordings_max_mb, 500u);
    EXPECT_TRUE(c->jobs.restart_queued);
    EXPECT_EQ(c->jobs.max_queued_per_controller, 20u);
    ASSERT_EQ(c->auth.tokens.size(), 4u);
    EXPECT_EQ(c->auth.tokens[0].role, role::viewer);
    EXPECT_EQ(c->auth.tokens[1].role, role::operator_);
    EXPECT_EQ(c->auth.tokens[2].role, role::admin);
    EXPECT_EQ(c->auth.tokens[2].name, "root");
    EXPECT_EQ(c->auth.tokens[3].role, role::viewer);  // the least privilege by default
    EXPECT_EQ(c->logging.level, log_level::debug);
    EXPECT_EQ(c->logging.format, log_format::json);
    EXPECT_EQ(c->logging.levels.at("api"), log_level::warn);
    EXPECT_EQ(c->logging.levels.at("ms2000"), log_level::trace);
    EXPECT_EQ(c->logging.levels.at("ms2000.stage1"), log_level::error);
    EXPECT_FALSE(c->shutdown.halt_on_exit);
}

TEST(config, every_supported_baud_is_accepted) {
    for (unsigned baud : supported_bauds) {
        auto c = parse_config(R"({"controllers": [{"id": "a", "port": "/dev/x", "baud": )" +
                              std::to_string(baud) + "}]}");
        ASSERT_TRUE(c) << baud << ": " << c.error();
        EXPECT_EQ(c->controllers[0].baud, baud);
    }
}

struct bad_case {
    const char* json;
    const char* error;  // the exact message
};

TEST(config, the_largest_body_fits_the_default_body_budget) {
    auto c = parse_config(R"({"http": {"limits": {"max_body_bytes": 67108864}}})");
    ASSERT_TRUE(c) << c.error();
    EXPECT_GE(c->http.limits.max_buffered_body_bytes, c->http.limits.max_body_bytes);
}

TEST(config, refuses_bad_values_naming_the_json_path) {
    const bad_case cases[] = {
        // Not JSON / wrong shapes.
        {"[]", "(top level): must be an object"},
        {R"({"http": 1})", "http: must be an object"},
        {R"({"http": {"limits": []}})", "http.limits: must be an object"},
        {R"({"controllers": {}})", "controllers: must be an array"},
        {R"({"controllers": [1]})", "controllers[0]: must be an object"},
        {R"({"simulate": "3"})", "simulate: must be an object"},
        {R"({"storage": null})", "storage: must be an object"},
        {R"({"auth": {"tokens": {}}})", "auth.tokens: must be an array"},
        {R"({"logging": {"levels": []}})", "logging.levels: must be an object"},
        {R"({"shutdown": true})", "shutdown: must be an object"},
        // http
        {R"({"http": {"listen_address": "localhost"}})",
         "http.listen_address: must be an IPv4 or IPv6 address"},
        {R"({"http": {"listen_address": ""}})", "http.listen_address: must not be empty"},
        {R"({"http": {"public_url": "lab3:8080"}})",
         "http.public_url: must be an http:// or https:// URL of at most 512 printable characters without "
         "spaces"},
        {R"({"http": {"public_url": "http://lab 3/"}})",
         "http.public_url: must be an http:// or https:// URL of at most 512 printable characters without "
         "spaces"},
        {R"({"http": {"tls": {"cert_file": "c.pem"}}})",
         "http.tls: needs both cert_file and key_file (PEM files)"},
        {R"({"http": {"tls": {"cert_file": "c.pem", "key_file": ""}}})",
         "http.tls.key_file: must not be empty"},
        {R"({"http": {"tls": {"cert_file": "c", "key_file": "k", "ciphers": "x"}}})",
         "http.tls.ciphers: unknown key"},
        {R"({"storage": {"retention": {"max_age_days": 0}}})",
         "storage.retention.max_age_days: must be an integer from 1 to 36500"},
        {R"({"storage": {"retention": {"keep": 3}}})", "storage.retention.keep: unknown key"},
        {R"({"http": {"trusted_proxies": ["127.0.0.1", "proxy.lab"]}})",
         "http.trusted_proxies[1]: \"proxy.lab\" must be an address (10.0.0.5, ::1) or a network "
         "(10.0.0.0/8, "
         "fd00::/8)"},
        {R"({"http": {"listen_address": 127}})", "http.listen_address: must be a string"},
        {R"({"http": {"port": 65536}})", "http.port: must be an integer from 0 to 65535"},
        {R"({"http": {"port": -1}})", "http.port: must be an integer from 0 to 65535"},
        {R"({"http": {"port": 80.5}})", "http.port: must be an integer from 0 to 65535"},
        {R"({"http": {"port": "80"}})", "http.port: must be an integer from 0 to 65535"},
        {R"({"http": {"limits": {"max_header_bytes": 10}}})",
         "http.limits.max_header_bytes: must be an integer from 1024 to 1048576"},
        {R"({"http": {"limits": {"max_body_bytes": 0}}})",
         "http.limits.max_body_bytes: must be an integer from 1 to 67108864"},
        {R"({"http": {"limits": {"read_timeout_ms": 99}}})",
         "http.limits.read_timeout_ms: must be an integer from 100 to 600000"},
        {R"({"http": {"limits": {"max_websocket_message_bytes": 1}}})",
         "http.limits.max_websocket_message_bytes: must be an integer from 128 to 16777216"},
        {R"({"http": {"limits": {"max_connections": 0}}})",
         "http.limits.max_connections: must be an integer from 1 to 10000"},
        {R"({"http": {"limits": {"header_timeout_ms": 50}}})",
         "http.limits.header_timeout_ms: must be an integer from 100 to 600000"},
        {R"({"http": {"limits": {"max_connections_per_address": 0}}})",
         "http.limits.max_connections_per_address: must be an integer from 1 to 10000"},
        {R"({"http": {"limits": {"max_buffered_body_mb": 0}}})",
         "http.limits.max_buffered_body_mb: must be an integer from 1 to 4096"},
        {R"({"http": {"limits": {"max_body_bytes": 4194304, "max_buffered_body_mb": 2}}})",
         "http.limits.max_buffered_body_mb: max_buffered_body_mb must hold at least one body of "
         "max_body_bytes"},
        // controllers
        {R"({"controllers": [{"port": "/dev/x"}]})", "controllers[0].id: required"},
        {R"({"controllers": [{"id": "a"}]})", "controllers[0].port: required"},
        {R"({"controllers": [{"id": "a/b", "port": "/dev/x"}]})",
         "controllers[0].id: must be 1-64 characters of letters, digits, '-' or '_'"},
        {R"({"controllers": [{"id": "", "port": "/dev/x"}]})", "controllers[0].id: must not be empty"},
        {R"({"controllers": [{"id": "a", "port": ""}]})", "controllers[0].port: must not be empty"},
        {R"({"controllers": [{"id": "a", "port": "/dev/x"}, {"id": "b", "port": "/dev/y", "baud": 9601}]})",
         "controllers[1].baud: must be one of 9600, 19200, 28800, 38400, 57600, 115200"},
        {R"({"controllers": [{"id": "a", "port": "/dev/x", "baud": "9600"}]})",
         "controllers[0].baud: must be one of 9600, 19200, 28800, 38400, 57600, 115200"},
        {R"({"controllers": [{"id": "a", "port": "/dev/x", "report_port": 3}]})",
         "controllers[0].report_port: must be a string"},
        {R"({"controllers": [{"id": "a", "port": "/dev/x", "poll_ms": 60001}]})",
         "controllers[0].poll_ms: must be an integer from 0 to 60000"},
        {R"({"controllers": [{"id": "a", "port": "/dev/x", "error_log_ms": -1}]})",
         "controllers[0].error_log_ms: must be an integer from 0 to 3600000"},
        {R"({"controllers": [{"id": "a", "port": "/dev/x", "command_timeout_ms": 5}]})",
         "controllers[0].command_timeout_ms: must be an integer from 10 to 60000"},
        {R"({"controllers": [{"id": "a", "port": "/dev/x"}, {"id": "a", "port": "/dev/y"}]})",
         "controllers[1].id: duplicate id \"a\""},
        {R"({"simulate": {"count": 2}, "controllers": [{"id": "sim2", "port": "/dev/y"}]})",
         "controllers[0].id: duplicate id \"sim2\" (simulated controllers are named sim1..simN)"},
        // simulate, storage
        {R"({"simulate": {"count": 17}})", "simulate.count: must be an integer from 0 to 16"},
        {R"({"simulate": {"time_scale": 0}})", "simulate.time_scale: must be a number from 0.01 to 1000"},
        {R"({"simulate": {"time_scale": "fast"}})",
         "simulate.time_scale: must be a number from 0.01 to 1000"},
        {R"({"simulate": {"directory": ""}})", "simulate.directory: must not be empty"},
        {R"({"storage": {"path": ""}})", "storage.path: must not be empty"},
        {R"({"storage": {"max_size_mb": 0}})", "storage.max_size_mb: must be an integer from 1 to 1048576"},
        {R"({"storage": {"recordings_max_mb": 0}})",
         "storage.recordings_max_mb: must be an integer from 1 to 1048576"},
        {R"({"storage": {"max_size_mb": 1048577}})",
         "storage.max_size_mb: must be an integer from 1 to 1048576"},
        {R"({"storage": {"max_size_mb": "1G"}})",
         "storage.max_size_mb: must be an integer from 1 to 1048576"},
        // jobs
        {R"({"jobs": []})", "jobs: must be an object"},
        {R"({"jobs": {"restart_queued": 1}})", "jobs.restart_queued: must be true or false"},
        {R"({"jobs": {"max_queued_per_controller": 0}})",
         "jobs.max_queued_per_controller: must be an integer from 1 to 100000"},
        {R"({"jobs": {"max_queued_per_controller": 100001}})",
         "jobs.max_queued_per_controller: must be an integer from 1 to 100000"},
        // gcode
        {R"({"gcode": {"max_file_mb": 0}})", "gcode.max_file_mb: must be an integer from 1 to 4096"},
        {R"({"gcode": {"max_file_mb": 2.5}})", "gcode.max_file_mb: must be an integer from 1 to 4096"},
        {R"({"gcode": {"max_file_mb": 4097}})", "gcode.max_file_mb: must be an integer from 1 to 4096"},
        // auth
        {R"({"auth": {"tokens": [{"token": "Tok-0123456789abcdef"}]}})", "auth.tokens[0].name: required"},
        {R"({"auth": {"tokens": [{"name": "a"}]}})", "auth.tokens[0].token_sha256: required (or \"token\")"},
        {R"({"auth": {"tokens": [{"name": "a", "token": "short"}]}})",
         "auth.tokens[0].token: is too easy to guess (about 23 bits; at least 128 are needed):"
         " make a token with `asi-gateway token new`"},
        {R"({"auth": {"tokens": [{"name": "a", "token": "0123456789abcdef"}]}})",
         "auth.tokens[0].token: is too easy to guess (about 82 bits; at least 128 are needed):"
         " make a token with `asi-gateway token new`"},
        {R"({"auth": {"tokens": [{"name": "a", "token": "change-me-operator-token"}]}})",
         "auth.tokens[0].token: is a placeholder (\"change-me\"): make a token with `asi-gateway token new`"},
        {R"({"auth": {"tokens": [{"name": "a", "token_sha256": "abc"}]}})",
         "auth.tokens[0].token_sha256: must be 64 hexadecimal digits (asi-gateway token new)"},
        {R"({"auth": {"tokens": [{"name": "a", "token": "Tok-0123456789abcdef",
                                  "token_sha256": "00000000000000000000000000000000000000000000000000000000000000000"}]}})",
         "auth.tokens[0].token: give \"token\" or \"token_sha256\", not both"},
        {R"({"auth": {"tokens": [{"name": "a", "token": "Tok-0123456789 abcdef"}]}})",
         "auth.tokens[0].token: must be printable ASCII without spaces"},
        {R"({"auth": {"tokens": [{"name": "a", "token": "Tok-0123456789abcdef", "role": "root"}]}})",
         "auth.tokens[0].role: must be one of viewer, operator, admin"},
        {R"({"auth": {"tokens": [{"name": "a", "token": "Tok-0123456789abcdef"},
                                  {"name": "a", "token": "Tok-0123456789abcdeX"}]}})",
         "auth.tokens[1].name: duplicate name \"a\""},
        {R"({"auth": {"tokens": [{"name": "a", "token": "Tok-0123456789abcdef"},
                                  {"name": "b", "token": "Tok-0123456789abcdef"}]}})",
         "auth.tokens[1].token: the same token is given twice"},
        {R"({"http": {"listen_address": "0.0.0.0"}})",
         "http.listen_address (--listen): 0.0.0.0 is not a loopback address, which needs auth.tokens (no "
         "tokens: loopback only)"},
        // logging, shutdown
        {R"({"logging": {"level": "verbose"}})",
         "logging.level: must be one of trace, debug, info, warn, error, critical, off"},
        {R"({"logging": {"format": "xml"}})", "logging.format: must be one of text, json"},
        {R"({"logging": {"levels": {"http": "debug"}}})",
         "logging.levels.http: unknown logger (gateway, api, jobs, mqtt, ms2000 or ms2000.<id>)"},
        {R"({"logging": {"levels": {"ms2000.": "debug"}}})",
         "logging.levels.ms2000.: unknown logger (gateway, api, jobs, mqtt, ms2000 or ms2000.<id>)"},
        {R"({"logging": {"levels": {"api": 3}}})",
         "logging.levels.api: must be one of trace, debug, info, warn, error, critical, off"},
        {R"({"shutdown": {"halt_on_exit": "yes"}})", "shutdown.halt_on_exit: must be true or false"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.json);
        auto r = parse_config(c.json);
        ASSERT_FALSE(r) << "accepted";
        EXPECT_EQ(r.error(), c.error);
    }
}

TEST(config, retention_is_off_unless_set) {
    auto none = parse_config("{}");
    EXPECT_TRUE(none->storage.retention.keeps_all_jobs());
    EXPECT_TRUE(none->storage.retention.keeps_all_audit());
    auto c = parse_config(
        R"({"storage": {"retention": {"max_age_days": 30, "max_audit_entries": 1000, "sweep_interval_s": 60}}})");
    ASSERT_TRUE(c) << c.error();
    EXPECT_EQ(c->storage.retention.max_age, std::chrono::hours(24 * 30));
    EXPECT_FALSE(c->storage.retention.max_ended_jobs);
    EXPECT_EQ(c->storage.retention.max_audit_entries, 1000U);
    EXPECT_EQ(c->storage.retention.sweep_interval, std::chrono::seconds(60));
}

TEST(config, tls_files_are_found_from_the_config_directory_and_credentials) {
    auto c = parse_config(R"({"http": {"tls": {"cert_file": "tls/server.crt", "key_file": "/etc/k.pem"}}})",
                          "/etc/asi-gateway");
    ASSERT_TRUE(c) << c.error();
    EXPECT_TRUE(c->http.tls.enabled());
    EXPECT_EQ(c->http.tls.cert_file, "/etc/asi-gateway/tls/server.crt");
    EXPECT_EQ(c->http.tls.key_file, "/etc/k.pem");
    EXPECT_FALSE(parse_config("{}")->http.tls.enabled());
    ::unsetenv("CREDENTIALS_DIRECTORY");
    auto unset = parse_config(
        R"({"http": {"tls": {"cert_file": "$CREDENTIALS_DIRECTORY/crt", "key_file": "$CREDENTIALS_DIRECTORY/key"}}})");
    ASSERT_FALSE(unset);
    EXPECT_NE(unset.error().find("http.tls.cert_file"), std::string::npos) << unset.error();
}

TEST(config, reads_a_controllers_share) {
    auto c = parse_config(R"({"controllers": [{"id": "a", "port": "/dev/ttyUSB0", "baud": 115200,
        "report_port": "/dev/ttyUSB1",
        "share": {"pty": "/run/gw/a", "pty_mode": "0640", "pty_group": "dialout", "tcp": "127.0.0.1:7001",
                  "report_pty": "/run/gw/a-report", "report_tcp": "[::1]:7002", "role": "viewer",
                  "lease": true, "max_clients": 2}}]})");
    ASSERT_TRUE(c) << c.error();
    ASSERT_EQ(c->shares.size(), 1U);
    const auto& s = c->shares[0];
    EXPECT_EQ(s.controller, "a");
    EXPECT_EQ(s.line_baud, 115200U);
    EXPECT_EQ(s.pty, "/run/gw/a");
    EXPECT_EQ(s.pty_mode, 0640U);
    EXPECT_EQ(s.pty_group, "dialout");
    EXPECT_EQ(s.tcp_host, "127.0.0.1");
    EXPECT_EQ(s.tcp_port, 7001);
    EXPECT_EQ(s.report_pty, "/run/gw/a-report");
    EXPECT_EQ(s.report_tcp_host, "::1");
    EXPECT_EQ(s.report_tcp_port, 7002);
    EXPECT_EQ(s.role, devices::share::share_role::viewer);
    EXPECT_TRUE(s.lease);
    EXPECT_EQ(s.max_clients, 2U);
    EXPECT_TRUE(parse_config("{}")->simulate.share);
}

TEST(config, refuses_a_bad_share_naming_the_key) {
    const std::string head = R"({"controllers": [{"id": "a", "port": "/dev/ttyUSB0", "share": )";
    const bad_case cases[] = {
        {"{}", "controllers[0].share: needs \"pty\", \"tcp\", \"report_pty\" or \"report_tcp\""},
        {R"({"pty": "relative"})", "controllers[0].share.pty: must be an absolute path"},
        {R"({"tcp": "localhost:7001"})",
         "controllers[0].share.tcp: must be \"HOST:PORT\" with an IP address, e.g. \"127.0.0.1:7001\""},
        {R"({"tcp": "127.0.0.1:0"})",
         "controllers[0].share.tcp: must be \"HOST:PORT\" with an IP address, e.g. \"127.0.0.1:7001\""},
        {R"({"tcp": "0.0.0.0:7001"})",
         "controllers[0].share.tcp: is not a loopback address: anyone who reaches it controls the stage with "
         "share.role and no token; set \"allow_network\": true to mean it"},
        {R"({"pty": "/x", "pty_mode": "0777"})",
         "controllers[0].share.pty_mode: must be an octal mode such as \"0660\" (no execute bits)"},
        {R"({"pty": "/x", "role": "root"})",
         "controllers[0].share.role: must be one of viewer, operator, admin"},
        {R"({"report_pty": "/x"})", "controllers[0].share.report_pty: needs the controller's report_port"},
        {R"({"pty": "/x", "colour": 1})", "controllers[0].share.colour: unknown key"},
    };
    std::vector<std::string> texts;
    for (const auto& c : cases) {
        const auto text = head + c.json + "}]}";
        SCOPED_TRACE(text);
        auto r = parse_config(text);
        ASSERT_FALSE(r) << "accepted";
        EXPECT_EQ(r.error(), c.error);
    }
    EXPECT_TRUE(parse_config(head + R"({"tcp": "0.0.0.0:7001", "allow_network": true}}]})"));
    auto twice = parse_config(R"({"controllers": [{"id": "a", "port": "/p1", "share": {"pty": "/s"}},
                                                  {"id": "b", "port": "/p2", "share": {"pty": "/s"}}]})");
    ASSERT_FALSE(twice);
    EXPECT_EQ(twice.error(), "controllers[].share.pty: /s is given twice");
}

TEST(config, refuses_unknown_keys_at_every_level) {
    const bad_case cases[] = {
        {R"({"htp": {}})", "htp: unknown key"},
        {R"({"http": {"prot": 80}})", "http.prot: unknown key"},
        {R"({"http": {"limits": {"max_bytes": 1}}})", "http.limits.max_bytes: unknown key"},
        {R"({"controllers": [{"id": "a", "port": "/dev/x"}, {"id": "b", "port": "/dev/y", "speed": 1}]})",
         "controllers[1].speed: unknown key"},
        {R"({"simulate": {"cont": 1}})", "simulate.cont: unknown key"},
        {R"({"storage": {"dir": "x"}})", "storage.dir: unknown key"},
        {R"({"jobs": {"restart": true}})", "jobs.restart: unknown key"},
        {R"({"gcode": {"max_file": 1}})", "gcode.max_file: unknown key"},
        {R"({"auth": {"token": []}})", "auth.token: unknown key"},
        {R"({"auth": {"tokens": [{"name": "a", "token": "Tok-0123456789abcdef", "roles": "admin"}]}})",
         "auth.tokens[0].roles: unknown key"},
        {R"({"logging": {"lvl": "info"}})", "logging.lvl: unknown key"},
        {R"({"shutdown": {"halt": true}})", "shutdown.halt: unknown key"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.json);
        auto r = parse_config(c.json);
        ASSERT_FALSE(r) << "accepted";
        EXPECT_EQ(r.error(), c.error);
    }
}

TEST(config, refuses_malformed_json_with_its_position) {
    auto r = parse_config("{\"http\": {\"port\": 80,}}");
    ASSERT_FALSE(r);
    EXPECT_TRUE(r.error().starts_with("not valid JSON: ")) << r.error();
    EXPECT_NE(r.error().find("line 1"), std::string::npos) << r.error();
}

TEST(config, non_loopback_address_is_fine_with_tokens_and_loopback_is_recognised) {
    auto r = parse_config(
        R"({"http": {"listen_address": "0.0.0.0"},
            "auth": {"tokens": [{"name": "a", "token": "Tok-0123456789abcdef", "role": "admin"}]}})");
    EXPECT_TRUE(r) << r.error();
    EXPECT_TRUE(is_loopback_address("127.0.0.1"));
    EXPECT_TRUE(is_loopback_address("127.1.2.3"));
    EXPECT_TRUE(is_loopback_address("::1"));
    EXPECT_FALSE(is_loopback_address("0.0.0.0"));
    EXPECT_FALSE(is_loopback_address("::"));
    EXPECT_FALSE(is_loopback_address("192.168.1.2"));
    EXPECT_FALSE(is_loopback_address("localhost"));
}

class config_file_test : public ::testing::Test {
  protected:
    std::string write(const std::string& text) {
        std::ofstream(path_) << text;
        return path_;
    }
    void TearDown() override { std::filesystem::remove(path_); }

    std::string path_ =
        (std::filesystem::temp_directory_path() / ("gw-config-test-" + std::to_string(::getpid()) + ".json"))
            .string();
};

TEST_F(config_file_test, check_config_prints_ok_and_returns_0) {
    // /dev/null: a character device every machine has, so no warning about the port.
    const auto path = write(R"({"controllers": [{"id": "stage1", "port": "/dev/null", "baud": 115200}]})");
    std::ostringstream out, err;
    EXPECT_EQ(check_config_file(path, out, err), 0);
    EXPECT_EQ(out.str(), "ok\n");
    EXPECT_EQ(err.str(), "");
}

TEST_F(config_file_test, check_config_warns_about_a_serial_port_that_is_not_there) {
    const auto missing = path_ + ".no-such-port";
    const auto path =
        write(R"({"controllers": [{"id": "stage1", "port": ")" + missing + R"(", "baud": 9600}]})");
    std::ostringstream out, err;
    EXPECT_EQ(check_config_file(path, out, err), 0);  // it may be plugged in later
    EXPECT_EQ(out.str(), "ok\n");
    EXPECT_NE(err.str().find(path + ": warning: controllers[0].port: " + missing + " does not exist now"),
              std::string::npos)
        << err.str();
    EXPECT_NE(err.str().find("asi-gateway ports"), std::string::npos) << err.str();
}

TEST_F(config_file_test, check_config_refuses_tls_files_that_cannot_be_used) {
    const auto not_pem = path_ + ".key";
    std::ofstream(not_pem) << "not a key\n";
    const auto missing_ca = path_ + ".no-such-ca.pem";
    const auto path =
        write(R"({"mqtt": {"enabled": true, "brokers": ["mqtts://127.0.0.1:8883"],
                                         "tls": {"ca_file": ")" +
              missing_ca + R"(", "cert_file": ")" + not_pem + R"(", "key_file": ")" + not_pem + R"("}}})");
    std::ostringstream out, err;
    EXPECT_EQ(check_config_file(path, out, err), 2);
    EXPECT_EQ(out.str(), "");
    EXPECT_NE(err.str().find("mqtt.tls.ca_file: " + missing_ca + ": No such file or directory"),
              std::string::npos)
        << err.str();
    EXPECT_NE(err.str().find("mqtt.tls.key_file: " + not_pem + ": not a PEM file"), std::string::npos)
        << err.str();
    std::filesystem::remove(not_pem);

    // The same files, readable PEM: fine.
    std::ofstream(not_pem) << "-----BEGIN PRIVATE KEY-----\nAAAA\n-----END PRIVATE KEY-----\n";
    const auto good = write(R"({"mqtt": {"enabled": true, "brokers": ["mqtts://127.0.0.1:8883"],
                                         "tls": {"ca_file": ")" +
                            not_pem + R"("}}})");
    std::ostringstream out2, err2;
    EXPECT_EQ(check_config_file(good, out2, err2), 0) << err2.str();
    std::filesystem::remove(not_pem);
}

TEST_F(config_file_test, check_config_prints_the_error_and_returns_2) {
    const auto path = write(R"({"http": {"prot": 80}})");
    std::ostringstream out, err;
    EXPECT_EQ(check_config_file(path, out, err), 2);
    EXPECT_EQ(out.str(), "");
    EXPECT_EQ(err.str(), path + ": http.prot: unknown key\n");
}

TEST_F(config_file_test, a_missing_file_is_an_error) {
    std::ostringstream out, err;
    EXPECT_EQ(check_config_file(path_ + ".absent", out, err), 2);
    EXPECT_EQ(err.str(), path_ + ".absent: cannot be read\n");
    auto loaded = load_config_file(path_ + ".absent");
    EXPECT_FALSE(loaded);
}

}  // namespace
}  // namespace gw
