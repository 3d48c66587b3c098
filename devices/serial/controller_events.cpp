#include "devices/serial/controller_events.hpp"

namespace gw::devices {

std::string_view to_string(link_fault::kind kind) {
    switch (kind) {
        case link_fault::kind::timeout:
            return "timeout";
        case link_fault::kind::mismatch:
            return "mismatch";
        case link_fault::kind::noise:
            return "noise";
        case link_fault::kind::unexpected:
            return "unexpected";
        case link_fault::kind::resynced:
            return "resynced";
        case link_fault::kind::resync_failed:
            return "resync_failed";
        case link_fault::kind::contained:
            return "contained";
    }
    return "other";
}

}  // namespace gw::devices
