#include "api/calls/recording_requests.hpp"

#include <boost/asio/append.hpp>
#include <boost/asio/post.hpp>

#include "api/calls/operation_requests.hpp"
#include "api/common/json_object.hpp"
#include "api/common/printable_text.hpp"
#include "gateway/common/json_value.hpp"
#include "gateway/leases/lease_manager.hpp"
#include "gateway/recordings/recorder.hpp"

namespace gw::api {

namespace net = boost::asio;
using nlohmann::json;
using recordings::recording_record;

namespace {

constexpr std::size_t max_list_limit = 500;
constexpr std::size_t max_metadata_bytes = std::size_t{16} * 1024;
constexpr std::uint64_t max_frames_limit = 1'000'000'000'000;
constexpr double max_seconds = 366.0 * 24 * 3600;  // a year
// Rows per piece of a download: a few hundred kilobytes of text.
constexpr std::size_t rows_per_piece = 4096;
constexpr std::size_t export_piece_bytes = std::size_t{256} * 1024;

problem no_recorder_problem() {
    return make_problem(
        make_error(operation_error_kind::storage_unavailable,
                   "recordings are not available: the gateway runs without a storage directory"));
}

// `done` with what `make` makes of the recorder's answer, or its error; on `done`'s executor.
template <typename T, typename Make>
recordings::recorder_handler<T> answer(const api_context& ctx, std::string request_id, api_handler done,
                                       Make make) {
    return [ex = ctx.executor, request_id = std::move(request_id), done = std::move(done),
            make = std::move(make)](operation_result<T> r) mutable {
        api_outcome out = r ? make(*r) : failed(r.error(), request_id);
        net::post(ex, net::append(std::move(done), std::move(out)));
    };
}

api_outcome record_outcome(const recording_record& r) {
    api_outcome out;
    out.body = recordings::to_json(r);
    return out;
}

// Answers `done` with `p` now (on its executor, never inline); true when there was a problem.
bool refused(const api_context& ctx, std::optional<problem> p, const std::string& request_id,
             api_handler& done) {
    if (!p) return false;
    net::post(ctx.executor, net::append(std::move(done), failed(std::move(*p), request_id)));
    return true;
}

std::optional<problem> without_recorder(const api_context& ctx) {
    if (ctx.recordings) return std::nullopt;
    return no_recorder_problem();
}

}  // namespace

operation_result<recordings::recording_request> parse_recording_request(const std::string& controller,
                                                                        const json& body_in) {
    static const json empty = json::object();
    const json& body = body_in.is_null() ? empty : body_in;
    if (!body.is_object())
        return invalid_field("",
                             "the body must be a JSON object {\"name\", \"arm\", \"max_frames\", \"max_s\", "
                             "\"metadata\"}");
    if (auto unknown = find_unknown_field(body, {"name", "arm", "max_frames", "max_s", "metadata"}))
        return invalid_field(unknown->field, unknown->message);
    recordings::recording_request r;
    r.controller = controller;
    auto name = body.find("name");
    if (name == body.end()) return invalid_field("name", "name is required (what the recording is of)");
    auto text = read_text(*name, {.allow_empty = false, .allow_control = false});
    if (!text)
        return invalid_field("name", "name must be a non-empty string without control characters, not " +
                                         std::string(json_type_name(*name)));
    r.name = *text.value;
    if (auto arm = body.find("arm"); arm != body.end()) {
        if (!arm->is_object())
            return invalid_field(
                "arm", "arm must be an object {\"ttl_in_mode\"}, not " + std::string(json_type_name(*arm)));
        if (auto unknown = find_unknown_field(*arm, {"ttl_in_mode"}))
            return invalid_field("arm." + unknown->field, unknown->message);
        if (auto mode = arm->find("ttl_in_mode"); mode != arm->end()) {
            auto v = read_integer(*mode, 1, 30);
            if (!v)
                return invalid_field("arm.ttl_in_mode",
                                     "arm.ttl_in_mode must be a TTL input mode 1..30 (TTL X=<mode>; any "
                                     "non-zero mode makes a report at each IN0 edge)");
            r.ttl_in_mode = static_cast<int>(*v.value);
        }
    }
    if (auto n = body.find("max_frames"); n != body.end() && !n->is_null()) {
        auto v = read_unsigned(*n, 1, max_frames_limit);
        if (!v) return invalid_field("max_frames", "max_frames must be a whole number 1..10^12");
        r.max_frames = *v.value;
    }
    if (auto s = body.find("max_s"); s != body.end() && !s->is_null()) {
        auto v = read_number(*s, 0.001, max_seconds);
        if (!v) return invalid_field("max_s", "max_s must be a number of seconds from 0.001 to a year");
        r.max_s = *v.value;
    }
    if (auto m = body.find("metadata"); m != body.end() && !m->is_null()) {
        if (!m->is_object())
            return invalid_field("metadata",
                                 "metadata must be an object, not " + std::string(json_type_name(*m)));
        if (m->dump().size() > max_metadata_bytes)
            return invalid_field("metadata", "metadata must be at most 16 KiB of JSON");
        r.metadata = *m;
    }
    return r;
}

operation_result<recordings::recording_filter> parse_recording_filter(const query_params& q) {
    if (auto known = check_known_parameters(q, {"controller", "state", "since", "until", "job", "limit"});
        !known)
        return known.error();
    recordings::recording_filter f;
    if (auto v = query_value(q, "controller")) {
        if (v->empty() || v->size() > 64 || !is_printable_word(*v))
            return invalid_field("controller", "controller must be a controller id");
        f.controller = *v;
    }
    if (auto v = query_value(q, "job")) {
        if (v->empty() || v->size() > 64 || !is_printable_word(*v))
            return invalid_field("job", "job must be a job id");
        f.job = *v;
    }
    if (auto v = query_value(q, "state")) {
        f.state = recordings::parse_recording_state(*v);
        if (!f.state)
            return invalid_field("state", "unknown recording state \"" + shown_in_message(*v) +
                                              "\" (one of: recording, stopped, failed)");
    }
    for (auto [name, into] : {std::pair{"since", &f.since_ms}, std::pair{"until", &f.until_ms}}) {
        auto v = query_value(q, name);
        if (!v) continue;
        auto n = parse_count(*v);
        if (!n || *n > static_cast<std::size_t>(INT64_MAX))
            return invalid_field(name, std::string(name) + " must be milliseconds since the Unix epoch");
        *into = static_cast<std::int64_t>(*n);
    }
    if (auto v = query_value(q, "limit")) {
        auto n = parse_count(*v);
        if (!n || *n < 1 || *n > max_list_limit)
            return invalid_field("limit", "limit must be an integer 1.." + std::to_string(max_list_limit));
        f.limit = *n;
    }
    return f;
}

operation_result<recordings::frame_format> parse_frame_format(const query_params& q) {
    if (auto known = check_known_parameters(q, {"format"}); !known) return known.error();
    auto v = query_value(q, "format");
    if (!v || *v == "csv") return recordings::frame_format::csv;
    if (*v == "jsonl") return recordings::frame_format::jsonl;
    if (*v == "hdf5") return recordings::frame_format::hdf5;
    return invalid_field("format",
                         "unknown format \"" + shown_in_message(*v) + "\" (one of: csv, jsonl, hdf5)");
}

void start_recording(api_context& ctx, const caller& who, const std::string& controller, const json& body,
                     api_handler done) {
    if (refused(ctx, without_recorder(ctx), who.request_id, done)) return;
    auto request = parse_recording_request(controller, body);
    if (!request) {
        refused(ctx, make_problem(request.error()), who.request_id, done);
        return;
    }
    // It changes the trigger input's mode: a lease holder's or a running job's controller is theirs.
    if (ctx.leases) {
        auto allowed = ctx.leases->check(
            controller, who.lease_id ? std::optional<std::string_view>(*who.lease_id) : std::nullopt);
        if (!allowed && refused(ctx, make_problem(allowed.error()), who.request_id, done)) return;
    }
    if (refused(ctx, job_hold_refusal(ctx, controller, who.lease_id), who.request_id, done)) return;
    ctx.recordings->start(
        std::move(*request),
        answer<recording_record>(ctx, who.request_id, std::move(done), [](const recording_record& r) {
            auto out = record_outcome(r);
            out.status = 201;
            out.location = "/api/v1/recordings/" + r.id;
            return out;
        }));
}

void stop_recording(api_context& ctx, const std::string& id, const std::string& request_id,
                    api_handler done) {
    if (refused(ctx, without_recorder(ctx), request_id, done)) return;
    ctx.recordings->stop(id, answer<recording_record>(ctx, request_id, std::move(done), record_outcome));
}

void delete_recording(api_context& ctx, const std::string& id, const std::string& request_id,
                      api_handler done) {
    if (refused(ctx, without_recorder(ctx), request_id, done)) return;
    ctx.recordings->remove(id, answer<bool>(ctx, request_id, std::move(done), [](bool) {
                               api_outcome out;
                               out.status = 204;
                               return out;
                           }));
}

void get_recording(api_context& ctx, const std::string& id, const std::string& request_id, api_handler done) {
    if (refused(ctx, without_recorder(ctx), request_id, done)) return;
    ctx.recordings->get(id, answer<recording_record>(ctx, request_id, std::move(done), record_outcome));
}

void list_recordings(api_context& ctx, recordings::recording_filter filter, const std::string& request_id,
                     api_handler done) {
    if (refused(ctx, without_recorder(ctx), request_id, done)) return;
    ctx.recordings->list(std::move(filter),
                         answer<std::vector<recording_record>>(
                             ctx, request_id, std::move(done), [](const std::vector<recording_record>& list) {
                                 json items = json::array();
                                 for (const auto& r : list)
                                     items.push_back(recordings::to_json(r));
                                 api_outcome out;
                                 out.body = {{"recordings", std::move(items)}};
                                 return out;
                             }));
}

namespace {

class frames_body final : public streamed_body, public std::enable_shared_from_this<frames_body> {
  public:
    frames_body(std::shared_ptr<recordings::recorder> recorder, recording_record record,
                recordings::frame_format format)
        : recorder_(std::move(recorder)),
          record_(std::move(record)),
          format_(format),
          rows_left_(record_.frames + record_.losses) {}

    void next(piece_handler h) override {
        if (!header_sent_) {
            header_sent_ = true;
            if (format_ == recordings::frame_format::csv)
                return h(recordings::csv_header(record_), rows_left_ == 0);
        }
        if (rows_left_ == 0) return h(std::string(), true);
        const auto limit = static_cast<std::size_t>(std::min<std::uint64_t>(rows_left_, rows_per_piece));
        recorder_->rows(
            record_.id, from_, limit,
            [self = shared_from_this(), h = std::move(h)](
                operation_result<recordings::frame_page> page) mutable { self->on_page(page, h); });
    }

  private:
    void on_page(operation_result<recordings::frame_page>& page, const piece_handler& h) {
        if (!page) return h(std::nullopt, true);
        auto& rows = page->rows;
        if (rows.size() > rows_left_) rows.resize(static_cast<std::size_t>(rows_left_));
        rows_left_ -= rows.size();
        // Fewer rows than the record counts: the recording was deleted meanwhile, or the file changed.
        if (rows_left_ > 0 && (!page->next || rows.empty())) return h(std::nullopt, true);
        if (page->next) from_ = *page->next;
        std::string text;
        recordings::append_rows(format_, record_, rows, text);
        h(std::move(text), rows_left_ == 0);
    }

    std::shared_ptr<recordings::recorder> recorder_;
    recording_record record_;
    recordings::frame_format format_;
    std::uint64_t rows_left_;
    std::int64_t from_ = 0;
    bool header_sent_ = false;
};

// An export file, a piece at a time (read on the recorder's exporter thread), removed at the end.
class export_body final : public streamed_body, public std::enable_shared_from_this<export_body> {
  public:
    export_body(std::shared_ptr<recordings::recorder> recorder, recordings::export_file file)
        : recorder_(std::move(recorder)), file_(std::move(file)) {}
    ~export_body() override { recorder_->remove_export(file_.path); }

    void next(piece_handler h) override {
        recorder_->read_export(
            file_.path, offset_, export_piece_bytes,
            [self = shared_from_this(), h = std::move(h)](operation_result<std::string> piece) {
                if (!piece) return h(std::nullopt, true);
                self->offset_ += piece->size();
                const bool last = piece->empty() || self->offset_ >= self->file_.bytes;
                h(std::move(*piece), last);
            });
    }

  private:
    std::shared_ptr<recordings::recorder> recorder_;
    recordings::export_file file_;
    std::uint64_t offset_ = 0;
};

}  // namespace

std::shared_ptr<streamed_body> recording_export_body(api_context& ctx, recordings::export_file file) {
    return std::make_shared<export_body>(ctx.recordings, std::move(file));
}

std::shared_ptr<streamed_body> recording_frames_body(api_context& ctx, recording_record record,
                                                     recordings::frame_format format) {
    return std::make_shared<frames_body>(ctx.recordings, std::move(record), format);
}

}  // namespace gw::api
