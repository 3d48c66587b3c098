#include "api/auth.hpp"

#include <cstdint>

namespace gw::api {

namespace {

bool same_token(std::string_view a, std::string_view b) {
    // Constant time in the content: a timing difference must not reveal a prefix.
    std::uint8_t diff = a.size() == b.size() ? 0 : 1;
    for (std::size_t i = 0; i < a.size(); ++i)
        diff |= static_cast<std::uint8_t>(a[i] ^ (i < b.size() ? b[i] : 0));
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
    const gw::auth_token* found = nullptr;
    for (const auto& t : auth.tokens)  // no early exit: every token is compared
        if (same_token(token, t.token) && !token.empty()) found = &t;
    if (!found) {
        error = make_problem(http_error::unauthorized, "unknown bearer token");
        return std::nullopt;
    }
    return auth_identity{found->name, found->role};
}

bool has_role(const auth_identity& who, gw::role needed) {
    return static_cast<int>(who.role) >= static_cast<int>(needed);
}

problem forbidden_problem(const auth_identity& who, gw::role needed) {
    return make_problem(http_error::forbidden, "this needs the " + std::string(to_string(needed)) +
                                                   " role; token \"" + who.name + "\" has " +
                                                   std::string(to_string(who.role)));
}

}  // namespace gw::api
