#include "api/mqtt/mqtt_signature.hpp"

#include <algorithm>
#include <array>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include <nlohmann/json.hpp>

namespace gw::api {

namespace {

using json = nlohmann::json;
using result = boost::system::result<signed_command, std::string>;

result refuse(std::string why) {
    return result(boost::system::in_place_error, std::move(why));
}

bool valid_nonce(std::string_view nonce) {
    return nonce.size() >= 8 && nonce.size() <= 64 && std::all_of(nonce.begin(), nonce.end(), [](char c) {
               return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '-' || c == '_';
           });
}

bool is_hex(char c) {
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}

char lower_hex(char c) {
    return (c >= 'A' && c <= 'F') ? static_cast<char>(c - 'A' + 'a') : c;
}

const std::string* string_field(const json& j, const char* name) {
    const auto it = j.find(name);
    return it != j.end() && it->is_string() ? &it->get_ref<const std::string&>() : nullptr;
}

}  // namespace

namespace {

// Reads a JSON text until it knows whether the top-level object has a "sig" key: nothing is built, and
// the scan stops at that key (the rest of a large body is not read twice).
class top_level_sig_finder : public nlohmann::json_sax<json> {
  public:
    bool found = false;

    bool key(string_t& k) override {
        if (depth_ == 1 && k == "sig") found = true;
        return !found;
    }
    bool start_object(std::size_t) override { return ++depth_ > 0; }
    bool end_object() override { return --depth_ >= 0; }
    bool start_array(std::size_t) override { return ++depth_ > 0; }
    bool end_array() override { return --depth_ >= 0; }
    bool null() override { return true; }
    bool boolean(bool) override { return true; }
    bool number_integer(number_integer_t) override { return true; }
    bool number_unsigned(number_unsigned_t) override { return true; }
    bool number_float(number_float_t, const string_t&) override { return true; }
    bool string(string_t&) override { return true; }
    bool binary(binary_t&) override { return true; }
    bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override {
        return false;
    }

  private:
    int depth_ = 0;
};

}  // namespace

bool looks_signed(std::string_view payload) {
    top_level_sig_finder finder;
    json::sax_parse(payload, &finder);
    return finder.found;
}

result read_signed_command(std::string_view payload) {
    const json j = json::parse(payload, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded() || !j.is_object()) return refuse("a signed command is not a JSON object");
    for (const auto& item : j.items())
        if (item.key() != "key" && item.key() != "ts" && item.key() != "nonce" && item.key() != "sig" &&
            item.key() != "body")
            return refuse("a signed command has an unknown key \"" + item.key().substr(0, 32) +
                          "\" (key, ts, nonce, sig, body; the command goes in body)");
    signed_command c;
    const auto* key = string_field(j, "key");
    if (!key || key->empty() || key->size() > 64) return refuse("\"key\" is not a key name");
    c.key = *key;
    const auto ts = j.find("ts");
    if (ts == j.end() || !ts->is_number_integer())
        return refuse("\"ts\" is not an integer (ms since the epoch)");
    c.ts_ms = ts->get<std::int64_t>();
    const auto* nonce = string_field(j, "nonce");
    if (!nonce || !valid_nonce(*nonce)) return refuse("\"nonce\" is not 8-64 characters of [A-Za-z0-9_-]");
    c.nonce = *nonce;
    const auto* sig = string_field(j, "sig");
    if (!sig || sig->size() != 64 || !std::all_of(sig->begin(), sig->end(), is_hex))
        return refuse("\"sig\" is not 64 hexadecimal digits");
    c.sig = *sig;
    const auto* body = string_field(j, "body");
    if (!body) return refuse("\"body\" is not a string (the command's JSON text)");
    c.body = *body;
    return c;
}

std::string signing_text(std::string_view topic, std::int64_t ts_ms, std::string_view nonce,
                         std::string_view body) {
    std::string text;
    text.reserve(topic.size() + nonce.size() + body.size() + 24);
    text.append(topic).append("\n").append(std::to_string(ts_ms)).append("\n").append(nonce).append("\n");
    text.append(body);
    return text;
}

std::string hmac_sha256_hex(const std::vector<std::uint8_t>& key, std::string_view text) {
    std::array<unsigned char, EVP_MAX_MD_SIZE> mac{};
    unsigned int size = 0;
    HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()),
         reinterpret_cast<const unsigned char*>(text.data()), text.size(), mac.data(), &size);
    static constexpr char digits[] = "0123456789abcdef";
    std::string hex;
    hex.reserve(std::size_t{size} * 2);
    for (unsigned int i = 0; i < size; ++i) {
        hex.push_back(digits[mac[i] >> 4]);
        hex.push_back(digits[mac[i] & 0x0f]);
    }
    return hex;
}

bool signature_matches(const std::vector<std::uint8_t>& key, std::string_view text, std::string_view sig) {
    const auto expected = hmac_sha256_hex(key, text);
    if (sig.size() != expected.size()) return false;
    std::string given(sig);
    std::transform(given.begin(), given.end(), given.begin(), lower_hex);
    return CRYPTO_memcmp(given.data(), expected.data(), expected.size()) == 0;
}

}  // namespace gw::api
