#include "api/common/request_id.hpp"

#include <atomic>
#include <cstdint>
#include <random>

namespace gw::api {

bool is_valid_request_id(std::string_view id) {
    if (id.empty() || id.size() > max_request_id_bytes) return false;
    for (char c : id)
        if (c <= ' ' || c > '~') return false;
    return true;
}

std::string make_request_id() {
    // A random start and a counter: unique within the process without a lock, and unlikely to
    // repeat across restarts (logs of several runs stay distinguishable).
    static std::atomic<std::uint64_t> next{[] {
        std::random_device rd;
        return (static_cast<std::uint64_t>(rd()) << 32) ^ rd();
    }()};
    std::uint64_t v = next.fetch_add(0x9e3779b97f4a7c15ULL, std::memory_order_relaxed);
    static constexpr char digits[] = "0123456789abcdef";
    std::string out(16, '0');
    for (int i = 15; i >= 0; --i, v >>= 4)
        out[static_cast<std::size_t>(i)] = digits[v & 0xf];
    return out;
}

std::string request_id_for(std::string_view header_value) {
    return is_valid_request_id(header_value) ? std::string(header_value) : make_request_id();
}

}  // namespace gw::api
