#pragma once
// Reading a job spec's fields strictly: every error is invalid_value whose `field` is the JSON path
// inside the spec ("spec.slow.lines"), with a message that names the field and the allowed values.
// Shared by the job types' spec parsers. Pure.

#include <string>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"

namespace gw::jobs {

operation_error spec_error(const std::string& field, std::string message);

// A finite number in [lo, hi].
operation_result<double> spec_number(const nlohmann::json& v, const std::string& field, double lo, double hi);
// An integer (no fraction) in [lo, hi].
operation_result<int> spec_integer(const nlohmann::json& v, const std::string& field, long long lo,
                                   long long hi);
operation_result<std::string> spec_text(const nlohmann::json& v, const std::string& field);

}  // namespace gw::jobs
