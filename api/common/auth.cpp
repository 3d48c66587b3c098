#include "api/common/auth.hpp"

#include <cstdint>

namespace gw::api {

namespace {

bool same_digest(const token_digest& a, const token_digest& b) {
    // Constant time in the content: a timing difference must not reveal a prefix.
    std::uint8_t diff = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        diff |= static_cast<std::uint8_t>(a[i] ^ b[i]);
    return diff == 0;
}

bool iequals(std::string_view a, std::string_view b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
        auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; };
        if (lower(a[i]) != lower(b[i])) return false;
    }
    return true;
}

}  // namespace

std::optional<auth_identity> authenticate(const auth_config& auth, std::string_view authorization,
                                          problem& error) {
    if (auth.tokens.empty()) return auth_identity{"anonymous", gw::role::admin};
    if (authorization.empty()) {
        error = make_problem(http_error::unauthorized, "an Authorization: Bearer <token> header is required");
        return std::nullopt;
    }
    constexpr std::string_view scheme = "bearer ";
    if (authorization.size() <= scheme.size() || !iequals(authorization.substr(0, scheme.size()), scheme)) {
        error = make_problem(http_error::unauthorized, "the Authorization header must be \"Bearer <token>\"");
        return std::nullopt;
    }
    auto token = authorization.substr(scheme.size());
    while (!token.empty() && token.front() == ' ')
        token.remove_prefix(1);
    while (!token.empty() && token.back() == ' ')
        token.remove_suffix(1);
    return authenticate_token(auth, token, error);
}

std::optional<auth_identity> authenticate_token(const auth_config& auth, std::string_view token,
                                                problem& error) {
    if (auth.tokens.empty()) return auth_identity{"anonymous", gw::role::admin};
    const gw::auth_token* found = nullptr;
    // Compared as hashes: the config keeps no token, and a hash compares in the same time whatever
    // the length. A token longer than any the gateway makes is no token (and costs no hashing).
    if (!token.empty() && token.size() <= max_token_bytes) {
        const auto digest = hash_token(token);
        for (const auto& t : auth.tokens)  // no early exit: every token is compared
            if (same_digest(digest, t.digest)) found = &t;
    }
    if (!found) {
        error = make_problem(http_error::unauthorized, "unknown bearer token");
        return std::nullopt;
    }
    return auth_identity{found->name, found->role};
}

std::optional<std::string> access_token_parameter(std::string_view target) {
    const auto q = target.find('?');
    if (q == std::string_view::npos) return std::nullopt;
    constexpr std::string_view name = "access_token=";
    auto query = target.substr(q + 1);
    while (!query.empty()) {
        const auto amp = query.find('&');
        const auto pair = query.substr(0, amp);
        query = amp == std::string_view::npos ? std::string_view{} : query.substr(amp + 1);
        if (!pair.starts_with(name)) continue;
        const auto raw = pair.substr(name.size());
        std::string value;
        value.reserve(raw.size());
        auto hex = [](char c) -> int {
            if (c >= '0' && c <= '9') return c - '0';
            if (c >= 'a' && c <= 'f') return c - 'a' + 10;
            if (c >= 'A' && c <= 'F') return c - 'A' + 10;
            return -1;
        };
        for (std::size_t i = 0; i < raw.size(); ++i) {
            if (raw[i] != '%') {
                value += raw[i];
                continue;
            }
            if (i + 2 >= raw.size()) return std::string{};
            const int hi = hex(raw[i + 1]);
            const int lo = hex(raw[i + 2]);
            if (hi < 0 || lo < 0) return std::string{};
            value += static_cast<char>(hi * 16 + lo);
            i += 2;
        }
        return value;
    }
    return std::nullopt;
}

std::string redact_access_token(std::string_view target) {
    const auto q = target.find('?');
    if (q == std::string_view::npos) return std::string(target);
    constexpr std::string_view name = "access_token=";
    std::string out(target.substr(0, q + 1));
    auto query = target.substr(q + 1);
    bool first = true;
    while (true) {
        const auto amp = query.find('&');
        const auto pair = query.substr(0, amp);
        if (!first) out += '&';
        first = false;
        if (pair.starts_with(name)) {
            out += name;
            out += "REDACTED";
        } else {
            out += pair;
        }
        if (amp == std::string_view::npos) break;
        query = query.substr(amp + 1);
    }
    return out;
}

bool has_role(const auth_identity& who, gw::role needed) {
    return static_cast<int>(who.role) >= static_cast<int>(needed);
}

problem forbidden_problem(const auth_identity& who, gw::role needed) {
    return make_problem(http_error::forbidden, "this needs the " + std::string(to_string(needed)) +
                                                   " role; token \"" + who.name + "\" has " +
                                                   std::string(to_string(who.role)));
}

nlohmann::json whoami_json(const auth_config& auth, const auth_identity& who) {
    const bool tokens = !auth.tokens.empty();
    return {{"client", tokens ? nlohmann::json(who.name) : nlohmann::json(nullptr)},
            {"role", std::string(to_string(who.role))},
            {"auth", tokens ? "token" : "none"}};
}

}  // namespace gw::api
