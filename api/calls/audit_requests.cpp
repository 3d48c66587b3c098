#include "api/calls/audit_requests.hpp"

#include <boost/asio/append.hpp>
#include <boost/asio/post.hpp>

#include "gateway/audit/audit_log.hpp"

namespace gw::api {

operation_result<audit::audit_filter> parse_audit_filter(const query_params& q) {
    if (auto known =
            check_known_parameters(q, {"controller", "principal", "since", "until", "limit", "before"});
        !known)
        return known.error();
    audit::audit_filter f;
    if (auto v = query_value(q, "controller")) f.controller = *v;
    if (auto v = query_value(q, "principal")) f.principal = *v;
    struct number_parameter {
        const char* name;
        std::optional<std::int64_t>* into;
        const char* what;
    };
    for (const auto& p :
         {number_parameter{"since", &f.since_ms, "milliseconds since the Unix epoch"},
          number_parameter{"until", &f.until_ms, "milliseconds since the Unix epoch"},
          number_parameter{"before", &f.before_id, "an entry id (the \"next_before\" of a page)"}}) {
        auto v = query_value(q, p.name);
        if (!v) continue;
        auto n = parse_count(*v);
        if (!n || *n > static_cast<std::size_t>(INT64_MAX))
            return invalid_field(p.name, std::string(p.name) + " must be " + p.what);
        *p.into = static_cast<std::int64_t>(*n);
    }
    if (auto v = query_value(q, "limit")) {
        auto n = parse_count(*v);
        if (!n || *n < 1 || *n > max_audit_limit)
            return invalid_field("limit", "limit must be an integer 1.." + std::to_string(max_audit_limit));
        f.limit = *n;
    }
    return f;
}

void query_audit(api_context& ctx, audit::audit_filter filter, api_handler done) {
    if (!ctx.audit) {
        return boost::asio::post(
            ctx.executor,
            boost::asio::append(std::move(done),
                                failed(make_error(operation_error_kind::storage_unavailable,
                                                  "the audit trail is kept only with a storage directory"),
                                       "")));
    }
    // std::function needs a copyable callable: the handler travels in a shared_ptr.
    auto shared_done = std::make_shared<api_handler>(std::move(done));
    ctx.audit->async_query(std::move(filter), [executor = ctx.executor, shared_done](
                                                  boost::system::result<audit::audit_page, std::string> r) {
        api_outcome out;
        if (r)
            out.body = audit::to_json(*r);
        else
            out = failed(make_error(operation_error_kind::storage_unavailable, r.error()), "");
        // On the handler's own executor (the session's), not the audit log's thread.
        boost::asio::post(executor, boost::asio::append(std::move(*shared_done), std::move(out)));
    });
}

}  // namespace gw::api
