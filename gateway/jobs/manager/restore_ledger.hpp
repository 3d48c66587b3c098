#pragma once
// What stopped or crashed runs left changed on each controller and must still be put back: "TTL Y=0"
// (safe_outputs.hpp) and their restore commands (job_context::restore_if_stopped), owed per controller
// until they reach it. Bookkeeping only, on the job_manager's strand (not thread-safe): the manager
// sends the commands, stores them with the job they are kept under, and asks here what is owed.
//
//   ledger.add("sim1", {"j-1", true, {"RM Y=0"}});
//   if (!ledger.sending("sim1")) { auto owed = ledger.take("sim1"); ledger.start_sending("sim1"); ... }

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace gw::jobs {

struct owed_restore {
    std::string job_id;                // the job the commands are stored under
    bool ttl_low = false;              // "TTL Y=0" is owed
    std::vector<std::string> restore;  // registration order; sent newest first
    bool halt = false;  // HALT before all: the job was running there when the gateway went down
    bool empty() const { return !halt && !ttl_low && restore.empty(); }
};

// Two debts on one controller as one: the older's commands first, then those of the newer it lacks, so
// that sent newest first a setting both changed ends at the older's value (the one from before either
// run); HALT and "TTL Y=0" when either owes them; kept under the newer job (pure).
owed_restore merge(const owed_restore& older, const owed_restore& newer);

class restore_ledger {
  public:
    struct added {
        owed_restore now;                           // what the controller is owed now
        bool merged = false;                        // it was owed something before
        std::optional<std::string> superseded_job;  // merged from another job's debt, now kept under `now`
    };
    // Adds `owed` to what `controller` is owed; `is_older`: it predates what is owed already (a debt
    // that could not be delivered, back after a newer one was added meanwhile).
    added add(const std::string& controller, owed_restore owed, bool is_older = false);
    bool owes(const std::string& controller) const { return owed_.contains(controller); }
    // What the controller is owed, taken out (empty when nothing).
    owed_restore take(const std::string& controller);
    std::vector<std::string> controllers_owed() const;

    // A debt is being sent to the controller: a run there waits until it is done.
    void start_sending(const std::string& controller) { sending_.insert(controller); }
    void done_sending(const std::string& controller) { sending_.erase(controller); }
    bool sending(const std::string& controller) const { return sending_.contains(controller); }

  private:
    std::map<std::string, owed_restore> owed_;
    std::set<std::string> sending_;
};

}  // namespace gw::jobs
