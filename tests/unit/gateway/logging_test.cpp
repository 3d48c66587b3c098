#include "gateway/config/logging.hpp"

#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

namespace gw {
namespace {

using namespace std::chrono_literals;

TEST(logging, json_line_is_one_object_with_time_level_logger_message) {
    const auto t = std::chrono::system_clock::time_point(std::chrono::seconds(1'700'000'000)) + 42ms;
    const auto line = format_json_line(t, "info", "ms2000.stage1", "said \"hi\"\\\n\tand\x01 left");
    ASSERT_FALSE(line.empty());
    EXPECT_EQ(line.back(), '\n');
    EXPECT_EQ(line.find('\n'), line.size() - 1);  // exactly one line
    const auto j = nlohmann::json::parse(line);
    EXPECT_EQ(j.size(), 4u);
    EXPECT_EQ(j.at("time"), "2023-11-14T22:13:20.042Z");
    EXPECT_EQ(j.at("level"), "info");
    EXPECT_EQ(j.at("logger"), "ms2000.stage1");
    EXPECT_EQ(j.at("message"), "said \"hi\"\\\n\tand\x01 left");
}

TEST(logging, effective_level_prefers_the_most_specific_entry) {
    logging_config c;
    c.level = log_level::warn;
    c.levels["ms2000"] = log_level::debug;
    c.levels["ms2000.stage2"] = log_level::error;
    c.levels["api"] = log_level::trace;
    EXPECT_EQ(effective_level(c, "gateway"), log_level::warn);
    EXPECT_EQ(effective_level(c, "api"), log_level::trace);
    EXPECT_EQ(effective_level(c, "ms2000.stage1"), log_level::debug);
    EXPECT_EQ(effective_level(c, "ms2000.stage2"), log_level::error);
    EXPECT_EQ(to_spdlog(log_level::error), spdlog::level::err);
    EXPECT_EQ(to_spdlog(log_level::off), spdlog::level::off);
}

TEST(logging, setup_writes_json_lines_with_per_logger_levels) {
    std::ostringstream out;
    logging_config c;
    c.level = log_level::info;
    c.format = log_format::json;
    c.levels["ms2000"] = log_level::debug;
    c.levels["jobs"] = log_level::off;
    setup_logging(c, std::make_shared<spdlog::sinks::ostream_sink_mt>(out));

    get_logger("gateway")->info("hello {}", 1);
    get_logger("gateway")->debug("hidden");          // below info
    get_logger("ms2000.unit-a")->debug("trace me");  // created now, with the ms2000 level
    get_logger("jobs")->error("silenced");
    spdlog::default_logger()->flush();

    std::istringstream lines(out.str());
    std::vector<nlohmann::json> parsed;
    for (std::string line; std::getline(lines, line);)
        parsed.push_back(nlohmann::json::parse(line));
    ASSERT_EQ(parsed.size(), 2u) << out.str();
    EXPECT_EQ(parsed[0].at("logger"), "gateway");
    EXPECT_EQ(parsed[0].at("message"), "hello 1");
    EXPECT_EQ(parsed[0].at("level"), "info");
    EXPECT_EQ(parsed[1].at("logger"), "ms2000.unit-a");
    EXPECT_EQ(parsed[1].at("level"), "debug");

    setup_logging(logging_config{});  // back to text on stdout for the other tests
}

TEST(logging, text_format_names_the_logger) {
    std::ostringstream out;
    logging_config c;
    setup_logging(c, std::make_shared<spdlog::sinks::ostream_sink_mt>(out));
    get_logger("api")->warn("careful");
    EXPECT_NE(out.str().find("[api] careful"), std::string::npos) << out.str();
    EXPECT_NE(out.str().find("[warning]"), std::string::npos) << out.str();
    setup_logging(logging_config{});
}

TEST(logging, keyed_limiter_limits_each_key_on_its_own) {
    keyed_log_limiter limiter(std::chrono::hours(1));
    std::uint64_t suppressed = 0;
    int passed_a = 0;
    for (int i = 0; i < 16; ++i)
        passed_a += limiter.allow("stage1/timeout", suppressed) ? 1 : 0;
    EXPECT_EQ(passed_a, 5);     // 1st, 2nd, 4th, 8th, 16th
    EXPECT_EQ(suppressed, 7u);  // the 9th..15th, reported with the 16th
    EXPECT_TRUE(limiter.allow("stage2/timeout", suppressed));
    EXPECT_EQ(suppressed, 0u);
}

}  // namespace
}  // namespace gw
