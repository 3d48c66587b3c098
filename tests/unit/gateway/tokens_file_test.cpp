// auth.tokens_file: tokens kept in a file of their own (gateway/config/tokens_file.hpp), read through
// load_config_file as the gateway does at start-up.
#include "gateway/config/tokens_file.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "gateway/config/config.hpp"
#include "gateway/config/secret_file_path.hpp"
#include "gateway/config/token_secret.hpp"

namespace gw {
namespace {

namespace fs = std::filesystem;

constexpr const char* operator_token = "kQ2v9TzX4mB7wR1yH8nL3pD6sF0gJ5cA";
constexpr const char* admin_token = "Zr7Yb2Lq9Wx4Ns1Pk6Jd3Hf8Tg5Mc0Va";

class tokens_file_test : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("gw-tokens-file-" + std::to_string(::getpid()));
        fs::create_directories(dir_);
    }
    void TearDown() override {
        fs::remove_all(dir_);
        ::unsetenv("CREDENTIALS_DIRECTORY");
    }
    std::string write(const std::string& name, const std::string& text, fs::perms mode) {
        const auto path = dir_ / name;
        std::ofstream(path) << text;
        fs::permissions(path, mode, fs::perm_options::replace);
        return path.string();
    }
    fs::path dir_;
};

constexpr auto private_mode = fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read;
constexpr auto public_mode = private_mode | fs::perms::others_read;

TEST_F(tokens_file_test, a_relative_file_is_read_from_the_configs_directory_and_adds_its_tokens) {
    const std::string hashed = to_hex(hash_token(admin_token));
    write("tokens.json",
          R"([{"name": "scheduler", "role": "operator", "token": ")" + std::string(operator_token) +
              R"("}, {"name": "root", "role": "admin", "token_sha256": ")" + hashed + R"("}])",
          private_mode);
    // Tokens only in the file still allow a non-loopback address.
    const auto config = write("gw.json",
                              R"({"http": {"listen_address": "0.0.0.0"},
                                  "auth": {"tokens_file": "tokens.json", "halt_role": "operator"}})",
                              public_mode);
    auto loaded = load_config_file(config);
    ASSERT_TRUE(loaded) << loaded.error();
    ASSERT_EQ(loaded->auth.tokens.size(), 2u);
    EXPECT_EQ(loaded->auth.tokens[0].name, "scheduler");
    EXPECT_EQ(loaded->auth.tokens[0].role, role::operator_);
    EXPECT_EQ(loaded->auth.tokens[0].digest, hash_token(operator_token));
    EXPECT_EQ(loaded->auth.tokens[1].role, role::admin);
    EXPECT_EQ(loaded->auth.tokens[1].digest, hash_token(admin_token));
    EXPECT_EQ(loaded->auth.halt_role, role::operator_);
}

TEST_F(tokens_file_test, plain_tokens_that_every_user_may_read_are_refused_hashes_are_not) {
    const auto plain =
        write("plain.json",
              R"([{"name": "s", "role": "operator", "token": ")" + std::string(operator_token) + R"("}])",
              public_mode);
    const auto config = write("gw.json", R"({"auth": {"tokens_file": "plain.json"}})", private_mode);
    auto loaded = load_config_file(config);
    ASSERT_FALSE(loaded);
    EXPECT_NE(loaded.error().find(plain + ": holds plain tokens and every user may read it"),
              std::string::npos)
        << loaded.error();

    write("plain.json",
          R"([{"name": "s", "role": "operator", "token_sha256": ")" + to_hex(hash_token(operator_token)) +
              R"("}])",
          public_mode);
    auto hashed = load_config_file(config);
    ASSERT_TRUE(hashed) << hashed.error();
    EXPECT_EQ(hashed->auth.tokens.size(), 1u);
}

TEST_F(tokens_file_test, credentials_directory_comes_from_systemd) {
    write("tokens", R"([{"name": "s", "token": ")" + std::string(operator_token) + R"("}])", private_mode);
    const auto config =
        write("gw.json", R"({"auth": {"tokens_file": "$CREDENTIALS_DIRECTORY/tokens"}})", private_mode);
    ::unsetenv("CREDENTIALS_DIRECTORY");
    auto unset = load_config_file(config);
    ASSERT_FALSE(unset);
    EXPECT_NE(unset.error().find("CREDENTIALS_DIRECTORY is not set"), std::string::npos) << unset.error();

    ::setenv("CREDENTIALS_DIRECTORY", dir_.c_str(), 1);
    auto loaded = load_config_file(config);
    ASSERT_TRUE(loaded) << loaded.error();
    EXPECT_EQ(loaded->auth.tokens.size(), 1u);
}

TEST_F(tokens_file_test, errors_name_the_file_and_the_entry) {
    const auto config = write("gw.json",
                              R"({"auth": {"tokens_file": "tokens.json",
                                  "tokens": [{"name": "s", "token": ")" +
                                  std::string(operator_token) + R"("}]}})",
                              private_mode);
    const auto tokens = (dir_ / "tokens.json").string();
    struct row {
        std::string file_text;  // empty: no file
        std::string error;
    };
    const row rows[] = {
        {"", tokens + ": No such file or directory"},
        {"{", tokens + ": not valid JSON"},
        {R"({"name": "x"})", "auth.tokens_file (" + tokens + "): must be an array"},
        {R"([{"role": "admin", "token": ")" + std::string(admin_token) + R"("}])",
         "auth.tokens_file (" + tokens + ")[0].name: required"},
        {R"([{"name": "s", "token": ")" + std::string(admin_token) + R"("}])",
         "auth.tokens_file (" + tokens + ")[0].name: duplicate name \"s\""},
        {R"([{"name": "t", "token": ")" + std::string(operator_token) + R"("}])",
         "auth.tokens_file (" + tokens + ")[0].token: the same token is given twice"},
        {R"([{"name": "t", "token": "change-me-admin-token"}])",
         "auth.tokens_file (" + tokens + ")[0].token: is a placeholder"},
    };
    for (const auto& r : rows) {
        fs::remove(tokens);
        if (!r.file_text.empty()) write("tokens.json", r.file_text, private_mode);
        auto loaded = load_config_file(config);
        ASSERT_FALSE(loaded) << r.file_text;
        EXPECT_NE(loaded.error().find(r.error), std::string::npos) << loaded.error();
    }
}

TEST(secret_file_path, resolves_credentials_relative_and_absolute_paths) {
    const auto resolve = [](std::string_view given, std::string_view dir, std::optional<std::string> cred) {
        return resolve_secret_file_path("auth.tokens_file", given, dir, std::move(cred));
    };
    EXPECT_EQ(*resolve("/etc/x.json", "/cfg", std::nullopt), "/etc/x.json");
    EXPECT_EQ(*resolve("x.json", "/cfg", std::nullopt), "/cfg/x.json");
    EXPECT_EQ(*resolve("x.json", "", std::nullopt), "x.json");
    EXPECT_EQ(*resolve("$CREDENTIALS_DIRECTORY/t", "/cfg", "/run/credentials/u"), "/run/credentials/u/t");
    EXPECT_FALSE(resolve("$CREDENTIALS_DIRECTORYt", "/cfg", "/run/c"));
    const auto unset = resolve("$CREDENTIALS_DIRECTORY/t", "/cfg", "");
    ASSERT_FALSE(unset);
    EXPECT_NE(unset.error().message.find("auth.tokens_file"), std::string::npos);
}

TEST(tokens_file_path, plain_tokens_are_found_in_any_entry) {
    EXPECT_TRUE(holds_plain_tokens(R"([{"name": "a", "token_sha256": "00"}, {"name": "b", "token": "x"}])"));
    EXPECT_FALSE(holds_plain_tokens(R"([{"name": "a", "token_sha256": "00"}])"));
    EXPECT_FALSE(holds_plain_tokens("not json"));
}

}  // namespace
}  // namespace gw
