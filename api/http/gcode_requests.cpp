#include "api/http/gcode_requests.hpp"

#include <algorithm>
#include <fstream>
#include <istream>
#include <ostream>
#include <sstream>
#include <streambuf>
#include <variant>

#include <boost/asio/append.hpp>
#include <boost/asio/post.hpp>
#include <nlohmann/json.hpp>

#include "api/calls/call_audit.hpp"
#include "api/common/auth.hpp"
#include "api/common/gcode_worker.hpp"
#include "api/common/json_object.hpp"
#include "api/common/printable_text.hpp"
#include "api/common/response_headers.hpp"
#include "gateway/audit/audit_log.hpp"
#include "gateway/gcode/gcode_plan_json.hpp"
#include "gateway/gcode/gcode_plan_summary_json.hpp"
#include "gateway/gcode/gcode_planner.hpp"
#include "gateway/storage/gcode_files.hpp"

namespace gw::api {

namespace {

using nlohmann::json;

// Reads a string in place (a request body of tens of megabytes is not copied), seekable so the
// planner can check the program before planning it.
class view_buf final : public std::streambuf {
  public:
    explicit view_buf(std::string_view text) {
        char* p = const_cast<char*>(text.data());  // never written: no overflow, no putback
        setg(p, p, p + text.size());
    }

  protected:
    pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which) override {
        if (!(which & std::ios_base::in)) return pos_type(off_type(-1));
        off_type base = dir == std::ios_base::beg   ? 0
                        : dir == std::ios_base::cur ? gptr() - eback()
                                                    : egptr() - eback();
        return seekpos(pos_type(base + off), which);
    }
    pos_type seekpos(pos_type pos, std::ios_base::openmode which) override {
        const off_type at = off_type(pos);
        if (!(which & std::ios_base::in) || at < 0 || at > egptr() - eback()) return pos_type(off_type(-1));
        setg(eback(), eback() + at, egptr());
        return pos;
    }
};

// Collects output up to a cap; past it the stream goes bad and the text stays as it was.
class capped_buf final : public std::streambuf {
  public:
    explicit capped_buf(std::size_t cap) : cap_(cap) {}
    std::string& text() { return text_; }
    bool overflowed() const { return overflowed_; }

  protected:
    int_type overflow(int_type c) override {
        if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
        const char ch = traits_type::to_char_type(c);
        return xsputn(&ch, 1) == 1 ? c : traits_type::eof();
    }
    std::streamsize xsputn(const char* s, std::streamsize n) override {
        if (overflowed_ || text_.size() + static_cast<std::size_t>(n) > cap_) {
            overflowed_ = true;
            return 0;
        }
        text_.append(s, static_cast<std::size_t>(n));
        return n;
    }

  private:
    std::size_t cap_;
    std::string text_;
    bool overflowed_ = false;
};

string_response problem_of(problem p, const response_meta& m) {
    return problem_response(std::move(p), m.version, m.keep_alive, m.target, m.request_id);
}

string_response error_of(const operation_error& e, const response_meta& m) {
    return problem_of(make_problem(e), m);
}

string_response gcode_error_response(const gcode::gcode_error& e, const response_meta& m) {
    auto p = invalid_gcode_problem(e);
    p.instance = std::string(target_path(m.target));
    p.request_id = m.request_id;
    return body_response(http::status::unprocessable_entity,
                         p.to_json().dump(-1, ' ', false, json::error_handler_t::replace),
                         problem_content_type, m);
}

string_response plan_response(std::istream& in, const gcode_query& q, const response_meta& m) {
    const auto start = in.tellg();
    auto checked = gcode::check_program(in, q.options);
    if (auto* e = std::get_if<gcode::gcode_error>(&checked)) return gcode_error_response(*e, m);
    const auto& summary = std::get<gcode::plan_summary>(checked);
    capped_buf buf(max_plan_response_bytes);
    std::ostream out(&buf);
    if (!q.moves) {
        gcode::write_plan_summary_json(out, summary);
    } else {
        in.clear();
        in.seekg(start);
        gcode::plan_json_writer writer(out);
        auto planned = gcode::plan_program(in, q.options, writer);
        if (auto* e = std::get_if<gcode::gcode_error>(&planned)) return gcode_error_response(*e, m);
        writer.finish(std::get<gcode::plan_summary>(planned));
    }
    if (buf.overflowed())
        return error_of(make_error(operation_error_kind::invalid_value,
                                   "the plan of " + std::to_string(summary.moves) + " moves is larger than " +
                                       std::to_string(max_plan_response_bytes / (std::size_t{1024} * 1024)) +
                                       " MiB: ask for moves=false (the summary), or plan with "
                                       "`asi-gateway gcode plan`",
                                   "moves"),
                        m);
    return body_response(http::status::ok, std::move(buf.text()), "application/json", m);
}

string_response preview_response(std::istream& in, const gcode_query& q, const response_meta& m) {
    std::ostringstream out;
    if (auto e = gcode::write_preview_svg(in, q.options, q.preview, out)) return gcode_error_response(*e, m);
    return body_response(http::status::ok, std::move(out).str(), "image/svg+xml", m);
}

// The program file of an uploaded id, opened; or the error response.
std::variant<std::ifstream, string_response> open_file(gcode_file_store& store, const std::string& id,
                                                       const response_meta& m) {
    auto path = store.path_of(id);
    if (!path) return error_of(path.error(), m);
    std::ifstream in(*path, std::ios::binary);
    if (!in)  // deleted in between
        return error_of(make_error(operation_error_kind::unknown_file, "no G-code file \"" + id + "\""), m);
    return in;
}

// The POSTs whose body is a program.
enum class program_action : std::uint8_t { plan, preview, save };

struct program_request {
    std::string route;
    program_action action = program_action::plan;
    gcode_query query;  // plan, preview
    std::string name;   // save
    caller who{};       // save: for the audit trail (check_program_header sets name and role)
};

// The routes whose body is a program, and what each does with it.
constexpr std::string_view plan_route = "/api/v1/gcode/plan";
constexpr std::string_view preview_route = "/api/v1/gcode/preview.svg";
constexpr std::string_view files_route = "/api/v1/gcode/files";

// The request of a program route (its template), for `who`; nullopt for any other route.
std::optional<program_request> program_request_of(std::string_view route,
                                                  const std::optional<auth_identity>& who) {
    program_request r;
    if (route == plan_route)
        r.action = program_action::plan;
    else if (route == preview_route)
        r.action = program_action::preview;
    else if (route == files_route)
        r.action = program_action::save;
    else
        return std::nullopt;
    r.route = std::string(route);
    if (who) {
        r.who.name = who->name;
        r.who.role = who->role;
    }
    return r;
}

// What a program request's query asks for (the options, or the name of an upload): fills `r`, or
// returns the refusal. The route table has authorised the caller already.
std::optional<problem> check_program_query(std::string_view target, program_request& r) {
    auto q = parse_query(target);
    if (!q) return make_problem(q.error());
    if (r.action == program_action::save) {
        if (auto known = check_known_parameters(*q, {"name"}); !known) return make_problem(known.error());
        r.name = query_value(*q, "name").value_or("");
        if (auto ok = check_gcode_file_name(r.name); !ok) return make_problem(ok.error());
        return std::nullopt;
    }
    auto parsed =
        parse_gcode_query(*q, r.action == program_action::plan ? gcode_output::plan : gcode_output::preview);
    if (!parsed) return make_problem(parsed.error());
    r.query = *parsed;
    return std::nullopt;
}

string_response created_response(const gcode_file_info& info, const response_meta& m) {
    auto res = body_response(http::status::created,
                             to_json(info).dump(-1, ' ', false, json::error_handler_t::replace),
                             "application/json", m);
    res.set(http::field::location, "/api/v1/gcode/files/" + info.id);
    return res;
}

// The answer to a save (201 with the file, or the store's refusal), recorded in the audit trail.
string_response saved_response(const api_context& ctx, const program_request& r,
                               const operation_result<gcode_file_info>& saved, const response_meta& meta) {
    auto res = saved ? created_response(*saved, meta) : error_of(saved.error(), meta);
    if (ctx.audit)
        ctx.audit->record(route_audit_entry(r.who, "gcode.upload", saved ? saved->id : "", res.result_int()));
    return res;
}

// The route's work on a program held in `in` (plan, preview) or in memory (save, in-memory bodies).
string_response plan_or_preview(const program_request& r, std::istream& in, const response_meta& m) {
    return r.action == program_action::plan ? plan_response(in, r.query, m)
                                            : preview_response(in, r.query, m);
}

}  // namespace

struct gcode_program_intake::state {
    std::shared_ptr<api_context> ctx;
    program_request request;
    response_meta meta;
    std::optional<gcode_worker::slot> slot;
    std::optional<gcode_upload> upload;

    // On the planner thread, once the whole body is in the upload.
    string_response run() {
        if (request.action == program_action::save) {
            auto saved = ctx->gcode_files->commit(std::move(*upload), request.name);
            upload.reset();
            return saved_response(*ctx, request, saved, meta);
        }
        auto path = upload->contents();
        if (!path) return error_of(path.error(), meta);
        std::ifstream in(*path, std::ios::binary);
        if (!in)
            return error_of(make_error(operation_error_kind::storage_unavailable,
                                       "G-code store: cannot read " + path->string()),
                            meta);
        return plan_or_preview(request, in, meta);
    }
};

gcode_program_intake::gcode_program_intake(std::unique_ptr<state> s) : s_(std::move(s)) {}
gcode_program_intake::~gcode_program_intake() = default;

const std::string& gcode_program_intake::route() const {
    return s_->request.route;
}

std::optional<string_response> gcode_program_intake::append(std::string_view chunk) {
    if (auto ok = s_->upload->append(chunk); !ok) return error_of(ok.error(), s_->meta);
    return std::nullopt;
}

void gcode_program_intake::finish(std::shared_ptr<gcode_program_intake> self,
                                  const net::any_io_executor& session_executor, response_handler done) {
    auto& worker = *self->s_->ctx->gcode_thread;
    auto slot = std::move(*self->s_->slot);
    self->s_->slot.reset();
    worker.post(
        std::move(slot), [self = std::move(self), session_executor, done = std::move(done)]() mutable {
            std::string route = self->route();
            string_response res = self->s_->run();
            self.reset();  // the temporary file is removed here, off the I/O thread
            net::post(session_executor, [done = std::move(done), res = std::move(res), route]() mutable {
                done({std::move(res), route});
            });
        });
}

gcode_program_admission admit_gcode_program(const std::shared_ptr<api_context>& ctx,
                                            const http::request<http::empty_body>& header,
                                            const std::string& request_id,
                                            const std::string& client_address) {
    gcode_program_admission a;
    if (!ctx->gcode_files || !ctx->gcode_thread) return a;  // no store to stream to: bodies stay in memory
    // A refused request is no program: the route table's refusal answers it.
    const auto d = api_routes().decide(*ctx, header, header.keep_alive(), request_id);
    if (d.refusal || !d.chosen || d.chosen->body != route_body::program) return a;
    auto r = program_request_of(d.label, d.who);
    if (!r) return a;
    a.applies = true;
    // The body is not read when refused: the connection closes after the answer.
    response_meta meta{header.version(), false, std::string(header.target()), request_id};
    auto refuse = [&](problem p) {
        a.refusal = routed_response{problem_of(std::move(p), meta), r->route};
        return a;
    };
    if (auto p = check_program_query(header.target(), *r)) return refuse(std::move(*p));
    r->who.request_id = request_id;
    r->who.address = client_address;
    auto slot = ctx->gcode_thread->try_reserve();
    if (!slot) return refuse(planner_busy(*ctx->gcode_thread));
    meta.keep_alive = header.keep_alive();
    auto s = std::make_unique<gcode_program_intake::state>();
    s->ctx = ctx;
    s->request = std::move(*r);
    s->meta = std::move(meta);
    s->slot.emplace(std::move(*slot));
    s->upload.emplace(ctx->gcode_files->begin_upload());
    a.intake = std::make_shared<gcode_program_intake>(std::move(s));
    return a;
}

std::optional<std::uint64_t> gcode_body_limit(const api_context& ctx, http::verb method,
                                              std::string_view target) {
    const auto* r = api_routes().route_for(method, target_path(target));
    if (!r || r->body != route_body::program || !ctx.gcode_files) return std::nullopt;
    return std::max<std::uint64_t>(ctx.gcode_files->settings().max_file_bytes, ctx.limits.max_body_bytes);
}

std::uint64_t max_gcode_body_bytes(const api_context& ctx) {
    return ctx.gcode_files ? ctx.gcode_files->settings().max_file_bytes : 0;
}

namespace {

// The blocking part on the worker thread; its response back on the session's executor.
template <typename Work>
void run_blocking(request_context& c, Work work) {
    // `done` is copied: it answers here when the worker refuses the task.
    auto task = [work = std::move(work), route = c.route, session_executor = c.session_executor,
                 done = c.done]() mutable {
        string_response res = work();
        net::post(session_executor, [done = std::move(done), res = std::move(res), route]() mutable {
            done({std::move(res), route});
        });
    };
    if (!c.ctx->gcode_thread) return task();
    if (!c.ctx->gcode_thread->try_post(std::move(task))) c.fail(planner_busy(*c.ctx->gcode_thread));
}

std::shared_ptr<gcode_file_store> need_store(request_context& c) {
    if (!c.ctx->gcode_files)
        c.fail(
            make_error(operation_error_kind::storage_unavailable, "this gateway has no G-code file store"));
    return c.ctx->gcode_files;
}

// A program in the body, here in memory (http_session streams it to the store when there is one:
// admit_gcode_program).
void program_in_body(request_context& c) {
    auto r = program_request_of(c.route, c.who);
    if (!r) return c.fail(make_problem(http_error::not_found, "no route for " + std::string(c.req.target())));
    if (auto p = check_program_query(c.req.target(), *r)) return c.fail(std::move(*p));
    if (r->action == program_action::save && !need_store(c)) return;
    r->who.request_id = c.request_id;
    r->who.address = c.client_address;
    run_blocking(c, [ctx = c.ctx, body = std::move(c.req.body()), r = std::move(*r), meta = c.meta()]() {
        view_buf buf(body);
        std::istream in(&buf);
        if (r.action != program_action::save) return plan_or_preview(r, in, meta);
        return saved_response(*ctx, r, ctx->gcode_files->save(in, r.name), meta);
    });
}

// A request on the file store without query parameters: `work(store, meta)` on the G-code thread.
template <typename Work>
void on_store(request_context& c, Work work) {
    if (!c.query_with({})) return;
    auto store = need_store(c);
    if (!store) return;
    run_blocking(c, [store, meta = c.meta(), work = std::move(work)]() { return work(*store, meta); });
}

string_response json_ok(const json& body, const response_meta& meta) {
    return body_response(http::status::ok, body.dump(-1, ' ', false, json::error_handler_t::replace),
                         "application/json", meta);
}

void list_files(request_context& c) {
    on_store(c, [](gcode_file_store& store, const response_meta& meta) {
        auto files = store.list();
        if (!files) return error_of(files.error(), meta);
        json list = json::array();
        for (const auto& f : *files)
            list.push_back(to_json(f));
        return json_ok({{"files", std::move(list)}}, meta);
    });
}

void get_file(request_context& c) {
    on_store(c, [id = c.params[0]](gcode_file_store& store, const response_meta& meta) {
        auto info = store.get(id);
        if (!info) return error_of(info.error(), meta);
        return json_ok(to_json(*info), meta);
    });
}

void delete_file(request_context& c) {
    on_store(c, [id = c.params[0], ctx = c.ctx, who = c.as_caller()](gcode_file_store& store,
                                                                     const response_meta& meta) {
        auto removed = store.remove(id);
        auto res =
            removed ? body_response(http::status::no_content, {}, {}, meta) : error_of(removed.error(), meta);
        if (ctx->audit) ctx->audit->record(route_audit_entry(who, "gcode.delete", id, res.result_int()));
        return res;
    });
}

// POST files/{id}/plan, GET files/{id}/preview.svg: as /gcode/plan and /gcode/preview.svg on a stored file.
void stored_file_output(request_context& c, gcode_output output) {
    auto q = c.query();
    if (!q) return;
    auto parsed = parse_gcode_query(*q, output);
    if (!parsed) return c.fail(parsed.error());
    auto store = need_store(c);
    if (!store) return;
    run_blocking(c, [store, id = c.params[0], q = *parsed, meta = c.meta(), output]() {
        auto opened = open_file(*store, id, meta);
        if (auto* res = std::get_if<string_response>(&opened)) return std::move(*res);
        auto& in = std::get<std::ifstream>(opened);
        return output == gcode_output::plan ? plan_response(in, q, meta) : preview_response(in, q, meta);
    });
}

}  // namespace

std::vector<route> gcode_routes() {
    using http::verb;
    const std::string g = "/api/v1/gcode";
    return {
        {verb::post, std::string(plan_route), gw::role::viewer, program_in_body, route_body::program},
        {verb::post, std::string(preview_route), gw::role::viewer, program_in_body, route_body::program},
        {verb::get, g + "/files", gw::role::viewer, list_files},
        {verb::post, std::string(files_route), gw::role::operator_, program_in_body, route_body::program},
        {verb::get, g + "/files/{id}", gw::role::viewer, get_file},
        {verb::delete_, g + "/files/{id}", gw::role::operator_, delete_file},
        {verb::post, g + "/files/{id}/plan", gw::role::viewer,
         [](request_context& c) { stored_file_output(c, gcode_output::plan); }},
        {verb::get, g + "/files/{id}/preview.svg", gw::role::viewer,
         [](request_context& c) { stored_file_output(c, gcode_output::preview); }},
    };
}

}  // namespace gw::api
