#include "devices/serial/port_scan.hpp"

#include <algorithm>
#include <filesystem>
#include <system_error>
#include <thread>

#include "devices/serial/port_lock.hpp"

namespace gw::devices {

std::string port_key(const std::string& path) {
    std::error_code ec;
    auto c = std::filesystem::canonical(path, ec);
    return ec ? path : c.string();
}

std::vector<port_report> scan_ports(const scan_request& request) {
    std::vector<port_report> reports(request.ports.size());
    std::vector<std::string> devices;
    for (const auto& c : request.ports)
        devices.push_back(c.device);
    const auto held = open_elsewhere(devices);

    auto probe_one = [&](std::size_t i) {
        const auto& c = request.ports[i];
        const auto key = c.device.empty() ? c.path : c.device;
        if (auto it = request.in_use.find(key); it != request.in_use.end()) {
            auto& r = reports[i];
            r.what = port_report::status::in_use;
            r.path = c.path;
            r.device = c.device;
            r.controller = it->second;
            r.text = c.path + " is controller \"" + it->second + "\" of this gateway";
            return;
        }
        const auto h = held.find(c.device);
        try {
            reports[i] = probe_port(c.path, request.settings, h == held.end() ? std::string() : h->second);
        } catch (const std::exception& e) {  // out of memory, or the like: that port's report says so
            reports[i].path = c.path;
            reports[i].what = port_report::status::error;
            reports[i].text = std::string("probing ") + c.path + " failed: " + e.what();
        }
    };
    const std::size_t batch = std::max<std::size_t>(request.max_parallel, 1);
    for (std::size_t first = 0; first < request.ports.size(); first += batch) {
        std::vector<std::thread> threads;
        for (std::size_t i = first; i < std::min(first + batch, request.ports.size()); ++i) {
            try {
                threads.emplace_back(probe_one, i);
            } catch (const std::system_error&) {
                probe_one(i);  // no thread to be had: probe this one here
            }
        }
        for (auto& t : threads)
            t.join();
    }
    return reports;
}

}  // namespace gw::devices
