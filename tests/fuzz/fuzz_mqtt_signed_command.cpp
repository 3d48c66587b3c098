// The signed MQTT command envelope (api/mqtt/mqtt_signature.hpp) on arbitrary payloads, and the
// replay guard on arbitrary (nonce, ts) sequences. Checks: an envelope that reads is one that
// looks_signed tells apart from a bearer payload; it has the documented
// shapes (a key of 1-64 characters, a nonce of 8-64 of [A-Za-z0-9_-], 64 hex digits of signature);
// a signature made for its text matches and one for another key does not; the replay guard never
// remembers more than its bound, never admits a nonce twice within the window, and admits nothing
// stale.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "api/mqtt/mqtt_signature.hpp"
#include "api/mqtt/replay_window.hpp"

namespace {

void check(bool condition, int line = __builtin_LINE()) {
    if (condition) return;
    std::fprintf(stderr, "fuzz_mqtt_signed_command.cpp:%d: check failed\n", line);
    std::abort();
}

void envelope(std::string_view payload) {
    const bool looks = gw::api::looks_signed(payload);
    auto c = gw::api::read_signed_command(payload);
    if (!c) return;
    check(looks);  // every envelope that reads is taken for a signed command
    check(!c->key.empty() && c->key.size() <= 64);
    check(c->nonce.size() >= 8 && c->nonce.size() <= 64);
    check(c->sig.size() == 64);
    const std::vector<std::uint8_t> key(32, 7), other(32, 8);
    const auto text = gw::api::signing_text("asi/x/controllers/a/cmd", c->ts_ms, c->nonce, c->body);
    const auto sig = gw::api::hmac_sha256_hex(key, text);
    check(gw::api::signature_matches(key, text, sig));
    check(!gw::api::signature_matches(other, text, sig));
}

// Pairs of bytes: nonce number (0..15) and a ts step; the clock moves on by the step's low bits.
void replays(std::string_view steps) {
    constexpr std::size_t bound = 8;
    constexpr std::int64_t window = 1000;
    gw::api::replay_window guard(std::chrono::milliseconds(window), bound);
    std::int64_t now = 100'000;
    std::vector<std::pair<std::string, std::int64_t>> admitted;
    for (std::size_t i = 0; i + 1 < steps.size(); i += 2) {
        const auto a = static_cast<std::uint8_t>(steps[i]);
        const auto b = static_cast<std::uint8_t>(steps[i + 1]);
        now += b & 0x3f;
        const auto ts = now + (static_cast<std::int64_t>(b >> 6) - 2) * 600;  // -1200..+600 ms
        const std::string nonce = "nonce-" + std::to_string(a & 0x0f) + "x";
        const auto verdict = guard.admit("k", nonce, ts, now);
        using v = gw::api::replay_window::verdict;
        if (ts < now - window || ts > now + window) check(verdict == v::stale);
        if (verdict == v::fresh) {
            for (const auto& [n, t] : admitted)
                check(n != nonce || now > t + window);  // the same nonce only once its first is out
            admitted.emplace_back(nonce, ts);
        }
        check(guard.remembered() <= bound);
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::string_view rest(reinterpret_cast<const char*>(data) + 1, size - 1);
    if (data[0] % 2 == 0)
        envelope(rest);
    else
        replays(rest);
    return 0;
}
