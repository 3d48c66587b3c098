#include "api/http/recording_routes.hpp"

#include <memory>
#include <string>

#include <boost/asio/bind_executor.hpp>

#include "api/calls/calls.hpp"
#include "api/calls/recording_requests.hpp"
#include "gateway/recordings/recorder.hpp"

namespace gw::api {

namespace {

using http::verb;

// A recording id that cannot be one (a typo, a path) is not looked up.
bool plausible_recording(request_context& c) {
    if (is_plausible_job_id(c.params[0])) return true;
    c.fail(make_problem(make_error(operation_error_kind::unknown_recording, "no such recording", "id")));
    return false;
}

void start(request_context& c) {
    if (!c.query_with({})) return;
    auto body = c.json_body();
    if (!body) return;
    caller who = c.as_caller();
    if (!c.key_header("Lease-Id", who.lease_id)) return;
    dispatch_call(*c.ctx, who, recording_start_call{c.params[0], std::move(*body)}, c.async_reply());
}

void stop(request_context& c) {
    if (!plausible_recording(c) || !c.query_with({})) return;
    auto body = c.json_body();
    if (!body) return;
    if (!body->is_null() && !(body->is_object() && body->empty()))
        return c.fail(make_error(operation_error_kind::invalid_value, "this request takes no body (or {})"));
    dispatch_call(*c.ctx, c.as_caller(), recording_stop_call{c.params[0]}, c.async_reply());
}

void remove(request_context& c) {
    if (!plausible_recording(c) || !c.query_with({})) return;
    dispatch_call(*c.ctx, c.as_caller(), recording_delete_call{c.params[0]}, c.async_reply());
}

void list(request_context& c) {
    auto q = c.query();
    if (!q) return;
    auto filter = parse_recording_filter(*q);
    if (!filter) return c.fail(filter.error());
    list_recordings(*c.ctx, std::move(*filter), c.request_id, c.async_reply());
}

void get_one(request_context& c) {
    if (!plausible_recording(c) || !c.query_with({})) return;
    get_recording(*c.ctx, c.params[0], c.request_id, c.async_reply());
}

// The rows as stored when the request came: the record first (a 404 is still possible then), then
// the body in pieces.
void frames(request_context& c) {
    if (!plausible_recording(c)) return;
    auto q = c.query();
    if (!q) return;
    auto format = parse_frame_format(*q);
    if (!format) return c.fail(format.error());
    if (!c.ctx->recordings)
        return c.fail(
            make_error(operation_error_kind::storage_unavailable,
                       "recordings are not available: the gateway runs without a storage directory"));
    auto held = std::make_shared<request_context>(std::move(c));
    auto ex = held->session_executor;
    if (*format == recordings::frame_format::hdf5) {
        // The file first (written on the exporter's thread): its errors can still be a status.
        held->ctx->recordings->export_hdf5(
            held->params[0],
            boost::asio::bind_executor(ex, [held](operation_result<recordings::export_file> r) {
                if (!r) return held->fail(r.error());
                const std::string file = r->record.id + ".h5";
                held->reply_stream(
                    "application/x-hdf5", recording_export_body(*held->ctx, std::move(*r)),
                    {{http::field::content_disposition, "attachment; filename=\"" + file + "\""}});
            }));
        return;
    }
    held->ctx->recordings->get(
        held->params[0],
        boost::asio::bind_executor(
            ex, [held, format = *format](operation_result<recordings::recording_record> r) {
                if (!r) return held->fail(r.error());
                const bool csv = format == recordings::frame_format::csv;
                const std::string file = r->id + (csv ? ".csv" : ".jsonl");
                auto body = recording_frames_body(*held->ctx, std::move(*r), format);
                held->reply_stream(
                    csv ? "text/csv; charset=utf-8" : "application/jsonl; charset=utf-8", std::move(body),
                    {{http::field::content_disposition, "attachment; filename=\"" + file + "\""}});
            }));
}

}  // namespace

std::vector<route> recording_routes() {
    const std::string v1 = "/api/v1";
    return {
        {verb::post, v1 + "/controllers/{id}/recordings", role_for(recording_start_call{}), start},
        {verb::get, v1 + "/recordings", gw::role::viewer, list},
        {verb::get, v1 + "/recordings/{id}", gw::role::viewer, get_one},
        {verb::delete_, v1 + "/recordings/{id}", role_for(recording_delete_call{}), remove},
        {verb::post, v1 + "/recordings/{id}/stop", role_for(recording_stop_call{}), stop},
        {verb::get, v1 + "/recordings/{id}/frames", gw::role::viewer, frames},
    };
}

}  // namespace gw::api
