#pragma once
// The recorder: records the report port's frames of a controller (recording.hpp) into the recordings
// store. start() arms the trigger input (TTL X=<mode>, remembering the mode before; a job's run arms it
// itself), counts frames from 0 as the controller sends them and marks where frames were lost; stop(),
// a limit (max_frames, max_s) or shutdown puts the previous input mode back. One recording at a time
// per controller.
//
// Threads: public methods may be called from any thread; handlers run on their associated executor (by
// default the executor given to open()), never inline. Frames arrive from the registry's observer on the
// controllers' strands and cross to the recorder's strand only for a controller that records. Every
// flush_interval the strand hands each recording's new rows to the writer, a thread of its own that owns
// the store (so the disk never holds up an I/O thread); reads run there too, after the writes before
// them.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/any_completion_handler.hpp>
#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/awaitable.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

#include "devices/serial/controller_events.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/common/worker_thread.hpp"
#include "gateway/recordings/recording.hpp"
#include "gateway/recordings/recording_store.hpp"

namespace spdlog {
class logger;
}

namespace gw {
class controller_registry;
class event_hub;
}  // namespace gw

namespace gw::devices {
class controller_observer;
}

namespace gw::recordings {

struct recorder_settings {
    std::string storage_path;                       // <storage_path>/recordings.sqlite3
    std::chrono::milliseconds flush_interval{250};  // how often rows go to the store (what a crash may lose)
    std::size_t max_buffered_rows = 100'000;        // per recording, waiting for the store: beyond, it fails
    std::size_t max_mb = 0;                         // storage.recordings_max_mb: the file's bound (0: none)
    // The live topic recordings/<id>: each flush's rows as one event, and the end (null: none).
    std::shared_ptr<event_hub> hub{};
    std::chrono::milliseconds ended_topic_ttl{60'000};  // an ended recording's topic, for late viewers
};

template <typename T>
using recorder_handler = boost::asio::any_completion_handler<void(operation_result<T>)>;

// A recording written into a file of its own for a download (hdf5_export.hpp).
struct export_file {
    std::string path;  // under <storage>/exports/: remove_export() it once sent
    recording_record record;
    std::uint64_t bytes = 0;
};

class recorder : public std::enable_shared_from_this<recorder> {
  public:
    // Opens the store; recordings a crashed gateway left recording are marked failed (what came after
    // their last stored batch is unknown). The error names the file.
    static operation_result<std::shared_ptr<recorder>> open(boost::asio::any_io_executor executor,
                                                            controller_registry& registry,
                                                            recorder_settings settings);
    ~recorder();

    void start(recording_request r, recorder_handler<recording_record> h);
    void stop(std::string id, recorder_handler<recording_record> h);
    void get(std::string id, recorder_handler<recording_record> h);
    void list(recording_filter f, recorder_handler<std::vector<recording_record>> h);
    // Refused while it records (stop it first).
    void remove(std::string id, recorder_handler<bool> h);
    // A page of a recording's rows (frames and loss markers) in order, from row `from` (0: the first).
    void rows(std::string id, std::int64_t from, std::size_t limit, recorder_handler<frame_page> h);
    // The recording as stored now, as an HDF5 file under <storage>/exports/, written on the exporter's
    // thread (with a reading connection of its own: the writer goes on meanwhile).
    void export_hdf5(std::string id, recorder_handler<export_file> h);
    // Up to `max_bytes` of an export file from `offset` (empty at its end), read on the exporter's thread.
    void read_export(std::string path, std::uint64_t offset, std::size_t max_bytes,
                     recorder_handler<std::string> h);
    // Removes an export file (on the exporter's thread).
    void remove_export(std::string path);
    // Stops every recording (their input modes put back), stores what waits, then calls `done`.
    void shutdown(std::function<void()> done);
    // Like a crash: nothing more is recorded, written or put back (the next open marks the recordings
    // failed).
    void abandon();

  private:
    struct active {
        recording_record record;                     // counters include `buffer`
        std::vector<recorded_frame> buffer;          // rows not yet handed to the writer
        std::optional<std::uint64_t> bytes_skipped;  // the decoder's count at the last frame
        bool away = false;                           // the controller is away; a marker stands for it
        bool ending = false;                         // a limit was reached: it ends and takes no more frames
        std::chrono::steady_clock::time_point started;
    };
    class observer;

    recorder(boost::asio::any_io_executor executor, controller_registry& registry, recorder_settings settings,
             std::unique_ptr<recording_store> store);
    void attach();
    // The controller records now (any thread: the controllers' strands ask for every frame).
    bool listens(std::string_view controller) const;

    boost::asio::awaitable<void> run_start(recording_request r, recorder_handler<recording_record> h);
    // Reads the trigger input's mode (TTL X?), then sets the request's: the mode to put back at the end.
    boost::asio::awaitable<operation_result<int>> arm_input(const recording_request& r);
    boost::asio::awaitable<void> run_stop(std::string id, recorder_handler<recording_record> h);
    boost::asio::awaitable<operation_result<recording_record>> finish(std::string id, recording_state state,
                                                                      std::string reason);
    // On the strand.
    void on_frame(const devices::report_event& e);
    void on_away(const std::string& controller, const std::string& why);
    void on_back(const std::string& controller);
    // The input mode a crashed gateway's recording left armed on the controller, put back unless a
    // recording runs or starts there now.
    void put_back_left_by_crash(const std::string& controller);
    boost::asio::awaitable<void> put_back_after_crash(std::string controller, int mode);
    // `count` triggers the controller could not report (error 87 in its log): one marker each.
    void on_overrun(const std::string& controller, std::size_t count);
    void add_marker(active& a, loss_kind kind);
    void check_limits(active& a);
    void flush();
    void schedule_flush();
    // Hands every recording's buffered rows to the writer, as one batch; false when the writer has too
    // much waiting (the rows stay buffered).
    bool hand_over();
    // The rows on the live topic, with the record's state and counters.
    void publish(const recording_record& r, std::span<const recorded_frame> rows);

    // On the writer's thread: a recording's last rows and its end, or, when rows of it are missing, its
    // end with the counters of what is stored.
    void store_end(const recording_record& record, std::span<const recorded_frame> rows);
    // Runs `work(*this)` on `worker` and posts its result to `h`.
    template <typename T, typename Work>
    void run_on(worker_thread& worker, recorder_handler<T> h, Work work);
    // Runs `work(store)` on the writer's thread (after the writes before it) and posts its result to `h`.
    template <typename T, typename Read>
    void read(recorder_handler<T> h, Read work);
    // On the exporter's thread.
    operation_result<export_file> write_export(const std::string& id);
    template <typename T>
    void deliver(recorder_handler<T> h, operation_result<T> r);

    boost::asio::any_io_executor executor_;
    boost::asio::strand<boost::asio::any_io_executor> strand_;
    controller_registry& registry_;
    recorder_settings settings_;
    std::shared_ptr<spdlog::logger> log_;
    std::shared_ptr<recording_store> store_;  // the writer's thread only
    boost::asio::steady_timer flush_timer_;
    bool flush_scheduled_ = false;
    std::chrono::steady_clock::time_point next_flush_{};  // strand: when the next flush is due
    bool shutting_down_ = false;
    std::atomic<bool> abandoned_{false};  // any thread
    // The store refused rows for want of room (the disk or max_mb) and nothing was deleted since: new
    // recordings are refused. Set and cleared by the writer.
    std::atomic<bool> store_full_{false};

    std::map<std::string, active> active_;              // strand: by recording id
    std::map<std::string, std::string> by_controller_;  // strand: controller -> recording id
    std::set<std::string> starting_;                    // strand: controllers being armed
    // strand: controllers whose trigger input a crashed gateway left armed, and the mode to put back
    // once they are connected (or the mode a new recording there restores at its end).
    std::map<std::string, int> restore_after_crash_;

    mutable std::mutex listening_mutex_;  // the controllers' strands read it for every frame
    std::set<std::string, std::less<>> listening_;
    std::shared_ptr<devices::controller_observer> observer_;

    std::string exports_path_;                       // <storage>/exports
    std::set<std::string> broken_;                   // the writer's thread only: recordings with rows refused
    std::unique_ptr<recording_store> export_store_;  // the exporter's thread only (opened there)
    std::uint64_t exports_made_ = 0;                 // the exporter's thread only: file names
    worker_thread writer_{256};   // destroyed before the stores, so no write runs on a store that is gone
    worker_thread exporter_{16};  // likewise
};

}  // namespace gw::recordings
