#include "gateway/storage/storage_path.hpp"

#include <map>

#include <gtest/gtest.h>

namespace gw {
namespace {

environment fake_environment(std::map<std::string, std::string> vars) {
    return [vars = std::move(vars)](const char* name) -> std::optional<std::string> {
        auto it = vars.find(name);
        if (it == vars.end() || it->second.empty()) return std::nullopt;
        return it->second;
    };
}

struct storage_case {
    const char* what;
    storage_path_inputs in;
    std::map<std::string, std::string> env;
    const char* expected;  // nullptr: an error
};

TEST(storage_path, resolution_order_and_forms) {
    const std::map<std::string, std::string> home{{"HOME", "/home/lab"}};
    const std::map<std::string, std::string> all{{"HOME", "/home/lab"},
                                                 {"XDG_STATE_HOME", "/xdg/state"},
                                                 {"STATE_DIRECTORY", "/var/lib/asi-gateway:/var/lib/other"}};
    const storage_case cases[] = {
        {"the flag wins", {"store", "cfg-store", "/etc/gw/gateway.json", "/srv"}, all, "/srv/store"},
        {"an absolute flag", {"/data/jobs/", "", "", "/srv"}, all, "/data/jobs"},
        {"a flag with dots", {"../jobs/./a", "", "", "/srv/run"}, all, "/srv/jobs/a"},
        {"the config file's path, relative to the file",
         {"", "data", "/etc/gw/gateway.json", "/srv"},
         all,
         "/etc/gw/data"},
        {"a relative config file", {"", "data", "conf/gateway.json", "/srv"}, all, "/srv/conf/data"},
        {"an absolute configured path", {"", "/var/jobs", "/etc/gw/gateway.json", "/srv"}, all, "/var/jobs"},
        {"systemd's state directory, its first entry", {"", "", "", "/"}, all, "/var/lib/asi-gateway"},
        {"XDG_STATE_HOME",
         {"", "", "", "/"},
         {{"HOME", "/home/lab"}, {"XDG_STATE_HOME", "/xdg/state"}},
         "/xdg/state/asi-gateway"},
        {"a relative XDG_STATE_HOME is ignored (XDG spec)",
         {"", "", "", "/"},
         {{"HOME", "/home/lab"}, {"XDG_STATE_HOME", "state"}},
         "/home/lab/.local/state/asi-gateway"},
        {"HOME", {"", "", "", "/srv"}, home, "/home/lab/.local/state/asi-gateway"},
        {"an empty variable counts as unset",
         {"", "", "", "/srv"},
         {{"HOME", "/h"}, {"STATE_DIRECTORY", ""}},
         "/h/.local/state/asi-gateway"},
        {"nothing to go by", {"", "", "", "/srv"}, {}, nullptr},
        {"a relative HOME is not a home", {"", "", "", "/srv"}, {{"HOME", "lab"}}, nullptr},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.what);
        auto r = resolve_storage_path(c.in, fake_environment(c.env));
        if (c.expected == nullptr) {
            ASSERT_FALSE(r);
            EXPECT_NE(r.error().message.find("--storage"), std::string::npos) << r.error().message;
        } else {
            ASSERT_TRUE(r) << r.error().message;
            EXPECT_EQ(*r, c.expected);
        }
    }
}

TEST(storage_path, the_process_environment_reads_real_variables) {
    ::setenv("GW_STORAGE_PATH_TEST", "x", 1);
    ::setenv("GW_STORAGE_PATH_EMPTY", "", 1);
    auto env = process_environment();
    EXPECT_EQ(env("GW_STORAGE_PATH_TEST"), "x");
    EXPECT_EQ(env("GW_STORAGE_PATH_EMPTY"), std::nullopt);
    EXPECT_EQ(env("GW_STORAGE_PATH_UNSET_0b1e"), std::nullopt);
}

}  // namespace
}  // namespace gw
