#pragma once
// Bearer tokens as the gateway keeps them: their SHA-256, never the token itself, so a config file
// (or a memory dump) that leaks does not hand out a role.
//
//   "auth": {"tokens": [{"name": "scheduler", "role": "operator", "token_sha256": "9f86d0...0a08"}]}
//   asi-gateway token new --name scheduler --role operator   // prints a token once, and that entry
//
// A token typed into the config ("token") is refused when it is an example from the documentation
// or guessable: under 128 bits by the estimate below. Pure, but for new_token (the system's random
// source).

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace gw {

using token_digest = std::array<std::uint8_t, 32>;

// SHA-256 of the token's bytes.
token_digest hash_token(std::string_view token);

// 64 hexadecimal digits (either case) to a digest; nullopt for anything else.
std::optional<token_digest> parse_token_digest(std::string_view hex);
std::string to_hex(const token_digest& digest);

// Why the token may not be used ("" when it may): a placeholder of the documentation ("change-me",
// "example", ...), fewer than 8 different characters, or an estimated strength under 128 bits,
// counted as length x log2(the size of the character classes it uses: lower case 26, upper case 26,
// digits 10, others 32).
std::string weak_token_reason(std::string_view token);

// 256 random bits from the system's source, as 43 characters of base64url (no padding).
std::string new_token();

}  // namespace gw
