#include "gateway/common/job_id.hpp"

#include <chrono>
#include <mutex>
#include <random>

namespace gw::jobs {

namespace {

constexpr std::string_view crockford = "0123456789ABCDEFGHJKMNPQRSTVWXYZ";

int crockford_value(char c) {
    auto pos = crockford.find(c);
    return pos == std::string_view::npos ? -1 : static_cast<int>(pos);
}

// 80 random bits, most significant byte first; returns false on overflow (all ones).
bool increment(std::array<std::uint8_t, 10>& r) {
    for (auto i = r.size(); i-- > 0;) {
        if (++r[i] != 0) return true;
    }
    return false;
}

std::array<std::uint8_t, 10> random_bits(std::random_device& rd) {
    std::array<std::uint8_t, 10> r{};
    for (std::size_t i = 0; i < r.size(); i += 2) {
        auto v = rd();
        r[i] = static_cast<std::uint8_t>(v);
        r[i + 1] = static_cast<std::uint8_t>(v >> 8);
    }
    return r;
}

}  // namespace

std::string format_job_id(std::uint64_t epoch_ms, const std::array<std::uint8_t, 10>& random) {
    std::string id = "j-";
    id.reserve(job_id_length);
    epoch_ms &= (std::uint64_t{1} << 48) - 1;
    // 10 characters of 5 bits = 50 bits: the first character holds the top 3 of 48 bits.
    for (int shift = 45; shift >= 0; shift -= 5)
        id.push_back(crockford[(epoch_ms >> shift) & 31]);
    // 80 bits = 16 characters of 5 bits: take them 40 bits (5 bytes) at a time.
    for (std::size_t half = 0; half < 2; ++half) {
        std::uint64_t v = 0;
        for (std::size_t i = 0; i < 5; ++i)
            v = (v << 8) | random[half * 5 + i];
        for (int shift = 35; shift >= 0; shift -= 5)
            id.push_back(crockford[(v >> shift) & 31]);
    }
    return id;
}

std::string make_job_id() {
    static std::mutex mutex;
    static std::random_device rd;
    static std::uint64_t last_ms = 0;
    static std::array<std::uint8_t, 10> last_random{};

    auto now = std::chrono::duration_cast<std::chrono::milliseconds>(
                   std::chrono::system_clock::now().time_since_epoch())
                   .count();
    auto ms = static_cast<std::uint64_t>(now < 0 ? 0 : now);
    std::lock_guard lock(mutex);
    // Same millisecond, or the clock went back: count up from the last id so ids keep increasing.
    if (ms <= last_ms) {
        if (!increment(last_random)) {
            ++last_ms;
            last_random = random_bits(rd);
        }
    } else {
        last_ms = ms;
        last_random = random_bits(rd);
    }
    return format_job_id(last_ms, last_random);
}

bool is_job_id(std::string_view s) {
    if (s.size() != job_id_length || !s.starts_with("j-")) return false;
    for (auto c : s.substr(2))
        if (crockford_value(c) < 0) return false;
    return crockford_value(s[2]) <= 7;
}

std::optional<std::uint64_t> job_id_time_ms(std::string_view s) {
    if (!is_job_id(s)) return std::nullopt;
    std::uint64_t ms = 0;
    for (auto c : s.substr(2, 10))
        ms = (ms << 5) | static_cast<std::uint64_t>(crockford_value(c));
    return ms;
}

std::string make_lease_id() {
    static std::mutex mutex;
    static std::random_device rd;
    constexpr std::string_view hex = "0123456789abcdef";
    std::string id = "l-";
    std::lock_guard lock(mutex);
    for (int i = 0; i < 4; ++i) {
        auto v = rd();
        for (int shift = 28; shift >= 0; shift -= 4)
            id.push_back(hex[(v >> shift) & 15]);
    }
    return id;
}

}  // namespace gw::jobs
