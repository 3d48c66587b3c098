#include "api/calls/lease_requests.hpp"

#include <cmath>

#include <boost/asio/append.hpp>
#include <boost/asio/bind_executor.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>

#include "api/common/json_object.hpp"
#include "api/common/printable_text.hpp"
#include "gateway/common/timestamp.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/jobs/manager/job_manager.hpp"

namespace gw::api {

using nlohmann::json;
namespace net = boost::asio;

namespace {

std::optional<api_outcome> check_controller(api_context& ctx, const std::string& controller,
                                            const std::string& request_id) {
    if (!ctx.registry.get(controller))
        return failed(
            make_error(operation_error_kind::unknown_controller, "no controller \"" + controller + "\""),
            request_id);
    if (!ctx.leases)
        return failed(make_problem(http_error::not_implemented, "leases are not enabled on this gateway"),
                      request_id);
    return std::nullopt;
}

std::optional<api_outcome> require_lease_id(const std::optional<std::string>& lease_id,
                                            const std::string& request_id) {
    if (!lease_id)
        return failed(
            invalid_field("Lease-Id", "the Lease-Id header is required (the lease_id of the lease)"),
            request_id);
    if (!is_valid_key(*lease_id))
        return failed(invalid_field("Lease-Id", "Lease-Id must be 1..128 printable characters"), request_id);
    return std::nullopt;
}

}  // namespace

operation_result<lease_body> parse_lease_body(const json& body_in, bool allow_holder) {
    static const json empty = json::object();
    const json& body = body_in.is_null() ? empty : body_in;
    if (!body.is_object()) return invalid_field("", "the body must be a JSON object");
    auto unknown =
        allow_holder ? find_unknown_field(body, {"ttl_s", "holder"}) : find_unknown_field(body, {"ttl_s"});
    if (unknown) return invalid_field(unknown->field, unknown->message);
    lease_body out;
    if (auto it = body.find("ttl_s"); it != body.end()) {
        const auto range =
            std::to_string(min_lease_ttl.count()) + ".." + std::to_string(max_lease_ttl.count());
        if (!it->is_number_integer())
            return invalid_field("ttl_s", "ttl_s must be an integer number of seconds " + range);
        const auto s = it->get<std::int64_t>();
        if (s < min_lease_ttl.count() || s > max_lease_ttl.count())
            return invalid_field("ttl_s", "ttl_s must be " + range + " seconds");
        out.ttl = std::chrono::seconds(s);
    }
    if (auto it = body.find("holder"); it != body.end()) {
        if (!it->is_string() || it->get_ref<const std::string&>().empty() ||
            it->get_ref<const std::string&>().size() > 64 ||
            !is_printable_label(it->get_ref<const std::string&>()))
            return invalid_field("holder", "holder must be a label of 1..64 printable characters");
        out.label = it->get<std::string>();
    }
    return out;
}

json lease_json(const lease& l, bool with_id, std::chrono::system_clock::time_point now) {
    json j = json::object();
    if (with_id) j["lease_id"] = l.id;
    j["controller"] = l.controller;
    j["holder"] = l.holder;
    j["acquired"] = format_timestamp(l.acquired);
    j["expires"] = format_timestamp(l.expires);
    const double left = std::chrono::duration<double>(l.expires - now).count();
    j["expires_in_s"] = std::max(0.0, std::round(left * 1000) / 1000);
    return j;
}

void acquire_lease(api_context& ctx, const std::string& controller, const json& body,
                   const std::string& principal, const std::string& request_id, api_handler handler) {
    auto finish_now = [&](api_outcome out) {
        net::post(ctx.executor, net::append(std::move(handler), std::move(out)));
    };
    if (auto bad = check_controller(ctx, controller, request_id)) return finish_now(std::move(*bad));
    auto parsed = parse_lease_body(body, true);
    if (!parsed) return finish_now(failed(parsed.error(), request_id));
    std::string holder = principal + (parsed->label ? "/" + *parsed->label : std::string());
    auto answer = [controller, request_id](operation_result<lease> l) {
        if (!l) return failed(l.error(), request_id);
        api_outcome out;
        out.status = 201;
        out.body = lease_json(*l, true, std::chrono::system_clock::now());
        out.location = "/api/v1/controllers/" + controller + "/lease";
        return out;
    };
    if (!ctx.jobs) return finish_now(answer(ctx.leases->acquire(controller, std::move(holder), parsed->ttl)));
    // Through the job manager: it refuses while jobs from before the lease hold or wait for the controller.
    auto shared = std::make_shared<api_handler>(std::move(handler));
    auto ex = ctx.executor;
    ctx.jobs->async_acquire_lease(controller, std::move(holder), parsed->ttl,
                                  net::bind_executor(ex, [shared, ex, answer](operation_result<lease> l) {
                                      net::dispatch(ex,
                                                    net::append(std::move(*shared), answer(std::move(l))));
                                  }));
}

api_outcome renew_lease(api_context& ctx, const std::string& controller,
                        const std::optional<std::string>& lease_id, const json& body,
                        const std::string& request_id) {
    if (auto bad = check_controller(ctx, controller, request_id)) return std::move(*bad);
    if (auto bad = require_lease_id(lease_id, request_id)) return std::move(*bad);
    auto parsed = parse_lease_body(body, false);
    if (!parsed) return failed(parsed.error(), request_id);
    auto l = ctx.leases->renew(controller, *lease_id, parsed->ttl);
    if (!l) return failed(l.error(), request_id);
    api_outcome out;
    out.body = lease_json(*l, true, std::chrono::system_clock::now());
    return out;
}

api_outcome release_lease(api_context& ctx, const std::string& controller,
                          const std::optional<std::string>& lease_id, bool force,
                          const std::string& request_id) {
    if (auto bad = check_controller(ctx, controller, request_id)) return std::move(*bad);
    if (!force)
        if (auto bad = require_lease_id(lease_id, request_id)) return std::move(*bad);
    auto l = ctx.leases->release(controller, lease_id.value_or(std::string()), force);
    if (!l) return failed(l.error(), request_id);
    api_outcome out;
    out.status = 204;
    return out;
}

api_outcome get_lease(api_context& ctx, const std::string& controller, const std::string& request_id) {
    if (auto bad = check_controller(ctx, controller, request_id)) return std::move(*bad);
    auto l = ctx.leases->current(controller);
    if (!l) return failed(make_problem(http_error::not_found, controller + " is not leased"), request_id);
    api_outcome out;
    out.body = lease_json(*l, false, std::chrono::system_clock::now());
    return out;
}

api_outcome list_leases(api_context& ctx, const std::string& request_id) {
    if (!ctx.leases)
        return failed(make_problem(http_error::not_implemented, "leases are not enabled on this gateway"),
                      request_id);
    const auto now = std::chrono::system_clock::now();
    json leases = json::array();
    for (const auto& l : ctx.leases->all())
        leases.push_back(lease_json(l, false, now));
    api_outcome out;
    out.body = json{{"leases", std::move(leases)}};
    return out;
}

}  // namespace gw::api
