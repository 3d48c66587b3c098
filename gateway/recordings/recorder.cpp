#include "gateway/recordings/recorder.hpp"

#include <algorithm>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <iterator>

#include <boost/asio/append.hpp>
#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <spdlog/spdlog.h>

#include "devices/ms2000/command.hpp"
#include "devices/serial/controller_observer.hpp"
#include "gateway/common/job_id.hpp"
#include "gateway/common/timestamp.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/recordings/frame_text.hpp"
#include "gateway/recordings/hdf5_export.hpp"

namespace gw::recordings {

namespace net = boost::asio;
using kind = operation_error_kind;
using std::chrono::steady_clock;
using std::chrono::system_clock;

namespace {

// The firmware's error code for triggers that came faster than it could send their reports.
constexpr int report_overrun_code = 87;
constexpr std::size_t max_name_bytes = 200;

std::int64_t now_ms() {
    return epoch_ms(system_clock::now());
}

std::int64_t epoch_us(system_clock::time_point t) {
    return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
}

std::string new_recording_id() {
    return "r-" + jobs::make_job_id().substr(2);  // the same time-ordered form as job ids
}

operation_error store_error(const std::string& why) {
    return make_error(kind::storage_unavailable, why);
}

}  // namespace

// The registry's events for the recorder: a frame crosses to the recorder's strand only for a
// controller that records.
class recorder::observer final : public devices::controller_observer {
  public:
    explicit observer(std::weak_ptr<recorder> r) : recorder_(std::move(r)) {}
    void on_report(const devices::report_event& e) override {
        auto r = recorder_.lock();
        if (!r || !r->listens(e.controller_id)) return;
        net::post(r->strand_, [r, e] { r->on_frame(e); });
    }
    void on_snapshot(const devices::controller_snapshot& s) override {
        auto r = recorder_.lock();
        if (!r || !r->listens(s.id)) return;
        const bool up = s.state == devices::connection_state::connected &&
                        s.report != devices::report_port_state::none &&
                        s.report != devices::report_port_state::closed;
        net::post(r->strand_, [r, id = s.id, up, state = std::string(devices::to_string(s.state))] {
            if (up)
                r->on_back(id);
            else
                r->on_away(id, state);
        });
    }
    void on_error_log(const devices::error_log_event& e) override {
        auto r = recorder_.lock();
        if (!r || !r->listens(e.controller_id)) return;
        // One code per trigger the controller could not report.
        const auto overruns =
            static_cast<std::size_t>(std::count(e.codes.begin(), e.codes.end(), report_overrun_code));
        if (overruns == 0) return;
        net::post(r->strand_, [r, id = e.controller_id, overruns] { r->on_overrun(id, overruns); });
    }

  private:
    std::weak_ptr<recorder> recorder_;
};

operation_result<std::shared_ptr<recorder>> recorder::open(net::any_io_executor executor,
                                                           controller_registry& registry,
                                                           recorder_settings settings) {
    auto store = recording_store::open(settings.storage_path, settings.max_mb);
    if (!store) return store_error(store.error());
    // What a crashed gateway left recording: its frames after the last stored batch are unknown.
    recording_filter recording_now;
    recording_now.state = recording_state::recording;
    recording_now.limit = 10000;
    auto left = (*store)->list(recording_now);
    if (!left) return store_error(left.error());
    // Their controllers' trigger inputs are still armed: put back once each is connected again.
    std::map<std::string, int> armed;
    for (const auto& r : *left)
        if (r.previous_in_mode) armed[r.controller] = *r.previous_in_mode;
    // Export files a stopped gateway left behind were being sent: nobody waits for them any more.
    std::error_code ignored;
    std::filesystem::remove_all(settings.storage_path + "/exports", ignored);
    for (auto& r : *left) {
        r.state = recording_state::failed;
        r.reason = "the gateway stopped while it recorded: frames after the last stored ones are unknown";
        r.stopped_ms = now_ms();
        if (auto updated = (*store)->update(r); !updated) return store_error(updated.error());
    }
    std::shared_ptr<recorder> out(
        new recorder(std::move(executor), registry, std::move(settings), std::move(*store)));
    for (const auto& [controller, mode] : armed)
        out->listening_.insert(controller);
    out->restore_after_crash_ = armed;  // before anything runs on the strand
    out->attach();
    // A controller connected already sends no new snapshot: its input is put back now.
    for (const auto& [controller, mode] : armed) {
        const auto s = registry.get(controller);
        if (s && s->state == devices::connection_state::connected)
            net::post(out->strand_, [out, controller = controller] { out->on_back(controller); });
    }
    return out;
}

recorder::recorder(net::any_io_executor executor, controller_registry& registry, recorder_settings settings,
                   std::unique_ptr<recording_store> store)
    : executor_(std::move(executor)),
      strand_(net::make_strand(executor_)),
      registry_(registry),
      settings_(std::move(settings)),
      log_(get_logger("gateway")),
      store_(std::move(store)),
      flush_timer_(strand_),
      exports_path_(settings_.storage_path + "/exports") {}

recorder::~recorder() = default;

void recorder::attach() {
    observer_ = std::make_shared<observer>(weak_from_this());
    registry_.add_observer(std::weak_ptr<devices::controller_observer>(observer_));
}

bool recorder::listens(std::string_view controller) const {
    std::lock_guard lock(listening_mutex_);
    return listening_.find(controller) != listening_.end();
}

template <typename T>
void recorder::deliver(recorder_handler<T> h, operation_result<T> r) {
    net::post(executor_, net::append(std::move(h), std::move(r)));
}

template <typename T, typename Read>
void recorder::read(recorder_handler<T> h, Read work) {
    run_on<T>(writer_, std::move(h), [work = std::move(work)](recorder& self) { return work(*self.store_); });
}

template <typename T, typename Work>
void recorder::run_on(worker_thread& worker, recorder_handler<T> h, Work work) {
    auto shared_h = std::make_shared<recorder_handler<T>>(std::move(h));
    const bool queued = worker.post([self = shared_from_this(), work = std::move(work), shared_h]() mutable {
        operation_result<T> result = work(*self);
        // The reference moves on with the result: the writer's thread never holds the last one.
        auto& ex = self->executor_;
        net::post(ex, [self = std::move(self), result = std::move(result), shared_h]() mutable {
            self->deliver<T>(std::move(*shared_h), std::move(result));  // on the handler's own executor
        });
    });
    if (!queued)
        deliver<T>(std::move(*shared_h),
                   make_error(kind::queue_full, "the recordings store is busy: ask again shortly"));
}

// ---------------------------------------------------------------------------------------------
// Exports, on the exporter's thread.

void recorder::export_hdf5(std::string id, recorder_handler<export_file> h) {
    run_on<export_file>(exporter_, std::move(h),
                        [id = std::move(id)](recorder& self) { return self.write_export(id); });
}

operation_result<export_file> recorder::write_export(const std::string& id) {
    if (!export_store_) {
        auto opened = recording_store::open(settings_.storage_path);
        if (!opened) return store_error(opened.error());
        export_store_ = std::move(*opened);
    }
    auto record = export_store_->get(id);
    if (!record) return store_error(record.error());
    if (!*record) return make_error(kind::unknown_recording, "no recording with id \"" + id + "\"", "id");
    std::error_code ec;
    std::filesystem::create_directories(exports_path_, ec);
    export_file out;
    out.record = std::move(**record);
    out.path = fmt::format("{}/{}-{}.h5", exports_path_, id, ++exports_made_);
    auto file = hdf5_export::create(out.path, out.record);
    const auto failed = [&](const std::string& why) -> operation_result<export_file> {
        if (file) file->reset();  // closes it
        std::filesystem::remove(out.path, ec);
        return store_error(why);
    };
    if (!file) return failed(file.error());
    // The rows the record counts: those stored with it (later ones belong to a later read).
    std::uint64_t left = out.record.frames + out.record.losses;
    std::int64_t from = 0;
    while (left > 0) {
        auto page =
            export_store_->rows(id, from, static_cast<std::size_t>(std::min<std::uint64_t>(left, 8192)));
        if (!page) return failed(page.error());
        if (page->rows.empty()) return failed("recording " + id + " lost rows while it was exported");
        if (auto appended = (*file)->append(page->rows); !appended) return failed(appended.error());
        left -= std::min<std::uint64_t>(left, page->rows.size());
        if (!page->next) break;
        from = *page->next;
    }
    if (left > 0) return failed("recording " + id + " has fewer rows than it counts");
    if (auto finished = (*file)->finish(out.record); !finished) return failed(finished.error());
    out.bytes = std::filesystem::file_size(out.path, ec);
    return out;
}

void recorder::read_export(std::string path, std::uint64_t offset, std::size_t max_bytes,
                           recorder_handler<std::string> h) {
    run_on<std::string>(
        exporter_, std::move(h),
        [path = std::move(path), offset, max_bytes](recorder&) -> operation_result<std::string> {
            std::ifstream in(path, std::ios::binary);
            if (!in) return store_error(path + ": cannot open the export");
            in.seekg(static_cast<std::streamoff>(offset));
            std::string piece(max_bytes, '\0');
            in.read(piece.data(), static_cast<std::streamsize>(max_bytes));
            if (in.bad()) return store_error(path + ": cannot read the export");
            piece.resize(static_cast<std::size_t>(in.gcount()));
            return piece;
        });
}

void recorder::remove_export(std::string path) {
    exporter_.post([self = shared_from_this(), path = std::move(path)]() mutable {
        std::error_code ec;
        std::filesystem::remove(path, ec);
        auto& ex = self->executor_;
        net::post(ex, [self = std::move(self)] {});  // the last reference never goes on the exporter's thread
    });
}

// ---------------------------------------------------------------------------------------------
// Start and stop.

void recorder::start(recording_request r, recorder_handler<recording_record> h) {
    net::co_spawn(strand_, run_start(std::move(r), std::move(h)), net::detached);
}

net::awaitable<void> recorder::run_start(recording_request r, recorder_handler<recording_record> h) {
    auto self = shared_from_this();
    const auto refuse = [&](operation_error e) { deliver<recording_record>(std::move(h), std::move(e)); };
    if (shutting_down_) co_return refuse(make_error(kind::not_connected, "the gateway is shutting down"));
    if (r.name.empty() || r.name.size() > max_name_bytes)
        co_return refuse(make_error(kind::invalid_value,
                                    fmt::format("name must be 1 to {} bytes", max_name_bytes), "name"));
    if (r.ttl_in_mode < 1 || r.ttl_in_mode > 30)
        co_return refuse(
            make_error(kind::invalid_value,
                       "arm.ttl_in_mode must be a non-zero TTL input mode (1..30): any non-zero mode "
                       "makes the report module send a frame at each IN0 edge",
                       "arm.ttl_in_mode"));
    const auto snapshot = registry_.get(r.controller);
    if (!snapshot)
        co_return refuse(make_error(kind::unknown_controller, "no controller \"" + r.controller + "\""));
    if (snapshot->state != devices::connection_state::connected || !snapshot->identity)
        co_return refuse(make_error(kind::not_connected, r.controller + " is not connected"));
    if (snapshot->report == devices::report_port_state::none)
        co_return refuse(make_error(kind::invalid_state,
                                    r.controller +
                                        " has no report port: configure its report_port (the TTL_REPORT "
                                        "module's SERIAL OUT) to record",
                                    "controller"));
    if (store_full_)
        co_return refuse(
            make_error(kind::storage_unavailable,
                       "the recordings storage is full (the disk, or storage.recordings_max_mb): "
                       "delete recordings to make room"));
    if (by_controller_.contains(r.controller) || starting_.contains(r.controller))
        co_return refuse(
            make_error(kind::busy, r.controller + " is recording already: one recording at a time"));
    starting_.insert(r.controller);
    std::optional<int> previous;
    if (r.arm) {
        auto armed = co_await arm_input(r);
        if (!armed) {
            starting_.erase(r.controller);
            co_return refuse(armed.error());
        }
        previous = *armed;
    }
    active a;
    a.record.id = new_recording_id();
    a.record.controller = r.controller;
    a.record.name = r.name;
    a.record.started_ms = now_ms();
    a.record.ttl_in_mode = r.ttl_in_mode;
    a.record.previous_in_mode = previous;
    a.record.max_frames = r.max_frames;
    a.record.max_s = r.max_s;
    a.record.metadata = r.metadata.is_object() ? r.metadata : nlohmann::json::object();
    a.record.job = r.job;
    a.started = steady_clock::now();
    const auto id = a.record.id;
    auto first = a.record;
    starting_.erase(r.controller);
    by_controller_[r.controller] = id;
    active_.emplace(id, std::move(a));
    {
        std::lock_guard lock(listening_mutex_);
        listening_.insert(r.controller);
    }
    // Stored before its first rows: the writer runs in order.
    writer_.post([first, self]() mutable {
        std::optional<std::string> refused;
        if (!self->abandoned_)
            if (auto created = self->store_->create(first); !created) refused = created.error();
        // The reference moves on: the writer's thread never holds the last one.
        auto& strand = self->strand_;
        net::post(strand, [self = std::move(self), id = first.id, refused = std::move(refused)] {
            if (refused && self->active_.contains(id))
                net::co_spawn(self->strand_, self->finish(id, recording_state::failed, *refused),
                              net::detached);
        });
    });
    if (previous)
        log_->info("recording {} on {} started (TTL X={}, was {})", id, first.controller, first.ttl_in_mode,
                   *previous);
    else
        log_->info("recording {} on {} started for job {}", id, first.controller, first.job.value_or("-"));
    publish(first, {});
    schedule_flush();
    deliver<recording_record>(std::move(h), std::move(first));
}

net::awaitable<operation_result<int>> recorder::arm_input(const recording_request& r) {
    auto self = shared_from_this();
    // The input mode to put back, then the mode that triggers a report.
    // Named arguments only: g++ 12 mishandles temporaries that live across a co_await.
    std::string controller = r.controller;
    std::string request_id = "recording";
    command_request ask{devices::ms2000::query("TTL", "X"), std::nullopt};
    auto before =
        co_await registry_.async_command(controller, std::move(ask), request_id, net::use_awaitable);
    std::optional<int> previous;
    if (auto armed = restore_after_crash_.find(r.controller); armed != restore_after_crash_.end()) {
        // Armed by a recording the gateway did not end: the mode before that one is the one to restore.
        previous = armed->second;
        restore_after_crash_.erase(armed);
    } else if (before && before->reply.what != devices::ms2000::reply::kind::error) {
        const auto* x = before->reply.axis('X');
        std::optional<double> v = x ? x->number : std::nullopt;
        if (!v) v = before->reply.number(0);
        if (v) previous = static_cast<int>(*v);
    }
    if (!previous)
        co_return before
            ? make_error(kind::controller_error, r.controller + " did not tell its TTL input mode (TTL X?)")
            : before.error();
    ttl_request arm;
    arm.in0_mode = r.ttl_in_mode;
    auto armed = co_await registry_.async_ttl(controller, arm, request_id, net::use_awaitable);
    if (!armed) co_return armed.error();
    co_return *previous;
}

void recorder::stop(std::string id, recorder_handler<recording_record> h) {
    net::co_spawn(strand_, run_stop(std::move(id), std::move(h)), net::detached);
}

net::awaitable<void> recorder::run_stop(std::string id, recorder_handler<recording_record> h) {
    auto self = shared_from_this();
    if (!active_.contains(id)) {
        // Not recording: its stored record says so.
        get(std::move(id), std::move(h));
        co_return;
    }
    auto r = co_await finish(id, recording_state::stopped, "stopped");
    if (!r) co_return deliver<recording_record>(std::move(h), std::move(r));
    // The stored record, read after its end is written: when the store refused rows, it says failed
    // with the counters of what is stored, as every later read will.
    read<recording_record>(std::move(h),
                           [ended = std::move(*r)](recording_store& s) -> operation_result<recording_record> {
                               auto stored = s.get(ended.id);
                               if (stored && *stored) return std::move(**stored);
                               return ended;
                           });
}

net::awaitable<operation_result<recording_record>> recorder::finish(std::string id, recording_state state,
                                                                    std::string reason) {
    auto self = shared_from_this();
    auto it = active_.find(id);
    if (it == active_.end()) co_return make_error(kind::invalid_state, "recording " + id + " has ended");
    auto a = std::move(it->second);
    active_.erase(it);
    by_controller_.erase(a.record.controller);
    {
        std::lock_guard lock(listening_mutex_);
        listening_.erase(a.record.controller);
    }
    a.record.state = state;
    a.record.reason = reason;
    a.record.stopped_ms = now_ms();
    // The input mode back as it was: later edges must not make reports nobody records.
    if (a.record.previous_in_mode) {
        ttl_request back;
        back.in0_mode = *a.record.previous_in_mode;
        std::string controller = a.record.controller;
        std::string request_id = "recording";
        auto put_back = co_await registry_.async_ttl(controller, back, request_id, net::use_awaitable);
        if (!put_back) {
            log_->warn("recording {}: cannot put TTL X={} back on {}: {}", id, *a.record.previous_in_mode,
                       a.record.controller, put_back.error().message);
            a.record.reason += fmt::format(" (TTL X={} could not be put back: {})",
                                           *a.record.previous_in_mode, put_back.error().message);
        }
    }
    // What a crashed gateway left armed there waits while a recording runs (a job's sets no input).
    put_back_left_by_crash(a.record.controller);
    auto rows = std::move(a.buffer);
    auto record = a.record;
    publish(record, rows);
    if (settings_.hub) (void)settings_.hub->retire_topic("recordings/" + id, settings_.ended_topic_ttl);
    writer_.post([self, record, rows = std::move(rows)]() mutable {
        if (!self->abandoned_) self->store_end(record, rows);
        auto& ex = self->executor_;
        net::post(ex, [self = std::move(self)] {});  // the last reference never goes on the writer's thread
    });
    log_->info("recording {} on {} {}: {} frames, {} losses{}{}", id, record.controller, to_string(state),
               record.frames, record.losses, reason.empty() ? "" : ": ", reason);
    co_return record;
}

void recorder::store_end(const recording_record& record, std::span<const recorded_frame> rows) {
    if (!broken_.contains(record.id) && store_->append(record, rows)) return;
    // Rows are missing (refused now or before): the record keeps the counters of what is stored, so
    // that its downloads hold what it counts, and says how it ended.
    broken_.erase(record.id);
    auto stored = store_->get(record.id);
    if (!stored || !*stored) return;
    auto ended = **stored;
    ended.state = recording_state::failed;
    ended.reason = record.state == recording_state::failed
                       ? record.reason
                       : "the store refused its last frames (" + record.reason + ")";
    ended.stopped_ms = record.stopped_ms;
    if (auto updated = store_->update(ended); !updated)
        log_->error("recording {}: its end cannot be stored: {}", record.id, updated.error());
}

void recorder::shutdown(std::function<void()> done) {
    net::co_spawn(
        strand_,
        [self = shared_from_this(), done = std::move(done)]() mutable -> net::awaitable<void> {
            self->shutting_down_ = true;
            self->flush_timer_.cancel();
            std::vector<std::string> ids;
            for (const auto& [id, a] : self->active_)
                ids.push_back(id);
            for (const auto& id : ids)
                (void)co_await self->finish(id, recording_state::stopped, "the gateway stopped");
            // After every write queued before it.
            self->writer_.post([self, done = std::move(done)]() mutable {
                auto& ex = self->executor_;
                net::post(ex, [self = std::move(self), done = std::move(done)] { done(); });
            });
        },
        net::detached);
}

void recorder::abandon() {
    abandoned_ = true;  // the writer skips what waits
    {
        std::lock_guard lock(listening_mutex_);
        listening_.clear();
    }
    net::post(strand_, [self = shared_from_this()] {
        self->shutting_down_ = true;
        self->flush_timer_.cancel();
        self->active_.clear();
        self->by_controller_.clear();
    });
}

// ---------------------------------------------------------------------------------------------
// Frames, on the strand.

void recorder::on_frame(const devices::report_event& e) {
    auto id = by_controller_.find(e.controller_id);
    if (id == by_controller_.end()) return;
    auto& a = active_.at(id->second);
    if (a.ending) return;  // a limit was reached: what comes after it is not part of it
    if (a.bytes_skipped && e.bytes_skipped > *a.bytes_skipped) add_marker(a, loss_kind::garbled);
    a.bytes_skipped = e.bytes_skipped;
    if (a.record.axes.empty())
        for (const auto& axis : e.axes)
            a.record.axes.push_back(axis.letter);
    recorded_frame f;
    f.index = a.record.frames;
    f.time_us = epoch_us(e.system_time);
    for (const auto& axis : e.axes) {
        f.counts.push_back(axis.counts);
        f.um.push_back(axis.position_um);
    }
    a.buffer.push_back(std::move(f));
    ++a.record.frames;
    check_limits(a);
}

void recorder::add_marker(active& a, loss_kind kind) {
    recorded_frame m;
    m.index = a.record.frames;  // the frames lost came before the frame of this index
    m.time_us = epoch_us(system_clock::now());
    m.loss = kind;
    a.buffer.push_back(std::move(m));
    ++a.record.losses;
}

void recorder::on_away(const std::string& controller, const std::string& why) {
    auto id = by_controller_.find(controller);
    if (id == by_controller_.end()) return;
    auto& a = active_.at(id->second);
    if (a.away) return;
    a.away = true;
    log_->warn("recording {}: {} is {}: its triggers meanwhile are unknown", a.record.id, controller, why);
    add_marker(a, loss_kind::disconnected);
}

void recorder::on_back(const std::string& controller) {
    auto id = by_controller_.find(controller);
    if (id != by_controller_.end()) active_.at(id->second).away = false;
    put_back_left_by_crash(controller);
}

void recorder::put_back_left_by_crash(const std::string& controller) {
    auto armed = restore_after_crash_.find(controller);
    if (armed == restore_after_crash_.end() || starting_.contains(controller) ||
        by_controller_.contains(controller))
        return;
    const int mode = armed->second;
    restore_after_crash_.erase(armed);
    {
        std::lock_guard lock(listening_mutex_);
        listening_.erase(controller);
    }
    net::co_spawn(strand_, put_back_after_crash(controller, mode), net::detached);
}

net::awaitable<void> recorder::put_back_after_crash(std::string controller, int mode) {
    auto self = shared_from_this();
    ttl_request back;
    back.in0_mode = mode;
    std::string request_id = "recording";
    auto put_back = co_await registry_.async_ttl(controller, back, request_id, net::use_awaitable);
    if (put_back)
        log_->info("{}: TTL X={} put back, as before the recording the gateway did not end", controller,
                   mode);
    else
        log_->warn("{}: cannot put TTL X={} back after a recording the gateway did not end: {}", controller,
                   mode, put_back.error().message);
}

void recorder::on_overrun(const std::string& controller, std::size_t count) {
    auto id = by_controller_.find(controller);
    if (id == by_controller_.end()) return;
    for (std::size_t i = 0; i < count; ++i)
        add_marker(active_.at(id->second), loss_kind::overrun);
}

void recorder::check_limits(active& a) {
    const bool frames_done = a.record.max_frames && a.record.frames >= *a.record.max_frames;
    const bool time_done =
        a.record.max_s &&
        std::chrono::duration<double>(steady_clock::now() - a.started).count() >= *a.record.max_s;
    if (a.ending || (!frames_done && !time_done)) return;
    a.ending = true;
    // Frames that arrive before the input mode is put back are not recorded (listening ends now).
    {
        std::lock_guard lock(listening_mutex_);
        listening_.erase(a.record.controller);
    }
    const auto why = frames_done ? fmt::format("max_frames ({}) reached", *a.record.max_frames)
                                 : fmt::format("max_s ({} s) reached", *a.record.max_s);
    net::co_spawn(strand_, finish(a.record.id, recording_state::stopped, why), net::detached);
}

// ---------------------------------------------------------------------------------------------
// Into the store.

void recorder::schedule_flush() {
    if (flush_scheduled_ || shutting_down_ || active_.empty()) return;
    flush_scheduled_ = true;
    // A fixed period, not an interval after the flush's own work: the write window stays
    // flush_interval (one late tick does not push the later ones back).
    const auto now = steady_clock::now();
    next_flush_ = std::max(next_flush_ + settings_.flush_interval, now);
    flush_timer_.expires_at(next_flush_);
    flush_timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
        self->flush_scheduled_ = false;
        if (ec) return;
        self->flush();
        self->schedule_flush();
    });
}

void recorder::flush() {
    for (auto& [id, a] : active_)
        check_limits(a);  // max_s is checked here too: a recording whose triggers stopped still ends in time
    if (hand_over()) return;
    std::vector<std::string> failed;
    for (auto& [id, a] : active_)
        if (a.buffer.size() > settings_.max_buffered_rows) failed.push_back(id);
    for (const auto& id : failed)
        net::co_spawn(strand_,
                      finish(id, recording_state::failed,
                             "the recordings store could not keep up: frames were waiting beyond the limit"),
                      net::detached);
}

bool recorder::hand_over() {
    // Every recording's new rows in one batch: one transaction, one disk flush, however many record.
    auto batches = std::make_shared<std::vector<row_batch>>();
    for (auto& [id, a] : active_)
        if (!a.buffer.empty()) batches->push_back({a.record, std::move(a.buffer)});
    if (batches->empty()) return true;
    const bool queued = writer_.post([self = shared_from_this(), batches]() mutable {
        if (self->abandoned_) {
            auto& ex = self->executor_;
            return net::post(ex, [self = std::move(self)] {});
        }
        // A recording whose rows the store refused before takes no more: its rows would follow a hole.
        // (The batches stay as they are: the strand reads them too, to publish.)
        const std::vector<row_batch>* to_store = batches.get();
        std::vector<row_batch> kept;
        const auto broken = [&](const row_batch& b) { return self->broken_.contains(b.record.id); };
        if (std::any_of(batches->begin(), batches->end(), broken)) {
            std::copy_if(batches->begin(), batches->end(), std::back_inserter(kept),
                         [&](const row_batch& b) { return !broken(b); });
            to_store = &kept;
        }
        auto appended = self->store_->append_all(*to_store);
        self->store_full_ = !appended && self->store_->last_write_was_full();
        std::vector<std::string> ids;
        for (const auto& b : *to_store) {
            ids.push_back(b.record.id);
            if (!appended) self->broken_.insert(b.record.id);
        }
        auto& strand = self->strand_;
        net::post(
            strand, [self = std::move(self), ids = std::move(ids), appended = std::move(appended)]() mutable {
                if (appended) return;
                for (const auto& id : ids) {
                    if (!self->active_.contains(id)) continue;
                    self->log_->error("recording {}: its frames cannot be stored: {}", id, appended.error());
                    net::co_spawn(self->strand_,
                                  self->finish(id, recording_state::failed,
                                               "the store refused its frames: " + appended.error()),
                                  net::detached);
                }
            });
    });
    if (!queued) {
        // Kept for the next flush, in order.
        for (auto& b : *batches) {
            auto& a = active_.at(b.record.id);
            b.rows.insert(b.rows.end(), std::make_move_iterator(a.buffer.begin()),
                          std::make_move_iterator(a.buffer.end()));
            a.buffer = std::move(b.rows);
        }
        return false;
    }
    for (const auto& b : *batches)
        publish(b.record, b.rows);
    return true;
}

void recorder::publish(const recording_record& r, std::span<const recorded_frame> rows) {
    if (!settings_.hub) return;
    (void)settings_.hub->publish("recordings/" + r.id,
                                 std::make_shared<const std::string>(live_event_json(r, rows)));
}

// ---------------------------------------------------------------------------------------------
// Reads, on the writer's thread after the writes before them.

void recorder::get(std::string id, recorder_handler<recording_record> h) {
    read<recording_record>(
        std::move(h), [id = std::move(id)](recording_store& s) -> operation_result<recording_record> {
            auto r = s.get(id);
            if (!r) return store_error(r.error());
            if (!*r) return make_error(kind::unknown_recording, "no recording with id \"" + id + "\"", "id");
            return std::move(**r);
        });
}

void recorder::list(recording_filter f, recorder_handler<std::vector<recording_record>> h) {
    read<std::vector<recording_record>>(
        std::move(h),
        [f = std::move(f)](recording_store& s) -> operation_result<std::vector<recording_record>> {
            auto r = s.list(f);
            if (!r) return store_error(r.error());
            return std::move(*r);
        });
}

void recorder::remove(std::string id, recorder_handler<bool> h) {
    net::post(strand_, [self = shared_from_this(), id = std::move(id), h = std::move(h)]() mutable {
        if (self->active_.contains(id))
            return self->deliver<bool>(
                std::move(h),
                make_error(kind::invalid_state, "recording " + id + " is recording: stop it first", "state"));
        self->read<bool>(
            std::move(h), [id, full = &self->store_full_](recording_store& s) -> operation_result<bool> {
                auto r = s.remove(id);
                if (!r) return store_error(r.error());
                if (*r) *full = false;  // room again, perhaps
                if (!*r)
                    return make_error(kind::unknown_recording, "no recording with id \"" + id + "\"", "id");
                return true;
            });
    });
}

void recorder::rows(std::string id, std::int64_t from, std::size_t limit, recorder_handler<frame_page> h) {
    read<frame_page>(
        std::move(h), [id = std::move(id), from, limit](recording_store& s) -> operation_result<frame_page> {
            auto known = s.get(id);
            if (!known) return store_error(known.error());
            if (!*known)
                return make_error(kind::unknown_recording, "no recording with id \"" + id + "\"", "id");
            auto r = s.rows(id, from, limit);
            if (!r) return store_error(r.error());
            return std::move(*r);
        });
}

}  // namespace gw::recordings
