#include "gateway/jobs/manager/run_recording.hpp"

#include <exception>
#include <fmt/format.h>
#include <optional>
#include <string>
#include <utility>

#include <boost/asio/async_result.hpp>
#include <boost/asio/use_awaitable.hpp>

#include "gateway/jobs/job_commands.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/jobs/manager/job_execution.hpp"
#include "gateway/recordings/recorder.hpp"

namespace gw::jobs {

namespace net = boost::asio;
using recordings::recording_record;

namespace {

// One recorder call, awaited: its answer comes back on the run's strand.
template <typename Call>
net::awaitable<operation_result<recording_record>> ask(Call call) {
    co_return co_await net::async_initiate<const net::use_awaitable_t<>&,
                                           void(operation_result<recording_record>)>(
        [&call](auto handler) { call(recordings::recorder_handler<recording_record>(std::move(handler))); },
        net::use_awaitable);
}

net::awaitable<recording_record> start_recording(recordings::recorder& recorder, job_execution& exec) {
    const auto& job = exec.job();
    recordings::recording_request request;
    request.controller = job.controller;
    request.name = fmt::format("{} job {}", to_string(job.type), job.id);
    request.arm = false;  // the run sets the input (run_recorded)
    request.job = job.id;
    request.metadata = {
        {"job", job.id}, {"job_type", std::string(to_string(job.type))}, {"first_step", exec.first_step()}};
    // Named callables: g++ 12 mishandles temporaries that live across a co_await.
    auto call = [&recorder, &request](auto h) { recorder.start(std::move(request), std::move(h)); };
    auto started = co_await ask(std::move(call));
    if (!started) {
        auto e = started.error();
        e.message = "cannot record (spec.record): " + e.message;
        throw job_failure(std::move(e));
    }
    exec.emit("recording", {{"recording", started->id}, {"state", "recording"}, {"name", started->name}});
    co_return std::move(*started);
}

// The input's mode before the run set it; nothing when it was on already (the mode stays as it is).
net::awaitable<std::optional<int>> switch_input_on(job_execution& exec) {
    auto before = co_await exec.settings_before("TTL", "X");
    const int mode = static_cast<int>(before.at('X'));
    if (mode != 0) co_return std::nullopt;
    exec.restore_if_stopped(ttl_in0_command(mode));
    co_await exec.command(ttl_in0(1));
    co_return mode;
}

// Never throws: the run's own end is what the job reports.
net::awaitable<void> stop_recording(recordings::recorder& recorder, job_execution& exec, std::string id) {
    auto call = [&recorder, &id](auto h) { recorder.stop(id, std::move(h)); };
    auto stopped = co_await ask(std::move(call));
    if (!stopped) {
        exec.emit("recording",
                  {{"recording", id}, {"state", "unknown"}, {"reason", stopped.error().message}});
        co_return;
    }
    exec.emit("recording", {{"recording", id},
                            {"state", to_string(stopped->state)},
                            {"reason", stopped->reason},
                            {"frames", stopped->frames},
                            {"losses", stopped->losses}});
}

}  // namespace

net::awaitable<void> run_recorded(std::shared_ptr<recordings::recorder> recorder, job_execution& exec) {
    if (!recorder)
        throw job_failure(make_error(operation_error_kind::invalid_state,
                                     "cannot record (spec.record): this gateway keeps no recordings"));
    auto recording = co_await start_recording(*recorder, exec);
    std::exception_ptr failed;
    try {
        auto before = co_await switch_input_on(exec);
        co_await run_job(exec);
        if (before) co_await exec.command(ttl_in0(*before));
    } catch (...) {
        failed = std::current_exception();
    }
    co_await stop_recording(*recorder, exec, recording.id);
    if (failed) std::rethrow_exception(failed);
}

}  // namespace gw::jobs
