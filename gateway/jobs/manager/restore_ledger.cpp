#include "gateway/jobs/manager/restore_ledger.hpp"

#include <algorithm>
#include <utility>

namespace gw::jobs {

owed_restore merge(const owed_restore& older, const owed_restore& newer) {
    owed_restore both;
    both.job_id = newer.job_id;
    both.halt = older.halt || newer.halt;
    both.ttl_low = older.ttl_low || newer.ttl_low;
    both.restore = older.restore;
    for (const auto& c : newer.restore)
        if (std::find(both.restore.begin(), both.restore.end(), c) == both.restore.end())
            both.restore.push_back(c);
    return both;
}

restore_ledger::added restore_ledger::add(const std::string& controller, owed_restore owed, bool is_older) {
    auto [it, inserted] = owed_.try_emplace(controller, owed);
    if (inserted) return {it->second, false, std::nullopt};
    const owed_restore& older = is_older ? owed : it->second;
    const owed_restore& newer = is_older ? it->second : owed;
    auto both = merge(older, newer);
    std::optional<std::string> superseded;
    if (older.job_id != newer.job_id) superseded = older.job_id;
    it->second = std::move(both);
    return {it->second, true, std::move(superseded)};
}

owed_restore restore_ledger::take(const std::string& controller) {
    auto it = owed_.find(controller);
    if (it == owed_.end()) return {};
    auto owed = std::move(it->second);
    owed_.erase(it);
    return owed;
}

std::vector<std::string> restore_ledger::controllers_owed() const {
    std::vector<std::string> out;
    for (const auto& [controller, owed] : owed_)
        out.push_back(controller);
    return out;
}

}  // namespace gw::jobs
