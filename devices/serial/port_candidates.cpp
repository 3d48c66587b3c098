#include "devices/serial/port_candidates.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>

namespace gw::devices {

namespace {

namespace fs = std::filesystem;

std::string resolve(const std::string& path) {
    std::error_code ec;
    auto c = fs::canonical(path, ec);
    return ec ? std::string() : c.string();
}

// "ttyS10" after "ttyS2": the digits at the end compare as a number.
bool natural_less(const std::string& a, const std::string& b) {
    auto split = [](const std::string& s) {
        const auto digits = s.find_last_not_of("0123456789") + 1;
        const std::string tail = s.substr(digits);
        return std::make_pair(s.substr(0, digits), tail.empty() ? -1L : std::stol(tail.substr(0, 9)));
    };
    return split(a) < split(b);
}

// A ttyS node the kernel made without a UART behind it reports type 0 (PORT_UNKNOWN) in sysfs: not a
// port, so it is not listed (a PC has 4 to 32 of them).
bool uart_absent(const std::string& name) {
    std::ifstream in("/sys/class/tty/" + name + "/type");
    int type = -1;
    return in >> type && type == 0;
}

}  // namespace

std::vector<port_candidate> list_candidate_ports(const std::vector<std::string>& extra, bool system_ports,
                                                 const std::string& dev_root) {
    std::vector<port_candidate> out;
    std::set<std::string> seen;  // resolved nodes already listed
    auto add = [&](const std::string& path, bool by_id, bool keep_missing) {
        port_candidate c{path, resolve(path), by_id};
        if (c.device.empty() && !keep_missing) return;
        if (!c.device.empty() && !seen.insert(c.device).second) return;
        out.push_back(std::move(c));
    };
    if (system_ports) {
        std::error_code ec;
        std::vector<std::string> links;
        for (fs::directory_iterator it(dev_root + "/serial/by-id", ec), end; !ec && it != end;
             it.increment(ec))
            links.push_back(it->path().string());
        std::sort(links.begin(), links.end());
        for (const auto& l : links)
            add(l, true, false);

        // sysfs describes the real /dev only (a test's fake tree has no UART types).
        const bool real_dev = dev_root == "/dev";
        std::vector<std::string> nodes;
        for (fs::directory_iterator it(dev_root, ec), end; !ec && it != end; it.increment(ec)) {
            const std::string name = it->path().filename().string();
            for (const char* prefix : {"ttyUSB", "ttyACM", "ttyS"})
                if (name.starts_with(prefix) && name.size() > std::string_view(prefix).size() &&
                    name.find_first_not_of("0123456789", std::string_view(prefix).size()) ==
                        std::string::npos &&
                    !(name.starts_with("ttyS") && real_dev && uart_absent(name)))
                    nodes.push_back(it->path().string());
        }
        // ttyUSB and ttyACM (where MS-2000 adapters appear) before the built-in ttyS ports.
        std::sort(nodes.begin(), nodes.end(), [](const std::string& a, const std::string& b) {
            const bool a_s = a.find("/ttyS") != std::string::npos;
            const bool b_s = b.find("/ttyS") != std::string::npos;
            if (a_s != b_s) return b_s;
            return natural_less(a, b);
        });
        for (const auto& n : nodes)
            add(n, false, false);
    }
    for (const auto& e : extra)
        add(e, e.find("/serial/by-id/") != std::string::npos, true);
    return out;
}

}  // namespace gw::devices
