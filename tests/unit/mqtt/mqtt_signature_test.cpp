// Signed MQTT commands (api/mqtt/mqtt_signature.hpp): the HMAC against RFC 4231, the envelope's
// reader and the signed text.
#include "api/mqtt/mqtt_signature.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

std::vector<std::uint8_t> bytes(std::string_view s) {
    return {s.begin(), s.end()};
}

TEST(mqtt_signature, hmac_sha256_matches_rfc_4231) {
    // RFC 4231, test case 2.
    EXPECT_EQ(hmac_sha256_hex(bytes("Jefe"), "what do ya want for nothing?"),
              "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
    const auto key = bytes("Jefe");
    EXPECT_TRUE(signature_matches(key, "what do ya want for nothing?",
                                  "5BDCC146BF60754E6A042426089575C75A003F089D2739839DEC58B964EC3843"));
    EXPECT_FALSE(signature_matches(key, "what do ya want for nothing!",
                                   "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843"));
    EXPECT_FALSE(signature_matches(key, "what do ya want for nothing?", "5bdcc146"));
}

TEST(mqtt_signature, the_signed_text_is_topic_ts_nonce_and_body_one_per_line) {
    EXPECT_EQ(
        signing_text("asi/lab/controllers/sim1/cmd", 1764921600123, "n0nce-01", R"({"operation":"halt"})"),
        "asi/lab/controllers/sim1/cmd\n1764921600123\nn0nce-01\n{\"operation\":\"halt\"}");
}

TEST(mqtt_signature, reads_the_envelope_and_refuses_what_is_not_one) {
    const std::string sig(64, 'a');
    auto ok = read_signed_command(R"({"key":"k","ts":5,"nonce":"abcdefgh","sig":")" + sig +
                                  R"(","body":"{\"operation\":\"halt\"}"})");
    ASSERT_TRUE(ok) << ok.error();
    EXPECT_EQ(ok->key, "k");
    EXPECT_EQ(ok->ts_ms, 5);
    EXPECT_EQ(ok->nonce, "abcdefgh");
    EXPECT_EQ(ok->body, R"({"operation":"halt"})");
    struct row {
        std::string payload;
        std::string error;
    };
    const row rows[] = {
        {"[1]", "a signed command is not a JSON object"},
        {R"({"key":"k","ts":5,"nonce":"abcdefgh","sig":")" + sig + R"(","body":"{}","token":"t"})",
         "a signed command has an unknown key \"token\""},
        {R"({"ts":5,"nonce":"abcdefgh","sig":")" + sig + R"(","body":"{}"})", "\"key\" is not a key name"},
        {R"({"key":"k","ts":"5","nonce":"abcdefgh","sig":")" + sig + R"(","body":"{}"})",
         "\"ts\" is not an integer"},
        {R"({"key":"k","ts":5,"nonce":"short","sig":")" + sig + R"(","body":"{}"})", "\"nonce\" is not 8-64"},
        {R"({"key":"k","ts":5,"nonce":"abc defgh","sig":")" + sig + R"(","body":"{}"})",
         "\"nonce\" is not 8-64"},
        {R"({"key":"k","ts":5,"nonce":"abcdefgh","sig":"xyz","body":"{}"})", "\"sig\" is not 64 hexadecimal"},
        {R"({"key":"k","ts":5,"nonce":"abcdefgh","sig":")" + sig + R"(","body":{}})",
         "\"body\" is not a string"},
    };
    for (const auto& r : rows) {
        auto parsed = read_signed_command(r.payload);
        ASSERT_FALSE(parsed) << r.payload;
        EXPECT_TRUE(parsed.error().starts_with(r.error)) << parsed.error();
    }
}

TEST(mqtt_signature, a_signed_payload_is_told_from_a_bearer_one) {
    EXPECT_TRUE(looks_signed(R"({"key":"k","sig":"00"})"));
    EXPECT_TRUE(looks_signed(R"({"body":"{}","nonce":"abcdefgh","sig":"00","key":"k"})"));
    EXPECT_FALSE(looks_signed(R"({"operation":"halt","token":"t"})"));
    // "sig" deeper down, or in a string, is a bearer payload's business.
    EXPECT_FALSE(looks_signed(R"({"operation":"command","args":{"sig":1},"token":"t"})"));
    EXPECT_FALSE(looks_signed(R"({"operation":"command","args":{"command":""sig""},"token":"t"})"));
    EXPECT_FALSE(looks_signed(R"([{"sig":1}])"));
    EXPECT_FALSE(looks_signed("not json"));
}

}  // namespace
}  // namespace gw::api
