#include "gateway/common/timestamp.hpp"

#include <string>

namespace gw {

std::int64_t epoch_ms(std::chrono::system_clock::time_point t) {
    return std::chrono::floor<std::chrono::milliseconds>(t.time_since_epoch()).count();
}

namespace {

// Writes `value` as exactly `digits` decimal digits, zero-padded, ending just before `end`.
void put_digits(char* end, unsigned value, int digits) {
    for (int i = 0; i < digits; ++i) {
        *--end = static_cast<char>('0' + value % 10);
        value /= 10;
    }
}

}  // namespace

std::string format_timestamp(std::chrono::system_clock::time_point t) {
    using namespace std::chrono;
    auto ms = floor<milliseconds>(t);
    auto day = floor<days>(ms);
    year_month_day ymd{day};
    hh_mm_ss hms{ms - day};
    // A system_clock time point (nanoseconds in 64 bits) lies within the years 1677..2262: always four
    // digits.
    const int year = static_cast<int>(ymd.year());
    // Every event carries one or two of these: written digit by digit, not through printf's parser.
    std::string out = "0000-00-00T00:00:00.000Z";
    char* buf = out.data();
    put_digits(buf + 4, static_cast<unsigned>(year), 4);
    put_digits(buf + 7, static_cast<unsigned>(ymd.month()), 2);
    put_digits(buf + 10, static_cast<unsigned>(ymd.day()), 2);
    put_digits(buf + 13, static_cast<unsigned>(hms.hours().count()), 2);
    put_digits(buf + 16, static_cast<unsigned>(hms.minutes().count()), 2);
    put_digits(buf + 19, static_cast<unsigned>(hms.seconds().count()), 2);
    put_digits(buf + 23, static_cast<unsigned>(hms.subseconds().count()), 3);
    return out;
}

}  // namespace gw
