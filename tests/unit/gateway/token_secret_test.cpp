// Tokens kept as hashes: SHA-256 as published, the config's hex form, what counts as too weak, and
// the tokens `asi-gateway token new` makes.
#include "gateway/config/token_secret.hpp"

#include <set>
#include <string>

#include <gtest/gtest.h>

namespace gw {
namespace {

TEST(token_secret, hashes_are_sha256) {
    // FIPS 180-2's test vector, and the empty string.
    EXPECT_EQ(to_hex(hash_token("abc")), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    EXPECT_EQ(to_hex(hash_token("")), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

TEST(token_secret, digests_parse_from_64_hex_digits_only) {
    const auto d = hash_token("viewer-token-0123456789");
    EXPECT_EQ(parse_token_digest(to_hex(d)), d);
    std::string upper = to_hex(d);
    for (auto& c : upper)
        c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    EXPECT_EQ(parse_token_digest(upper), d);
    EXPECT_FALSE(parse_token_digest(""));
    EXPECT_FALSE(parse_token_digest(to_hex(d).substr(1)));
    EXPECT_FALSE(parse_token_digest(to_hex(d) + "0"));
    EXPECT_FALSE(parse_token_digest(std::string(63, '0') + "g"));
    EXPECT_FALSE(parse_token_digest(std::string(62, '0') + " 0"));
}

TEST(token_secret, weak_tokens_are_named) {
    for (const char* weak :
         {"change-me-admin-token", "CHANGEME0123456789abcdefghijkl", "example-token-0123456789", "short",
          "0123456789abcdef", "aaaaaaaaaaaaaaaaaaaaaaaaa", "abababababababababababababababab", ""})
        EXPECT_FALSE(weak_token_reason(weak).empty()) << weak;
    for (const char* strong : {"viewer-token-0123456789", "Tok-0123456789abcdef",
                               "0123456789abcdef0123456789abcdef"})  // 32 hex digits: 128 bits
        EXPECT_EQ(weak_token_reason(strong), "") << strong;
}

TEST(token_secret, new_tokens_are_256_random_bits_in_base64url) {
    std::set<std::string> seen;
    for (int i = 0; i < 20; ++i) {
        const auto t = new_token();
        EXPECT_EQ(t.size(), 43u) << t;
        EXPECT_EQ(t.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_"),
                  std::string::npos)
            << t;
        EXPECT_EQ(weak_token_reason(t), "") << t;
        seen.insert(t);
    }
    EXPECT_EQ(seen.size(), 20u);
}

}  // namespace
}  // namespace gw
