#include "api/calls/port_requests.hpp"

#include <chrono>
#include <sys/stat.h>

#include <boost/asio/append.hpp>
#include <boost/asio/dispatch.hpp>

#include "api/common/port_scan_worker.hpp"
#include "devices/serial/port_candidates.hpp"
#include "devices/serial/port_scan.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/controllers/port_report_json.hpp"

namespace gw::api {

namespace {

problem scan_busy() {
    problem p;
    p.status = 503;
    p.kind = "port_scan_busy";
    p.title = "Port scan busy";
    p.detail = "a port scan is already running; try again shortly";
    p.retry_after_s = 2;
    return p;
}

std::vector<std::string> split_paths(const std::string& list) {
    std::vector<std::string> out;
    std::size_t start = 0;
    while (start <= list.size()) {
        const auto comma = std::min(list.find(',', start), list.size());
        if (comma > start) out.push_back(list.substr(start, comma - start));
        start = comma + 1;
    }
    return out;
}

}  // namespace

void scan_ports_request(api_context& ctx, const query_params& q, const std::string& request_id,
                        api_handler done) {
    auto fail = [&](operation_error e) { done(failed(e, request_id)); };
    if (auto known = check_known_parameters(q, {"path", "only_paths"}); !known) return fail(known.error());
    auto only = query_flag(q, "only_paths", false);
    if (!only) return fail(only.error());
    std::vector<std::string> paths;
    if (auto v = query_value(q, "path")) paths = split_paths(*v);
    for (const auto& p : paths) {
        struct stat st {};
        if (p.empty() || p[0] != '/')
            return fail(make_error(operation_error_kind::invalid_value, "path \"" + p + "\" is not absolute",
                                   "path"));
        if (::stat(p.c_str(), &st) == 0 && !S_ISCHR(st.st_mode))
            return fail(make_error(operation_error_kind::invalid_value,
                                   "path \"" + p + "\" is not a character device (a serial port)", "path"));
    }
    if (*only && paths.empty())
        return fail(
            make_error(operation_error_kind::invalid_value, "only_paths needs at least one path", "path"));

    devices::scan_request request;
    request.ports = devices::list_candidate_ports(paths, !*only);
    // This gateway's ports are not opened: their controller owns them (settings are immutable).
    for (const auto& id : ctx.registry.ids()) {
        if (auto c = ctx.registry.controller(id)) {
            request.in_use[devices::port_key(c->settings().port)] = id;
            if (!c->settings().report_port.empty())
                request.in_use[devices::port_key(c->settings().report_port)] = id + " (report port)";
        }
    }
    auto shared_done = std::make_shared<api_handler>(std::move(done));
    const bool started = ctx.port_scans->try_post([request = std::move(request), shared_done, request_id] {
        const auto began = std::chrono::steady_clock::now();
        api_outcome o;
        try {
            const auto reports = devices::scan_ports(request);
            const auto took = std::chrono::duration_cast<std::chrono::milliseconds>(
                std::chrono::steady_clock::now() - began);
            o.body = port_scan_json(request.ports, reports, took);
        } catch (const std::exception& e) {
            o = failed(
                make_error(operation_error_kind::internal, std::string("port scan failed: ") + e.what()),
                request_id);
        }
        // On the session's executor (the handler's associated one), never here on the worker thread.
        boost::asio::dispatch(boost::asio::append(std::move(*shared_done), std::move(o)));
    });
    if (!started) std::move (*shared_done)(failed(scan_busy(), request_id));  // on the session's strand
}

}  // namespace gw::api
