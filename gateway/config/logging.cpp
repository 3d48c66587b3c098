#include "gateway/config/logging.hpp"

#include <ctime>
#include <vector>

#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

namespace gw {

namespace {

std::mutex config_mutex;
logging_config current_config;  // guarded by config_mutex

constexpr const char* text_pattern = "[%Y-%m-%d %H:%M:%S.%e] [%^%l%$] [%n] %v";

void append_json_string(std::string& out, std::string_view s) {
    out += '"';
    for (const char ch : s) {
        const auto c = static_cast<unsigned char>(ch);
        switch (ch) {
            case '"':
                out += "\\\"";
                break;
            case '\\':
                out += "\\\\";
                break;
            case '\n':
                out += "\\n";
                break;
            case '\r':
                out += "\\r";
                break;
            case '\t':
                out += "\\t";
                break;
            default:
                if (c < 0x20 || c == 0x7f) {
                    constexpr char hex[] = "0123456789abcdef";
                    out += "\\u00";
                    out += hex[c >> 4];
                    out += hex[c & 0xf];
                } else {
                    out += ch;
                }
        }
    }
    out += '"';
}

}  // namespace

spdlog::level::level_enum to_spdlog(log_level level) {
    switch (level) {
        case log_level::trace:
            return spdlog::level::trace;
        case log_level::debug:
            return spdlog::level::debug;
        case log_level::info:
            return spdlog::level::info;
        case log_level::warn:
            return spdlog::level::warn;
        case log_level::error:
            return spdlog::level::err;
        case log_level::critical:
            return spdlog::level::critical;
        case log_level::off:
            return spdlog::level::off;
    }
    return spdlog::level::info;
}

log_level effective_level(const logging_config& config, std::string_view name) {
    if (auto it = config.levels.find(std::string(name)); it != config.levels.end()) return it->second;
    if (auto dot = name.find('.'); dot != std::string_view::npos) {
        if (auto it = config.levels.find(std::string(name.substr(0, dot))); it != config.levels.end())
            return it->second;
    }
    return config.level;
}

std::string format_json_line(std::chrono::system_clock::time_point time, std::string_view level,
                             std::string_view logger, std::string_view message) {
    using namespace std::chrono;
    const auto secs = time_point_cast<seconds>(time);
    auto millis = duration_cast<milliseconds>(time - secs).count();
    if (millis < 0) millis += 1000;
    const std::time_t t = system_clock::to_time_t(secs);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char stamp[40];
    std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%S", &tm);
    std::string out;
    out.reserve(96 + message.size());
    out += "{\"time\":\"";
    out += stamp;
    out += fmt::format(".{:03}Z\",\"level\":", millis);
    append_json_string(out, level);
    out += ",\"logger\":";
    append_json_string(out, logger);
    out += ",\"message\":";
    append_json_string(out, message);
    out += "}\n";
    return out;
}

void json_formatter::format(const spdlog::details::log_msg& msg, spdlog::memory_buf_t& dest) {
    const auto level = spdlog::level::to_string_view(msg.level);
    const auto line = format_json_line(msg.time, std::string_view(level.data(), level.size()),
                                       std::string_view(msg.logger_name.data(), msg.logger_name.size()),
                                       std::string_view(msg.payload.data(), msg.payload.size()));
    dest.append(line.data(), line.data() + line.size());
}

std::unique_ptr<spdlog::formatter> json_formatter::clone() const {
    return std::make_unique<json_formatter>();
}

void setup_logging(const logging_config& config, std::shared_ptr<spdlog::sinks::sink> sink) {
    if (!sink) {
        if (config.format == log_format::json)
            sink = std::make_shared<spdlog::sinks::stdout_sink_mt>();
        else
            sink = std::make_shared<spdlog::sinks::stdout_color_sink_mt>();
    }
    if (config.format == log_format::json)
        sink->set_formatter(std::make_unique<json_formatter>());
    else
        sink->set_formatter(std::make_unique<spdlog::pattern_formatter>(text_pattern));
    sink->set_level(spdlog::level::trace);  // levels are per logger

    {
        std::lock_guard lock(config_mutex);
        current_config = config;
    }
    spdlog::drop_all();
    auto fallback = std::make_shared<spdlog::logger>("", sink);
    fallback->set_level(to_spdlog(config.level));
    fallback->flush_on(spdlog::level::warn);
    spdlog::set_default_logger(fallback);
    for (const char* area : {"gateway", "api", "jobs", "mqtt"})
        get_logger(area);
}

std::shared_ptr<spdlog::logger> get_logger(const std::string& name) {
    if (auto existing = spdlog::get(name)) return existing;
    log_level level;
    {
        std::lock_guard lock(config_mutex);
        level = effective_level(current_config, name);
    }
    const auto fallback = spdlog::default_logger();
    auto logger = std::make_shared<spdlog::logger>(name, fallback->sinks().begin(), fallback->sinks().end());
    logger->set_level(to_spdlog(level));
    logger->flush_on(spdlog::level::warn);
    try {
        spdlog::register_logger(logger);
    } catch (const spdlog::spdlog_ex&) {
        if (auto existing = spdlog::get(name)) return existing;  // another thread registered it first
    }
    return logger;
}

bool keyed_log_limiter::allow(const std::string& key, std::uint64_t& suppressed) {
    std::lock_guard lock(mutex_);
    auto it = limiters_.find(key);
    if (it == limiters_.end()) it = limiters_.emplace(key, devices::log_limiter(interval_)).first;
    return it->second.allow(std::chrono::steady_clock::now(), suppressed);
}

}  // namespace gw
