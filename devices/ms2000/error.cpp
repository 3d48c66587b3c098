#include "devices/ms2000/error.hpp"

#include <string>

namespace gw::devices::ms2000 {

std::string_view controller_error_name(int code) {
    switch (code) {
        case unknown_command:
            return "unknown_command";
        case unrecognized_axis:
            return "unrecognized_axis";
        case missing_parameters:
            return "missing_parameters";
        case parameter_out_of_range:
            return "parameter_out_of_range";
        case operation_failed:
            return "operation_failed";
        case undefined_error:
            return "undefined_error";
        case halted:
            return "halted";
        default:
            return "controller_error";
    }
}

std::string_view controller_error_description(int code) {
    switch (code) {
        case unknown_command:
            return "Unknown Command (Not Issued in MS-2000)";
        case unrecognized_axis:
            return "Unrecognized Axis Parameter";
        case missing_parameters:
            return "Missing parameters";
        case parameter_out_of_range:
            return "Parameter Out of Range";
        case operation_failed:
            return "Operation failed";
        case undefined_error:
            return "Undefined Error";
        case halted:
            return "Serial Command halted by the HALT command";
        default:
            return "Unlisted controller error";
    }
}

namespace {

class ms2000_category final : public boost::system::error_category {
  public:
    const char* name() const noexcept override { return "ms2000"; }
    std::string message(int ev) const override {
        switch (static_cast<error>(ev)) {
            case error::timeout:
                return "controller did not reply in time";
            case error::unrecognized_reply:
                return "unrecognized reply from controller";
            case error::line_too_long:
                return "reply line too long";
            case error::controller_rejected:
                return "controller rejected the command";
            case error::invalid_argument:
                return "invalid command argument";
            case error::queue_full:
                return "command queue full";
            case error::not_connected:
                return "controller not connected";
            case error::disconnected:
                return "controller disconnected";
            case error::cancelled:
                return "cancelled";
            case error::halted:
                return "a HALT was sent after this command was decided";
            case error::binary_reply:
                return "the command answers raw bytes, not text";
        }
        return "unknown ms2000 error";
    }
};

}  // namespace

const boost::system::error_category& error_category() noexcept {
    static const ms2000_category category;
    return category;
}

boost::system::error_code make_error_code(error e) noexcept {
    return {static_cast<int>(e), error_category()};
}

}  // namespace gw::devices::ms2000
