// Association of an estimate's poses with the ground truth's: evo's nearest-stamp rule,
// TUM's one-to-one rule, or by index for files without stamps (docs/evaluation.md,
// "1. Association").
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/eval/trajectory.h"

namespace vilma {

// ---- association ----

enum class AssociationRule {
  // evo's sync.associate_trajectories: the SHORTER trajectory (the estimate when both are
  // equally long) is walked; each of its poses takes the nearest stamp of the other (ties: the
  // earlier) when |dt| <= max_dt. A pose of the longer one may be matched more than once.
  kEvo,
  // TUM's associate.py: all pairs within max_dt, accepted in increasing |dt| while neither
  // pose is used yet: one-to-one (vilma's rule before issue 17).
  kUnique,
};
// "evo", "unique".
const char* AssociationRuleName(AssociationRule rule);
// Parses the names above; false for anything else.
bool ParseAssociationRule(const std::string& name, AssociationRule* rule);

struct AssociationOptions {
  // Largest |t_gt - t_est| [s] of a matched pair: 10 ms, as evo's default --t_max_diff 0.01 and
  // TUM's associate.py 0.02 (here tighter, ground truth usually comes at >= 100 Hz).
  double max_dt_s = 0.01;
  // Which pairs are made (docs/evaluation.md, "1. Association"); evo's, so that ATE equals
  // evo_ape's on the same files.
  AssociationRule rule = AssociationRule::kEvo;
  // Empty when valid, else what is wrong.
  std::string Validate() const;
};

// Matched pairs, ordered by time (both index lists non-decreasing; strictly increasing with
// kUnique): gt.T_W_B[gt_index[k]] <-> est.T_W_B[est_index[k]].
struct Association {
  std::vector<std::size_t> gt_index;
  std::vector<std::size_t> est_index;
  // True when one of the trajectories has no time stamps (KITTI): pairs are (k, k) for
  // k < min(gt.size(), est.size()); the caller decides whether a size mismatch is an error.
  bool by_index = false;
  std::size_t size() const { return gt_index.size(); }
};

// Time association by options.rule. kEvo: walk the shorter trajectory (est when sizes are
// equal), pair each pose with the nearest stamp of the other (ties: the earlier stamp, as
// numpy's argmin) if |dt| <= max_dt; O(n log m). Stamps are compared as exact integer ns (evo
// compares doubles in seconds: only a pair exactly max_dt apart may differ). kUnique (TUM's
// associate.py): all pairs with |t_gt - t_est| <= max_dt are candidates, accepted in increasing
// |dt| (ties: earlier estimate, then earlier gt) when neither pose is used yet; O((n + m) log +
// candidates).
Association AssociateTrajectories(const Trajectory& gt, const Trajectory& est,
                                  const AssociationOptions& options);

}  // namespace vilma
