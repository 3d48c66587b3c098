#include "api/calls/halt_requests.hpp"

#include <memory>
#include <vector>

#include <boost/asio/append.hpp>
#include <boost/asio/bind_executor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>

#include "gateway/controllers/controller_registry.hpp"

namespace gw::api {

namespace net = boost::asio;
using nlohmann::json;

bool is_halt_target(std::string_view path) {
    if (path == "/api/v1/halt") return true;
    constexpr std::string_view prefix = "/api/v1/controllers/";
    constexpr std::string_view suffix = "/halt";
    if (!path.starts_with(prefix) || !path.ends_with(suffix) || path.size() <= prefix.size() + suffix.size())
        return false;
    const auto id = path.substr(prefix.size(), path.size() - prefix.size() - suffix.size());
    return id.find('/') == std::string_view::npos;
}

void run_halt_all(api_context& ctx, const caller& who, api_handler handler) {
    struct gathering {
        // Constructed, never assigned: Boost 1.81's any_completion_handler move assignment wraps the
        // handler in itself (it constructs from the lvalue) and recurses until the stack runs out.
        explicit gathering(api_handler h) : handler(std::move(h)) {}
        api_handler handler;
        net::any_io_executor executor;
        std::vector<json> answers;  // in the registry's order
        std::size_t pending = 0;
        json result;
    };
    const auto ids = ctx.registry.ids();
    auto g = std::make_shared<gathering>(std::move(handler));
    g->executor = ctx.executor;
    g->answers.resize(ids.size());
    g->pending = ids.size();
    g->result = {{"operation", "halt_all"}, {"request_id", who.request_id}};
    auto finish = [g] {
        g->result["controllers"] = std::move(g->answers);
        // Through ctx.executor, then the handler's own associated executor if it has one.
        api_outcome out;
        out.body = std::move(g->result);
        net::post(g->executor, net::append(std::move(g->handler), std::move(out)));
    };
    if (ids.empty()) return net::post(ctx.executor, finish);
    // Every HALT goes out at once; the answers are gathered on one strand.
    auto strand = net::make_strand(ctx.executor);
    for (std::size_t i = 0; i < ids.size(); ++i) {
        ctx.registry.async_emergency_halt(
            ids[i], who.name, who.request_id,
            net::bind_executor(
                strand, [g, i, id = ids[i], finish](const operation_result<operation_done>& r) {
                    if (r) {
                        g->answers[i] = {{"id", id}, {"halted", true}, {"latency_us", r->latency.count()}};
                    } else {
                        auto p = make_problem(r.error());
                        p.request_id = g->result["request_id"].get<std::string>();
                        g->answers[i] = {{"id", id}, {"halted", false}, {"problem", p.to_json()}};
                    }
                    if (--g->pending == 0) finish();
                }));
    }
}

}  // namespace gw::api
