#pragma once
// The one reader of typed JSON values: a number in a range, an integer, a text. The config file
// (gateway/config) and the job specs (jobs/kinds/spec_fields) read their fields through it and say
// what is wrong in their own words (the config names the key path, a spec the field). Pure.
//
//   auto port = read_unsigned(j, 0, 65535);
//   if (!port) return complain(port.fault);  // wrong_type or out_of_range
//   use(*port.value);

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace gw {

// Why a value was not read.
enum class json_fault : std::uint8_t {
    wrong_type,         // not the JSON type asked for (a string for a number, 1.5 for an integer)
    out_of_range,       // the right type, outside [lo, hi]
    empty,              // an empty text where one is needed
    control_character,  // a text with a byte below 0x20 or 0x7F
};

template <typename T>
struct json_read {
    std::optional<T> value;  // empty: `fault` says why
    json_fault fault = json_fault::wrong_type;
    explicit operator bool() const { return value.has_value(); }
};

// A finite number in [lo, hi].
json_read<double> read_number(const nlohmann::json& v, double lo, double hi);
// An integer in [lo, hi], as JSON Schema counts integers: 20.0 is one (some clients write every number
// as a float), 20.5 is not.
json_read<long long> read_integer(const nlohmann::json& v, long long lo, long long hi);
// A whole number written without a sign or fraction ("20", not "20.0" or "-1"), in [lo, hi].
json_read<std::uint64_t> read_unsigned(const nlohmann::json& v, std::uint64_t lo, std::uint64_t hi);

struct text_rules {
    bool allow_empty = true;
    bool allow_control = true;  // bytes below 0x20 and 0x7F
};
json_read<std::string> read_text(const nlohmann::json& v, text_rules rules = {});

}  // namespace gw
