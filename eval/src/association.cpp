#include "vilma/eval/association.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "vilma/core/time.h"

namespace vilma {

// ---- association ----

std::string AssociationOptions::Validate() const {
  if (!std::isfinite(max_dt_s) || max_dt_s < 0.0) {
    return "max_dt_s: expected a finite time difference >= 0 [s]";
  }
  return "";
}

const char* AssociationRuleName(AssociationRule rule) {
  switch (rule) {
    case AssociationRule::kEvo:
      return "evo";
    case AssociationRule::kUnique:
      return "unique";
  }
  return "unknown";
}

bool ParseAssociationRule(const std::string& name, AssociationRule* rule) {
  for (AssociationRule r : {AssociationRule::kEvo, AssociationRule::kUnique}) {
    if (name == AssociationRuleName(r)) {
      *rule = r;
      return true;
    }
  }
  return false;
}

namespace {

// evo's sync.associate_trajectories (evo/core/sync.py, matching_time_indices): for each stamp
// of the shorter trajectory, argmin |t_long - t_short| over the longer one, kept if <= max_dt.
// Both stamp vectors are strictly increasing, so the nearest is one of the two neighbours of
// the lower bound; on a tie the earlier one wins (argmin returns the first minimum).
Association AssociateEvo(const Trajectory& gt, const Trajectory& est, int64_t max_dt_ns) {
  Association result;
  const bool est_longer = est.size() > gt.size();
  const std::vector<int64_t>& walked = est_longer ? gt.t_ns : est.t_ns;
  const std::vector<int64_t>& searched = est_longer ? est.t_ns : gt.t_ns;
  for (std::size_t s = 0; s < walked.size(); ++s) {
    const int64_t t = walked[s];
    const auto it = std::lower_bound(searched.begin(), searched.end(), t);
    std::size_t best = searched.size();
    if (it != searched.end()) best = static_cast<std::size_t>(it - searched.begin());
    if (it != searched.begin()) {
      const std::size_t before = static_cast<std::size_t>(it - searched.begin()) - 1;
      if (best == searched.size() || t - searched[before] <= searched[best] - t) best = before;
    }
    if (best == searched.size() || std::abs(searched[best] - t) > max_dt_ns) continue;
    result.gt_index.push_back(est_longer ? s : best);
    result.est_index.push_back(est_longer ? best : s);
  }
  return result;
}

}  // namespace

Association AssociateTrajectories(const Trajectory& gt, const Trajectory& est,
                                  const AssociationOptions& options) {
  Association result;
  if (!gt.has_timestamps || !est.has_timestamps) {
    result.by_index = true;
    const std::size_t n = std::min(gt.size(), est.size());
    for (std::size_t k = 0; k < n; ++k) {
      result.gt_index.push_back(k);
      result.est_index.push_back(k);
    }
    return result;
  }
  const int64_t max_dt_ns = SecondsToNs(options.max_dt_s);
  if (options.rule == AssociationRule::kEvo) return AssociateEvo(gt, est, max_dt_ns);
  // Candidates (|dt|, est, gt): the gt stamps within the window of each estimate stamp, found
  // by binary search (both stamp vectors are strictly increasing).
  std::vector<std::tuple<int64_t, std::size_t, std::size_t>> candidates;
  for (std::size_t e = 0; e < est.size(); ++e) {
    const int64_t t = est.t_ns[e];
    auto it = std::lower_bound(gt.t_ns.begin(), gt.t_ns.end(), t - max_dt_ns);
    for (; it != gt.t_ns.end() && *it <= t + max_dt_ns; ++it) {
      const std::size_t g = static_cast<std::size_t>(it - gt.t_ns.begin());
      candidates.emplace_back(std::abs(*it - t), e, g);
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> gt_used(gt.size(), false);
  std::vector<long> est_match(est.size(), -1);
  for (const auto& [dt, e, g] : candidates) {
    (void)dt;
    if (est_match[e] >= 0 || gt_used[g]) continue;
    est_match[e] = static_cast<long>(g);
    gt_used[g] = true;
  }
  for (std::size_t e = 0; e < est.size(); ++e) {
    if (est_match[e] < 0) continue;
    result.est_index.push_back(e);
    result.gt_index.push_back(static_cast<std::size_t>(est_match[e]));
  }
  return result;
}

}  // namespace vilma
