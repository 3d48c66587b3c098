#include "gateway/config/token_secret.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <openssl/evp.h>
#include <openssl/rand.h>
#include <set>
#include <stdexcept>

namespace gw {

token_digest hash_token(std::string_view token) {
    token_digest out{};
    unsigned int size = 0;
    if (EVP_Digest(token.data(), token.size(), out.data(), &size, EVP_sha256(), nullptr) != 1 ||
        size != out.size())
        throw std::runtime_error("SHA-256 is not available from OpenSSL");
    return out;
}

std::optional<token_digest> parse_token_digest(std::string_view hex) {
    if (hex.size() != 64) return std::nullopt;
    auto value = [](char c) -> int {
        if (c >= '0' && c <= '9') return c - '0';
        if (c >= 'a' && c <= 'f') return c - 'a' + 10;
        if (c >= 'A' && c <= 'F') return c - 'A' + 10;
        return -1;
    };
    token_digest out{};
    for (std::size_t i = 0; i < out.size(); ++i) {
        const int high = value(hex[2 * i]);
        const int low = value(hex[2 * i + 1]);
        if (high < 0 || low < 0) return std::nullopt;
        out[i] = static_cast<std::uint8_t>(high * 16 + low);
    }
    return out;
}

std::string to_hex(const token_digest& digest) {
    static constexpr char digits[] = "0123456789abcdef";
    std::string out;
    out.reserve(digest.size() * 2);
    for (auto byte : digest) {
        out += digits[byte >> 4];
        out += digits[byte & 0x0f];
    }
    return out;
}

std::string weak_token_reason(std::string_view token) {
    std::string lower(token);
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    for (std::string_view placeholder : {"change-me", "changeme", "example", "placeholder", "your-token"})
        if (lower.find(placeholder) != std::string::npos)
            return "is a placeholder (\"" + std::string(placeholder) +
                   "\"): make a token with `asi-gateway token new`";
    bool lower_case = false;
    bool upper_case = false;
    bool digit = false;
    bool other = false;
    for (unsigned char c : token) {
        lower_case |= std::islower(c) != 0;
        upper_case |= std::isupper(c) != 0;
        digit |= std::isdigit(c) != 0;
        other |= std::isalnum(c) == 0;
    }
    const int alphabet = (lower_case ? 26 : 0) + (upper_case ? 26 : 0) + (digit ? 10 : 0) + (other ? 32 : 0);
    const double bits = alphabet > 1 ? static_cast<double>(token.size()) * std::log2(alphabet) : 0.0;
    if (bits < 128)
        return "is too easy to guess (about " + std::to_string(static_cast<int>(bits)) +
               " bits; at least 128 are needed): make a token with `asi-gateway token new`";
    if (std::set<char>(token.begin(), token.end()).size() < 8)
        return "repeats too few characters: make a token with `asi-gateway token new`";
    return {};
}

std::string new_token() {
    std::array<unsigned char, 32> bytes{};
    if (RAND_bytes(bytes.data(), static_cast<int>(bytes.size())) != 1)
        throw std::runtime_error("the system's random source is not available");
    static constexpr char alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";
    std::string out;
    std::uint32_t bits = 0;
    int count = 0;
    for (auto byte : bytes) {
        bits = (bits << 8) | byte;
        count += 8;
        while (count >= 6) {
            count -= 6;
            out += alphabet[(bits >> count) & 0x3f];
        }
    }
    if (count > 0) out += alphabet[(bits << (6 - count)) & 0x3f];
    return out;
}

}  // namespace gw
