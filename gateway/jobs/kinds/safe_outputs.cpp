#include "gateway/jobs/kinds/safe_outputs.hpp"

namespace gw::jobs {

bool may_leave_ttl_output_high(job_type type, const nlohmann::json& spec) {
    switch (type) {
        case job_type::gcode:
            return true;
        case job_type::array: {
            if (!spec.is_object()) return false;
            const auto it = spec.find("ttl_pulse");
            return it != spec.end() && it->is_boolean() && it->get<bool>();
        }
        case job_type::scan:
        case job_type::ring_buffer:
        case job_type::planar_correction:
            return false;
    }
    return false;
}

std::string safe_output_request_id(const std::string& job_id) {
    return "recovery-" + job_id;
}

}  // namespace gw::jobs
