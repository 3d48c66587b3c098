#pragma once
// Signed MQTT commands: a command proves its sender with an HMAC, so no reusable secret crosses the
// broker (a bearer token in a payload could be read by anyone allowed to read the command topics, a
// broker admin, or the wire, and then used on REST). Pure but for OpenSSL's HMAC-SHA256.
//
// The payload wraps the command message (the JSON text it would be unsigned) as a string:
//   {"key": "orchestrator", "ts": 1764921600123, "nonce": "6f1c2a9b0e4d7c35", "sig": "<64 hex>",
//    "body": "{\"id\":\"c7\",\"operation\":\"move\",\"args\":{\"axes\":{\"X\":1000}}}"}
//   sig = hex(HMAC-SHA256(key bytes, topic + "\n" + ts + "\n" + nonce + "\n" + body))
// "key" names an entry of mqtt.commands.signing_keys (its role is the sender's role), "ts" is the
// sender's clock in milliseconds since the Unix epoch, "nonce" 8-64 characters of [A-Za-z0-9_-] used
// once. The gateway takes a command whose ts is within the window of its own clock and whose
// (key, nonce) it has not seen within the window (api/mqtt/replay_window.hpp); the topic is signed, so a
// command cannot be replayed to another controller. The body is parsed only after all of that.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <boost/system/result.hpp>

namespace gw::api {

struct signed_command {
    std::string key;  // the signing key's name
    std::int64_t ts_ms = 0;
    std::string nonce;
    std::string sig;   // 64 lower- or upper-case hex digits
    std::string body;  // the command message's JSON text, not parsed yet
};

// True when the payload is meant as a signed command: a JSON object with a "sig" key at its top
// level (a "sig" deeper in a bearer-token payload's arguments does not count). Builds nothing.
bool looks_signed(std::string_view payload);

// The envelope, or why it is not one (never answered: the sender is not known yet).
boost::system::result<signed_command, std::string> read_signed_command(std::string_view payload);

// What is signed: topic, ts, nonce and body, one per line.
std::string signing_text(std::string_view topic, std::int64_t ts_ms, std::string_view nonce,
                         std::string_view body);

// HMAC-SHA256 of `text` under `key`, as 64 lower-case hex digits.
std::string hmac_sha256_hex(const std::vector<std::uint8_t>& key, std::string_view text);

// Whether `sig` is the signature of `text` under `key`, compared in constant time.
bool signature_matches(const std::vector<std::uint8_t>& key, std::string_view text, std::string_view sig);

}  // namespace gw::api
