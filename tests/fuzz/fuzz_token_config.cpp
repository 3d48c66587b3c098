// The token parts of the config on arbitrary text (gateway/config/token_secret.hpp, tokens_file.hpp).
// Input: byte 0 picks the reader, then the text. Checks: a digest is accepted exactly when it is 64
// hexadecimal digits and reads back as the same digits in lower case; the strength verdict never
// accepts a token of fewer than 8 distinct characters or one containing a documentation placeholder;
// a tokens-file text said to hold plain tokens parses as JSON with a "token" key.
#include <algorithm>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "gateway/config/token_secret.hpp"
#include "gateway/config/tokens_file.hpp"

namespace {

void check(bool condition, int line = __builtin_LINE()) {
    if (condition) return;
    std::fprintf(stderr, "fuzz_token_config.cpp:%d: check failed\n", line);
    std::abort();
}

std::string lower(std::string_view s) {
    std::string out(s);
    std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return std::tolower(c); });
    return out;
}

void digest_reader(std::string_view text) {
    const bool hex = text.size() == 64 && std::all_of(text.begin(), text.end(),
                                                      [](unsigned char c) { return std::isxdigit(c) != 0; });
    const auto digest = gw::parse_token_digest(text);
    check(digest.has_value() == hex);
    if (digest) check(gw::to_hex(*digest) == lower(text));
}

void strength_verdict(std::string_view token) {
    const auto why = gw::weak_token_reason(token);
    check(why == gw::weak_token_reason(token));
    const std::set<char> distinct(token.begin(), token.end());
    if (distinct.size() < 8) check(!why.empty());
    if (lower(token).find("change-me") != std::string::npos) check(!why.empty());
    check(gw::hash_token(token) == gw::hash_token(token));
}

void tokens_file_text(std::string_view text) {
    if (!gw::holds_plain_tokens(text)) return;
    const auto j = nlohmann::json::parse(text, nullptr, false);
    check(!j.is_discarded());
    check(j.dump().find("\"token\"") != std::string::npos);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
    switch (data[0] % 3) {
        case 0:
            digest_reader(text);
            break;
        case 1:
            strength_verdict(text);
            break;
        default:
            tokens_file_text(text);
            break;
    }
    return 0;
}
