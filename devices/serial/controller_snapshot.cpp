#include "devices/serial/controller_snapshot.hpp"

namespace gw::devices {

std::string_view to_string(connection_state s) {
    switch (s) {
        case connection_state::stopped:
            return "stopped";
        case connection_state::disconnected:
            return "disconnected";
        case connection_state::identifying:
            return "identifying";
        case connection_state::connected:
            return "connected";
        case connection_state::connecting:
            return "connecting";
        case connection_state::unreachable:
            return "unreachable";
    }
    return "unknown";
}

std::string_view to_string(report_port_state s) {
    switch (s) {
        case report_port_state::none:
            return "none";
        case report_port_state::closed:
            return "closed";
        case report_port_state::open:
            return "open";
    }
    return "unknown";
}

const axis_state* controller_snapshot::axis(char letter) const {
    for (const auto& a : axes)
        if (a.axis == letter) return &a;
    return nullptr;
}

std::string controller_snapshot::motor_axes() const {
    std::string letters;
    for (const auto& a : axes)
        letters += a.axis;
    return letters;
}

namespace {

bool same_identity(const std::optional<controller_identity>& a, const std::optional<controller_identity>& b) {
    if (a.has_value() != b.has_value()) return false;
    if (!a) return true;
    return a->version == b->version && a->version_raw == b->version_raw && a->build.name == b->build.name &&
           a->build.motor_axes == b->build.motor_axes && a->build.module_lines == b->build.module_lines;
}

}  // namespace

bool same_content(const controller_snapshot& a, const controller_snapshot& b) {
    return a.id == b.id && a.state == b.state && a.port == b.port && same_identity(a.identity, b.identity) &&
           a.axes == b.axes && a.busy == b.busy && a.ttl_in0_mode == b.ttl_in0_mode &&
           a.ttl_out0_mode == b.ttl_out0_mode && a.crisp_state == b.crisp_state &&
           a.last_error == b.last_error && a.report == b.report && a.error_log_recent == b.error_log_recent &&
           a.error_log_count == b.error_log_count && a.last_attempt == b.last_attempt &&
           a.next_retry == b.next_retry && a.halted == b.halted;
}

}  // namespace gw::devices
