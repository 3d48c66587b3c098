#include "devices/serial/emergency_halt.hpp"

#include <array>
#include <atomic>
#include <unistd.h>

namespace gw::devices::emergency_halt {

namespace {

// A descriptor plus one; 0 is a free slot (zero-initialised before anything runs). Lock-free atomics
// only: a signal handler may read the table at any moment.
std::array<std::atomic<int>, max_ports> ports{};

static_assert(std::atomic<int>::is_always_lock_free, "a signal handler reads the table");

}  // namespace

bool add_port(int fd) {
    for (auto& p : ports) {
        int expected = 0;
        if (p.compare_exchange_strong(expected, fd + 1, std::memory_order_acq_rel)) return true;
    }
    return false;
}

void remove_port(int fd) {
    for (auto& p : ports) {
        int expected = fd + 1;
        if (p.compare_exchange_strong(expected, 0, std::memory_order_acq_rel)) return;
    }
}

int halt_every_open_port() {
    static constexpr char halt[] = {'\\', '\r'};
    int sent = 0;
    for (auto& p : ports) {
        const int fd = p.load(std::memory_order_acquire) - 1;
        if (fd >= 0 && ::write(fd, halt, sizeof halt) == static_cast<ssize_t>(sizeof halt)) ++sent;
    }
    return sent;
}

}  // namespace gw::devices::emergency_halt
