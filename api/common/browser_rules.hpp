#pragma once
// The configured exceptions to the browser rules (api/http/browser_guard.hpp): what the context holds.

#include <string>
#include <vector>

namespace gw::api {

struct browser_rules {
    std::vector<std::string> allowed_origins;  // "https://lab.example:8443", besides the gateway's own
    std::vector<std::string> allowed_hosts;    // "gateway.lab.example", besides loopback (no tokens only)
    bool without_tokens = true;                // the gateway has no auth tokens
};

}  // namespace gw::api
