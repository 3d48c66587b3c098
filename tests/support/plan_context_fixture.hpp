#pragma once
// A planner's context for the job kinds' unit tests: controller "sim1", connected, with `axes` at 0,
// the simulator's encoder (45,397.6 counts per mm) and soft limits of +-110 mm. Tests add modules,
// motion parameters and modes to it.
#include <string>

#include "gateway/jobs/job_plan.hpp"

namespace gw::jobs::test_support {

inline plan_context connected_context(const std::string& axes, std::string build_name = "") {
    plan_context ctx;
    auto& s = ctx.snapshot;
    s.id = "sim1";
    s.state = devices::connection_state::connected;
    devices::controller_identity identity;
    identity.build.name = std::move(build_name);
    identity.build.motor_axes = axes;
    s.identity = identity;
    for (char a : axes) {
        devices::axis_state st;
        st.axis = a;
        st.position_um = 0;
        st.counts_per_mm = 45397.6;
        st.lower_limit_mm = -110;
        st.upper_limit_mm = 110;
        s.axes.push_back(st);
    }
    return ctx;
}

}  // namespace gw::jobs::test_support
