#include "gateway/jobs/motion_probe.hpp"

#include <cmath>
#include <fmt/format.h>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <utility>

#include <spdlog/logger.h>

#include "devices/ms2000/reply.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/controller_registry.hpp"

namespace gw::jobs {

namespace {

// Each fallback reason is logged once per process (controller, what), not on every submission.
void log_fallback_once(const std::string& controller, const std::string& what, const std::string& why) {
    static std::mutex mutex;
    static std::set<std::string> logged;
    {
        std::lock_guard lock(mutex);
        if (!logged.insert(controller + "/" + what).second) return;
    }
    get_logger("jobs")->warn("motion model of {}: {} ({}); estimates use the default", controller, what, why);
}

// Half a unit of the last decimal the controller printed ("0.000005": 5e-7), so that a finish error
// that prints as the screw's default (A screw: 0.0000055 mm prints "0.000005") counts as the default.
double half_last_digit(const std::string& text) {
    const auto dot = text.find('.');
    if (dot == std::string::npos) return 0.5;
    std::size_t decimals = 0;
    for (std::size_t i = dot + 1; i < text.size() && text[i] >= '0' && text[i] <= '9'; ++i)
        ++decimals;
    return 0.5 * std::pow(10.0, -static_cast<double>(decimals));
}

struct probe_state {
    probe_state(controller_registry& r, std::string id, std::string rid, std::function<void(motion_model)> d)
        : registry(r), controller(std::move(id)), request_id(std::move(rid)), done(std::move(d)) {}

    controller_registry& registry;
    std::string controller;
    std::string request_id;
    std::function<void(motion_model)> done;
    std::string axes;                                           // hardware order
    std::map<char, std::optional<double>> counts;               // CNTS from the snapshot
    std::map<char, std::optional<double>> lower, upper;         // SL, SU from the snapshot
    std::map<char, std::optional<double>> speed, ramp, pc;      // S, AC, PC answers
    std::map<char, std::optional<double>> backlash, overshoot;  // B, OS answers (unset: none)
    std::map<char, double> pc_resolution;                       // half the last printed digit of PC
    std::optional<unsigned> baud;                               // the controller's serial settings
};

// "S X? Y? Z?"
std::string query_line(const std::string& verb, const std::string& axes) {
    std::string line = verb;
    for (const char a : axes)
        line += fmt::format(" {}?", a);
    return line;
}

// Reads one setting of every axis into `out`; a failed or partial answer leaves axes unset.
void query(const std::shared_ptr<probe_state>& s, const std::string& verb,
           std::map<char, std::optional<double>> probe_state::*out, std::function<void()> next) {
    s->registry.async_raw_command(
        s->controller, raw_command_request{query_line(verb, s->axes)}, s->request_id,
        [s, verb, out, next = std::move(next)](operation_result<raw_command_result> r) {
            if (!r) {
                log_fallback_once(s->controller, verb + " query failed", r.error().message);
            } else if (r->reply.what != devices::ms2000::reply::kind::ack) {
                log_fallback_once(s->controller, verb + " query failed", "reply \"" + r->raw_reply + "\"");
            } else {
                for (const char a : s->axes) {
                    const auto* v = r->reply.axis(a);
                    if (v && v->number && *v->number >= 0) {
                        ((*s).*out)[a] = *v->number;
                        if (out == &probe_state::pc) s->pc_resolution[a] = half_last_digit(v->text);
                    } else
                        log_fallback_once(s->controller, fmt::format("{} {}? unanswered", verb, a),
                                          "reply \"" + r->raw_reply + "\"");
                }
            }
            next();
        });
}

void finish(const std::shared_ptr<probe_state>& s) {
    motion_model model;
    for (const char a : s->axes) {
        std::optional<lead_screw_motion> screw;
        if (const auto c = s->counts[a]) screw = lead_screw_for_counts(*c);
        if (!screw) {
            log_fallback_once(s->controller, fmt::format("lead screw of {}", a),
                              s->counts[a] ? fmt::format("unknown counts per mm {}", *s->counts[a])
                                           : std::string("no counts per mm in the snapshot"));
            screw = default_lead_screw();
        }
        // ACCEL 0 would be no ramp at all; the firmware refuses it (range 1..), so treat it as unknown.
        auto ramp = s->ramp[a];
        if (ramp && *ramp <= 0) ramp.reset();
        auto speed = s->speed[a];
        if (speed && *speed <= 0) speed.reset();
        auto pc = s->pc[a];
        if (pc && std::abs(*pc - screw->default_pc_mm) <= s->pc_resolution[a]) pc = screw->default_pc_mm;
        if (pc && *pc <= 0) pc.reset();
        auto params = axis_params_for(*screw, speed, ramp, pc);
        params.backlash_mm = s->backlash[a].value_or(0);
        params.overshoot_mm = s->overshoot[a].value_or(0);
        params.lower_limit_mm = s->lower[a];
        params.upper_limit_mm = s->upper[a];
        model.set_axis(a, params);
    }
    if (s->baud) {
        auto link = model.link();
        link.baud = *s->baud;
        model.set_link(link);
    }
    s->done(std::move(model));
}

}  // namespace

void async_read_motion_model(controller_registry& registry, const std::string& controller_id,
                             const std::string& request_id, std::function<void(motion_model)> done) {
    auto s = std::make_shared<probe_state>(registry, controller_id, request_id, std::move(done));
    if (const auto snap = registry.get(controller_id); snap && !snap->axes.empty()) {
        for (const auto& a : snap->axes) {
            s->axes.push_back(a.axis);
            s->counts[a.axis] = a.counts_per_mm;
            s->lower[a.axis] = a.lower_limit_mm;
            s->upper[a.axis] = a.upper_limit_mm;
        }
    } else {
        s->axes = "XYZ";  // the queries will fail and say why; the model gets the default axes
    }
    if (const auto c = registry.controller(controller_id)) s->baud = c->settings().baud;
    // One at a time: the driver serialises them anyway, and a dead controller fails fast.
    query(s, "S", &probe_state::speed, [s] {
        query(s, "AC", &probe_state::ramp, [s] {
            query(s, "PC", &probe_state::pc, [s] {
                query(s, "B", &probe_state::backlash,
                      [s] { query(s, "OS", &probe_state::overshoot, [s] { finish(s); }); });
            });
        });
    });
}

}  // namespace gw::jobs
