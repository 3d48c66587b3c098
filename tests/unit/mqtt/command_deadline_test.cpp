// An MQTT command's deadline (api/mqtt/command_deadline.hpp): the earliest of what it carries.
#include "api/mqtt/command_deadline.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

using namespace std::chrono_literals;

struct deadline_case {
    std::string what;
    command_times times;
    std::optional<std::int64_t> at_ms;
    std::string source;
};

TEST(command_deadline, the_earliest_of_what_the_command_carries) {
    const std::int64_t received = 1'000'000;
    const std::vector<deadline_case> cases = {
        {"nothing: no deadline", {received, {}, {}, {}}, std::nullopt, ""},
        {"message expiry counts from receipt", {received, 5, {}, {}}, received + 5000, "message expiry"},
        {"an expiry of 0 left: due now", {received, 0, {}, {}}, received, "message expiry"},
        {"not_after as given", {received, {}, received - 1, {}}, received - 1, "not_after"},
        {"a signed ts plus max_age",
         {received, {}, {}, received - 4000},
         received + 6000,
         "ts + mqtt.commands.max_age_s"},
        {"not_after before expiry", {received, 60, received + 2000, {}}, received + 2000, "not_after"},
        {"expiry before not_after", {received, 1, received + 2000, {}}, received + 1000, "message expiry"},
        {"ts + max_age before not_after",
         {received, {}, received + 20'000, received},
         received + 10'000,
         "ts + mqtt.commands.max_age_s"},
        {"a large expiry does not overflow",
         {received, 4'294'967'295u, {}, {}},
         received + std::int64_t{4'294'967'295} * 1000,
         "message expiry"},
    };
    for (const auto& c : cases) {
        const auto d = earliest_deadline(c.times, 10s);
        ASSERT_EQ(d.has_value(), c.at_ms.has_value()) << c.what;
        if (!d) continue;
        EXPECT_EQ(d->at_ms, *c.at_ms) << c.what;
        EXPECT_EQ(d->source, c.source) << c.what;
    }
}

}  // namespace
}  // namespace gw::api
