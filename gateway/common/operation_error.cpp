#include "gateway/common/operation_error.hpp"

#include <string>

#include "devices/ms2000/error.hpp"

namespace gw {

std::string_view to_string(operation_error_kind kind) {
    switch (kind) {
        case operation_error_kind::unknown_controller:
            return "unknown_controller";
        case operation_error_kind::invalid_value:
            return "invalid_value";
        case operation_error_kind::missing_module:
            return "missing_module";
        case operation_error_kind::busy:
            return "busy";
        case operation_error_kind::leased:
            return "leased";
        case operation_error_kind::not_connected:
            return "not_connected";
        case operation_error_kind::timeout:
            return "timeout";
        case operation_error_kind::controller_error:
            return "controller_error";
        case operation_error_kind::queue_full:
            return "queue_full";
        case operation_error_kind::unknown_job:
            return "unknown_job";
        case operation_error_kind::invalid_state:
            return "invalid_state";
        case operation_error_kind::storage_unavailable:
            return "storage_unavailable";
        case operation_error_kind::unknown_file:
            return "unknown_file";
        case operation_error_kind::halted:
            return "halted";
        case operation_error_kind::job_active:
            return "job_active";
        case operation_error_kind::unknown_recording:
            return "unknown_recording";
        case operation_error_kind::stale_command:
            return "stale_command";
        case operation_error_kind::internal:
            return "internal";
    }
    return "internal";
}

operation_error make_error(operation_error_kind kind, std::string message, std::string field) {
    operation_error e;
    e.kind = kind;
    e.message = std::move(message);
    e.field = std::move(field);
    return e;
}

operation_error invalid_field(std::string field, std::string message) {
    return make_error(operation_error_kind::invalid_value, std::move(message), std::move(field));
}

std::string describe(const operation_error& e) {
    return e.message.empty() ? std::string(to_string(e.kind)) : e.message;
}

operation_error from_driver_error(boost::system::error_code ec, int code, std::string_view controller_id) {
    namespace ms2000 = devices::ms2000;
    const std::string who(controller_id);
    if (ec.category() != ms2000::error_category())
        return make_error(operation_error_kind::internal, who + ": " + ec.message());
    switch (static_cast<ms2000::error>(ec.value())) {
        case ms2000::error::timeout:
            return make_error(operation_error_kind::timeout, who + ": the controller did not answer in time");
        case ms2000::error::not_connected:
        case ms2000::error::disconnected:
        case ms2000::error::cancelled:
            return make_error(operation_error_kind::not_connected, who + ": " + ec.message());
        case ms2000::error::halted:
            return make_error(operation_error_kind::halted, who + ": a HALT was sent after this was decided");
        case ms2000::error::queue_full:
            return make_error(operation_error_kind::queue_full, who + ": too many commands waiting");
        case ms2000::error::invalid_argument:
        case ms2000::error::binary_reply:
            return make_error(operation_error_kind::invalid_value, who + ": " + ec.message());
        case ms2000::error::controller_rejected: {
            auto e = make_error(operation_error_kind::controller_error,
                                who + ": the controller answered :N" + std::to_string(code) + " (" +
                                    std::string(ms2000::controller_error_description(code)) + ")");
            e.controller_code = code;
            e.controller_code_name = std::string(ms2000::controller_error_name(code));
            return e;
        }
        case ms2000::error::unrecognized_reply:
        case ms2000::error::line_too_long: {
            auto e = make_error(operation_error_kind::controller_error, who + ": " + ec.message());
            e.controller_code_name = "unrecognized_reply";
            return e;
        }
    }
    return make_error(operation_error_kind::internal, who + ": " + ec.message());
}

}  // namespace gw
