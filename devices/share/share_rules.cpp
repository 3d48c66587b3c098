#include "devices/share/share_rules.hpp"

namespace gw::devices::share {

using ms2000::command_effect;

const char* to_string(share_role role) {
    switch (role) {
        case share_role::viewer:
            return "viewer";
        case share_role::operator_:
            return "operator";
        case share_role::admin:
            return "admin";
    }
    return "viewer";
}

std::string refusal_reply(refusal_code code) {
    return ":N" + std::to_string(static_cast<int>(code)) + "\r\n";
}

bool role_allows(share_role role, command_effect effect) {
    switch (effect) {
        case command_effect::reads:
        case command_effect::halts:
            return true;
        case command_effect::acts:
            return role != share_role::viewer;
        case command_effect::writes_flash:
        case command_effect::breaks_link:
        case command_effect::unknown:
            return role == share_role::admin;
    }
    return false;
}

bool needs_control(command_effect effect) {
    return effect != command_effect::reads && effect != command_effect::halts;
}

}  // namespace gw::devices::share
