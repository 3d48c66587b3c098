#pragma once
// The simulated MS-2000 itself: framing, command language, motion and firmware modules, driven by
// simulated time that the caller passes in (no clock inside, no I/O). The simulator shell feeds it
// the bytes a client writes and sends back what it returns, paced at the baud rate.
//
// Behaviour choices where the protocol doc is [U] (documented here so the driver can rely on them):
//  * Moves beyond SETUP/SETLOW are clamped to the limit, answered ":A", and error 34 (upper) / 35
//    (lower) is appended to the DU Y error buffer.
//  * LOAD into a full ring buffer answers ":N-5".
//  * INFO for an axis the build lacks answers nothing at all (PYM detects axes that way).
//  * "BU" answers the bare build name, like BU X's first line ("STD_XYZ\r\n", no ":A").
//  * "DU Y" answers ":A <code> <code> ... " (oldest first); "DU X" clears it.
//  * An ARRAY self-scan visits the wells serpentine (row 1 left to right, row 2 right to left, ...);
//    that is what makes the seed's "96 well-plate" times come out (95 moves of 9 mm).
//  * A stray 0xFF starts a two-byte low-level setup command, which is swallowed without a reply.

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "devices/ms2000/build_info.hpp"
#include "devices/sim/axis_motion.hpp"
#include "devices/sim/command_line.hpp"
#include "devices/sim/sim_config.hpp"

namespace gw::devices::sim {

// Bytes that leave on a port at a given simulated time.
struct timed_output {
    sim_time at{0};
    std::string bytes;
};

class ms2000_model {
  public:
    static constexpr std::size_t max_line_bytes = 256;
    static constexpr std::size_t ring_buffer_slots = 50;

    explicit ms2000_model(sim_config config);

    // Framing: CR ends a command, LF is ignored, DEL/BS flush the line, XON/XOFF are ignored.
    // Returns the replies of every command completed by `bytes`, in order.
    std::string feed(std::string_view bytes, sim_time now);

    // One command line (without CR). Returns the reply bytes (with CR LF), or "" when the command
    // answers nothing (empty line with empty_line_reply::ignore, INFO of an absent axis).
    std::string handle_line(std::string_view line, sim_time now);

    // Runs motion and module state machines up to `now`.
    void advance(sim_time now);
    // When advance() has something to do next (a move ends, a dwell ends, a flash write ends).
    std::optional<sim_time> next_event() const;
    // Delayed main-port output that is due by `now` (SS Z's "A\r\n"), oldest first.
    std::vector<timed_output> take_output(sim_time now);

    // A TTL edge on IN0. With TTL_REPORT_INT and TTL X != 0, returns the report frame to send on the
    // report port and the time its transmission starts; otherwise acts per the IN0 mode.
    std::optional<timed_output> ttl_pulse(sim_time now);

    // Read access for the shell and the tests.
    const sim_config& config() const { return config_; }
    bool busy(sim_time now) const;
    // When every axis has settled, if nothing new is started (end of the current motion).
    sim_time idle_at() const { return motion_done_at(); }
    double position_mm(char axis, sim_time now) const;
    double position_units(char axis, sim_time now) const;  // what WHERE prints
    const std::vector<int>& error_buffer() const { return errors_; }
    char array_state() const { return array_.state; }
    std::size_t ring_buffer_count() const { return ring_.slots.size(); }
    int ttl_in_mode() const { return ttl_.in0_mode; }
    std::uint64_t reports_sent() const { return reports_sent_; }
    nlohmann::json state(sim_time now) const;

    // Fault injection: the next command with this verb (canonical: "MOVE" also for "M") is answered
    // ":N<code>" and not carried out, as a controller that refuses it would.
    void refuse_next(std::string_view verb, int code);

  private:
    struct axis {
        char letter = 'X';
        axis_motion motion;      // current or last motion
        bool commanded = false;  // the running motion came from a serial command (STATUS 'B')
        std::map<std::string, double, std::less<>> params;  // SPEED, ACCEL, PCROS, ...
        double last_relative_mm = 0;                        // for TTL IN0 mode 2
        // A SPIN/VECTOR motion that runs into the soft limit logs 34/35 when it gets there.
        int limit_error_ahead = 0;
    };

    struct ring_state {
        std::vector<std::array<double, 4>> slots;  // units per axis (up to four axes)
        std::size_t pointer = 0;
        int axis_byte = 3;
        int mode = 1;  // 1 TTL-triggered, 2 one-shot autoplay, 3 repeating autoplay
        bool autoplay = false;
        bool waiting_arrival = false;
        std::optional<sim_time> next_step;
    };

    struct array_state_t {
        int columns = 12, rows = 8;
        double dx_mm = 9.0, dy_mm = -9.0;
        double home_x_mm = 0, home_y_mm = 0;
        char state = 'I';  // I S M D A N C E
        int index = -1;    // serpentine index of the current well
        bool self_scan = false;
        bool graceful = false;  // started with RM X=0: stop after the last well
        std::optional<sim_time> next_step;
    };

    struct scan_state {
        double r_start = 0, r_stop = 1, v_start = 0, v_stop = 0;
        int divide = 24, pixels = 0, lines = 1;
        double retrace_pct = 100;
        int fast_axis = 0, slow_axis = 1, pattern = 0;  // 0 raster, 1 serpentine
        bool running = false;
        int line = 0;
        int phase = 0;  // 0 going to line start, 1 scanning the line
    };

    struct ttl_state {
        int in0_mode = 0, out0_mode = 0, aux_state = 0, polarity = 1, aux_mask = 0, aux_mode = 0;
    };

    // Reply shapes (doc §2.6; kept in one place so they can follow real captures).
    std::string ack() const;
    std::string values(const std::vector<std::string>& items) const;
    std::string axes_a(const std::vector<std::pair<char, std::string>>& items) const;      // ":A X=1 "
    std::string axes_colon(const std::vector<std::pair<char, std::string>>& items) const;  // ":X=1 A"
    std::string axes_led(const std::vector<std::pair<char, std::string>>& items) const;    // "X=1 :A"
    static std::string error(int code);

    std::string dispatch(const command_line& cmd, sim_time now);
    std::optional<sim_time> next_internal_event() const;
    axis* find_axis(char letter);
    const axis* find_axis(char letter) const;
    double units_per_mm(const axis& a) const;
    // A move to `target_mm`, clamped to the soft limits (34/35 logged when it had to be).
    void start_move(axis& a, double target_mm, sim_time now, bool commanded = true,
                    double speed_override = 0);
    // A move to `target_mm` inside [lower_mm, upper_mm] (its approach leg included), no clamping.
    void start_move_between(axis& a, double target_mm, double lower_mm, double upper_mm, sim_time now,
                            bool commanded, double speed_override);
    void stop_all(sim_time now);
    bool commanded_busy(sim_time now) const;
    sim_time motion_done_at() const;  // when every axis is settled
    void log_error(int code);

    // Core commands.
    std::string cmd_move(const command_line& cmd, sim_time now, bool relative);
    std::string cmd_where(const command_line& cmd, sim_time now);
    std::string cmd_here(const command_line& cmd, sim_time now);
    std::string cmd_home(const command_line& cmd, sim_time now);
    std::string cmd_sethome(const command_line& cmd, sim_time now);
    std::string cmd_rdstat(const command_line& cmd, sim_time now);
    std::string cmd_rdsbyte(const command_line& cmd, sim_time now);
    std::string cmd_joystick(const command_line& cmd);
    std::string cmd_velocity(const command_line& cmd, sim_time now);
    void start_velocity(axis& a, double velocity_mm_s, sim_time now);
    int status_byte(const axis& a, sim_time now) const;
    // Where motion up / down ends: the soft limit (SU/SL) or the limit switch, whichever comes first.
    double upper_stop(const axis& a) const;
    double lower_stop(const axis& a) const;
    std::string cmd_axis_param(const command_line& cmd, sim_time now);
    std::string cmd_build(const command_line& cmd);
    std::string cmd_info(const command_line& cmd, sim_time now);
    std::string cmd_dump(const command_line& cmd);
    std::string cmd_saveset(const command_line& cmd, sim_time now);
    std::string cmd_rtime(const command_line& cmd, sim_time now);
    std::string cmd_ttl(const command_line& cmd);
    std::string cmd_zstack(const command_line& cmd, sim_time now);
    void zstack_pulse(sim_time now);
    void queue_output(sim_time at, std::string bytes);
    std::string position_report_line(sim_time at) const;

    // Modules (ms2000_model_modules.cpp).
    std::string cmd_load(const command_line& cmd, sim_time now);
    std::string cmd_rbmode(const command_line& cmd, sim_time now);
    std::string cmd_array(const command_line& cmd, sim_time now);
    std::string cmd_ahome(const command_line& cmd, sim_time now);
    std::string cmd_aij(const command_line& cmd, sim_time now);
    std::string cmd_scanr(const command_line& cmd);
    std::string cmd_scanv(const command_line& cmd);
    std::string cmd_scan(const command_line& cmd, sim_time now);
    std::string cmd_wrdac(const command_line& cmd);
    std::string cmd_led(const command_line& cmd);
    std::string cmd_customb(const command_line& cmd, sim_time now);
    std::string cmd_lock(const command_line& cmd, sim_time now);
    std::string cmd_afocus(const command_line& cmd, sim_time now);
    std::string cmd_extra(const command_line& cmd, sim_time now) const;
    // CRISP's readings now: focus error (nm of Z from the lock's set point), sum, signal-to-noise.
    struct crisp_reading {
        long focus_error = 0;
        long sum = 0;
        double snr = 0;
    };
    crisp_reading crisp_read(sim_time now) const;
    void crisp_settle_lock(sim_time now);

    void ring_next(sim_time now);
    void array_start(sim_time now, bool self_scan, bool graceful);
    void array_next(sim_time now);
    void array_move_to(int index, sim_time now);
    std::pair<int, int> array_cell(int index) const;  // serpentine index -> (column, row), 1-based
    void scan_step(sim_time now);
    double planar_offset_units(double x_units, double y_units) const;

    sim_config config_;
    ms2000::build_info build_;
    lead_screw screw_;
    std::vector<axis> axes_;
    std::string line_;
    bool low_level_pending_ = false;
    bool halted_fast_ = false;          // a fast-path HALT was just handled: a CR right after it is its own
    std::deque<timed_output> pending_;  // delayed main-port output
    std::vector<int> errors_;           // DU Y
    ring_state ring_;
    array_state_t array_;
    scan_state scan_;
    ttl_state ttl_;
    double rt_report_ms_ = 200, rt_dwell_ms_ = 0, rt_f_ = 1;
    // Serial position reports ("RT M+", or TTL X=5 pulses): "T:   400    0.0    0.1" lines.
    bool reporting_ = false;
    sim_time report_start_{0};
    std::optional<sim_time> next_position_report_;
    // Z-stack (ZS, TTL X=4): each pulse steps Z by dz; sawtooth returns, triangle reverses.
    struct zstack_state {
        double dz_units = 0;
        int slices = 1, mode = 0, index = 0, direction = 1;
        double start_mm = 0;
        bool active = false;
    } zstack_;
    double dac_volts_ = 0;
    std::map<char, double> led_;
    // Planar correction: up to three points (units), plane z = a*x + b*y + c when enabled.
    std::vector<std::array<double, 3>> plane_points_;
    std::optional<std::array<double, 3>> plane_;
    bool plane_enabled_ = false;
    char crisp_state_ = 'I';
    std::optional<sim_time> crisp_lock_at_;
    double crisp_offset_ = 0;  // LK Z: the focus error the lock holds, in the focus error's unit
    std::optional<sim_time> autofocus_done_at_;
    std::string build_user_string_;
    long build_counter_ = 0;
    sim_time report_busy_until_{0};
    std::uint64_t reports_sent_ = 0;
    std::uint64_t reports_dropped_ = 0;
    std::uint64_t ttl_edges_ = 0;
    std::optional<std::pair<std::string, int>> refuse_next_;
};

}  // namespace gw::devices::sim
