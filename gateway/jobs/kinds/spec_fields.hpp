#pragma once
// Reading a job spec's fields strictly: every error is invalid_value whose `field` is the JSON path
// inside the spec ("spec.slow.lines"), with a message that names the field and the allowed values.
// Shared by the job types' spec parsers. Pure.

#include <initializer_list>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"

namespace gw::jobs {

operation_error spec_error(const std::string& field, std::string message);

// Every key of `object` is one of `known`; else "unknown field <prefix><key>" (prefix "fast." for a
// nested object).
operation_result<void> spec_known_fields(const nlohmann::json& object, const std::string& prefix,
                                         std::initializer_list<std::string_view> known);

// A finite number in [lo, hi] (gateway/common/json_value reads them all).
operation_result<double> spec_number(const nlohmann::json& v, const std::string& field, double lo, double hi);
// An integer (no fraction) in [lo, hi].
operation_result<int> spec_integer(const nlohmann::json& v, const std::string& field, int lo, int hi);
operation_result<std::string> spec_text(const nlohmann::json& v, const std::string& field);

}  // namespace gw::jobs
