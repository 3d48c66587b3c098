#include "api/calls/gcode_check.hpp"

#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <variant>

#include <boost/asio/append.hpp>
#include <boost/asio/post.hpp>
#include <nlohmann/json.hpp>

#include "api/common/gcode_worker.hpp"
#include "api/common/json_object.hpp"
#include "api/common/net.hpp"
#include "api/common/printable_text.hpp"
#include "gateway/gcode/gcode_plan_summary_json.hpp"
#include "gateway/gcode/gcode_planner.hpp"
#include "gateway/storage/gcode_files.hpp"

namespace gw::api {

using nlohmann::json;

problem invalid_gcode_problem(const gcode::gcode_error& e) {
    problem p;
    p.status = 422;
    p.kind = "invalid_gcode";
    p.title = "Invalid G-code program";
    p.detail = e.line > 0 ? "line " + std::to_string(e.line) + ", column " + std::to_string(e.column) + ": " +
                                e.message
                          : e.message;
    p.program = problem::program_error{e.line, e.column, e.message};
    return p;
}

problem planner_busy(const gcode_worker& worker) {
    problem p;
    p.status = 503;
    p.kind = "planner_busy";
    p.title = "Planner busy";
    p.detail =
        std::to_string(worker.max_pending()) + " G-code requests are already waiting; try again shortly";
    p.retry_after_s = 1;
    return p;
}

namespace {

operation_result<query_params> options_as_query(const json& options) {
    query_params q;
    if (options.is_null()) return q;
    if (!options.is_object())
        return make_error(
            operation_error_kind::invalid_value,
            "\"options\" must be an object of G-code options, not " + std::string(json_type_name(options)),
            "options");
    for (const auto& [name, value] : options.items()) {
        const auto field = "options." + shown_in_message(name);
        if (name == "moves")
            return make_error(operation_error_kind::invalid_value,
                              "a check answers with the plan's summary; the moves come from POST "
                              "/api/v1/gcode/files/{id}/plan",
                              field);
        if (value.is_string())
            q.emplace_back(name, value.get<std::string>());
        else if (value.is_boolean())
            q.emplace_back(name, value.get<bool>() ? "true" : "false");
        else if (value.is_number())
            q.emplace_back(name, value.dump());
        else
            return make_error(operation_error_kind::invalid_value,
                              "a G-code option is a string, a number or a boolean, not " +
                                  std::string(json_type_name(value)),
                              field);
    }
    return q;
}

}  // namespace

operation_result<gcode_query> parse_gcode_query(const query_params& q, gcode_output output) {
    gcode_query r;
    auto bad_value = [](const std::string& name, const std::string& why, const std::string& value) {
        return make_error(operation_error_kind::invalid_value,
                          why + ", not \"" + shown_in_message(value) + "\"", name);
    };
    for (const auto& [name, value] : q) {
        if (output == gcode_output::plan && name == "moves") {
            auto flag = query_flag(q, "moves", true);
            if (!flag) return flag.error();
            r.moves = *flag;
            continue;
        }
        if (output == gcode_output::preview) {
            auto p = gcode::set_preview_option(r.preview, name, value);
            if (p.known) {
                if (p.error) return bad_value(name, *p.error, value);
                continue;
            }
        }
        if (auto why = gcode::set_option(r.options, name, value)) {
            if (why->starts_with("unknown option"))  // set_option's word for a name it lacks
                return make_error(
                    operation_error_kind::invalid_value,
                    "unknown parameter \"" + shown_in_message(name) + "\" (known: " +
                        (output == gcode_output::plan ? "moves" : "view, width_px, max_points") +
                        " and the G-code options of gateway/gcode/README.md)",
                    shown_in_message(name));
            return bad_value(name, *why, value);
        }
    }
    if (auto why = gcode::validate(r.options)) {
        // Messages start with the option; a pair given half names the missing half.
        std::string field = why->substr(0, why->find(' '));
        if (why->ends_with("must be given together"))
            field = query_value(q, "analog_low_um") ? "analog_high_um" : "analog_low_um";
        return make_error(operation_error_kind::invalid_value, *why, field);
    }
    return r;
}

void check_stored_program(api_context& ctx, const std::string& file, const json& options,
                          const std::string& request_id, api_handler done) {
    const auto executor = ctx.executor;
    auto answer = [executor, request_id](api_handler h, api_outcome out) {
        if (out.error) out.error->request_id = request_id;
        net::post(executor, net::append(std::move(h), std::move(out)));
    };
    if (!ctx.gcode_files)
        return answer(std::move(done), failed(make_error(operation_error_kind::storage_unavailable,
                                                         "this gateway has no G-code file store"),
                                              request_id));
    auto query = options_as_query(options);
    if (!query) return answer(std::move(done), failed(query.error(), request_id));
    auto parsed = parse_gcode_query(*query, gcode_output::plan);
    if (!parsed) {
        auto e = parsed.error();
        if (!e.field.empty()) e.field = "options." + e.field;
        return answer(std::move(done), failed(e, request_id));
    }
    if (!ctx.gcode_thread)
        return answer(std::move(done),
                      failed(make_error(operation_error_kind::internal, "no G-code thread"), request_id));
    // The handler waits in a shared slot: it is answered here when the planner refuses the task.
    auto waiting = std::make_shared<std::optional<api_handler>>(std::move(done));
    const bool posted = ctx.gcode_thread->try_post([store = ctx.gcode_files, file, options = parsed->options,
                                                    waiting, answer, request_id]() {
        api_outcome out;
        auto path = store->path_of(file);
        std::ifstream in;
        if (path) in.open(*path, std::ios::binary);
        if (!path)
            out = failed(path.error(), request_id);
        else if (!in)  // deleted in between
            out = failed(make_error(operation_error_kind::unknown_file, "no G-code file \"" + file + "\""),
                         request_id);
        else if (auto checked = gcode::check_program(in, options);
                 auto* e = std::get_if<gcode::gcode_error>(&checked))
            out = failed(invalid_gcode_problem(*e), request_id);
        else {
            std::ostringstream summary;
            gcode::write_plan_summary_json(summary, std::get<gcode::plan_summary>(checked));
            out.body = json::parse(summary.str(), nullptr, false);
        }
        answer(std::move(**waiting), std::move(out));
    });
    if (!posted) answer(std::move(**waiting), failed(planner_busy(*ctx.gcode_thread), request_id));
}

}  // namespace gw::api
