#include "gateway/controllers/port_report_json.hpp"

#include <string>

namespace gw {

namespace {

nlohmann::json build_json(const devices::ms2000::build_info& b) {
    namespace ms2000 = devices::ms2000;
    auto modules = nlohmann::json::array();
    for (std::size_t i = 0; i < static_cast<std::size_t>(ms2000::module::count_); ++i) {
        auto m = static_cast<ms2000::module>(i);
        if (b.has(m)) modules.push_back(std::string(ms2000::module_id(m)));
    }
    return {{"name", b.name},
            {"motor_axes", b.motor_axes},
            {"modules", std::move(modules)},
            {"module_lines", b.module_lines}};
}

template <typename T>
nlohmann::json or_null(bool present, const T& value) {
    return present ? nlohmann::json(value) : nlohmann::json(nullptr);
}

}  // namespace

nlohmann::json port_report_json(const devices::port_candidate& candidate, const devices::port_report& r) {
    using status = devices::port_report::status;
    const bool ms2000 = r.what == status::ms2000;
    return {{"path", candidate.path},
            {"device", or_null(!candidate.device.empty(), candidate.device)},
            {"by_id", candidate.by_id},
            {"status", std::string(devices::to_string(r.what))},
            {"baud", or_null(r.baud != 0, r.baud)},
            {"version", or_null(ms2000, r.version)},
            {"version_raw", or_null(ms2000, r.version_raw)},
            {"build", r.build ? build_json(*r.build) : nlohmann::json(nullptr)},
            {"controller", or_null(r.what == status::in_use, r.controller)},
            {"text", r.text},
            {"hint", or_null(!r.hint.empty(), r.hint)}};
}

nlohmann::json controller_entries(const std::vector<devices::port_report>& reports) {
    auto list = nlohmann::json::array();
    for (const auto& r : reports) {
        if (r.what != devices::port_report::status::ms2000) continue;
        list.push_back(
            {{"id", "stage" + std::to_string(list.size() + 1)}, {"port", r.path}, {"baud", r.baud}});
    }
    return list;
}

nlohmann::json port_scan_json(const std::vector<devices::port_candidate>& candidates,
                              const std::vector<devices::port_report>& reports,
                              std::chrono::milliseconds took) {
    auto ports = nlohmann::json::array();
    for (std::size_t i = 0; i < candidates.size() && i < reports.size(); ++i)
        ports.push_back(port_report_json(candidates[i], reports[i]));
    return {{"ports", std::move(ports)},
            {"controllers", controller_entries(reports)},
            {"duration_ms", took.count()}};
}

}  // namespace gw
