#include "vilma/mapping/summarization/landmark_sparsification.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <random>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "vilma/mapping/summarization/coverage_ilp.h"

namespace vilma::mapping {

using mapstore::IdHash;
using mapstore::LandmarkId;
using mapstore::LandmarkQuality;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

std::string LandmarkSparsificationOptions::Validate() const {
  if (num_landmarks_to_keep < 0) return "num_landmarks_to_keep: expected >= 0";
  if (!(keep_fraction >= 0.0 && keep_fraction <= 1.0)) return "keep_fraction: expected in [0, 1]";
  if (num_landmarks_to_keep == 0 && keep_fraction == 0.0) {
    return "num_landmarks_to_keep: expected > 0 (or keep_fraction in (0, 1])";
  }
  if (method != "ilp" && method != "most_observed" && method != "random") {
    return "method: expected ilp, most_observed or random, got '" + method + "'";
  }
  if (min_landmarks_per_keyframe < 0) return "min_landmarks_per_keyframe: expected >= 0";
  if (partition_max_landmarks < 1) return "partition_max_landmarks: expected >= 1";
  if (!(time_limit_s > 0.0)) return "time_limit_s: expected > 0";
  if (!(mip_gap >= 0.0 && mip_gap < 1.0)) return "mip_gap: expected in [0, 1)";
  return "";
}

std::string LandmarkSparsificationSummary::BriefReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(2) << "lsparsify (" << method << "): " << landmarks_before
      << " landmarks (" << good_before << " good) -> " << landmarks_after << ", observations "
      << observations_before << " -> " << observations_after << "; " << keyframes_below_minimum
      << " of " << keyframes << " keyframes below their minimum, " << keyframes_without_landmarks
      << " without landmarks; " << seconds << " s";
  return out.str();
}

std::string LandmarkSparsificationSummary::FullReport() const {
  std::ostringstream out;
  out << BriefReport() << "\n";
  for (std::size_t p = 0; p < partitions.size(); ++p) {
    const SparsificationPartition& s = partitions[p];
    out << std::fixed << std::setprecision(2) << "  partition " << p << ": " << s.keyframes
        << " keyframes, " << s.candidates << " candidates, budget " << s.budget << ", kept "
        << s.kept << " (" << s.status << ", objective " << std::setprecision(1) << s.objective
        << ", slack " << s.slack << ", " << std::setprecision(2) << s.seconds << " s)\n";
  }
  return out.str();
}

namespace {

// The map as the selection sees it: vertices in order, good landmarks (candidates) in order,
// and who sees what.
struct CoverageIndex {
  std::vector<VertexId> vertices;         // map order
  std::vector<LandmarkId> candidates;     // good landmarks, map order
  std::vector<double> scores;             // per candidate: observations
  std::vector<std::vector<int>> seen_by;  // per candidate: distinct vertex indices, sorted
  std::vector<std::vector<int>> sees;     // per vertex: distinct candidates, sorted
  std::vector<int> first_observer;        // per candidate: a vertex index
};

CoverageIndex IndexMap(const VIMap& map) {
  CoverageIndex index;
  std::unordered_map<VertexId, int, IdHash> vertex_index;
  for (const MissionId& m : map.mission_ids()) {
    for (const VertexId& v : map.VertexChain(m)) {
      if (vertex_index.emplace(v, static_cast<int>(index.vertices.size())).second) {
        index.vertices.push_back(v);
      }
    }
    // A broken chain (check_map_consistency reports it): the rest in insertion order.
    for (const VertexId& v : map.vertex_ids(m)) {
      if (vertex_index.emplace(v, static_cast<int>(index.vertices.size())).second) {
        index.vertices.push_back(v);
      }
    }
  }
  index.sees.resize(index.vertices.size());
  for (const MissionId& m : map.mission_ids()) {
    for (const LandmarkId& l : map.landmark_ids(m)) {
      const mapstore::Landmark& landmark = map.landmark(l);
      if (landmark.quality != LandmarkQuality::kGood) continue;
      const int j = static_cast<int>(index.candidates.size());
      index.candidates.push_back(l);
      index.scores.push_back(
          static_cast<double>(std::max<std::size_t>(landmark.observations.size(), 1)));
      std::vector<int> observers;
      for (const mapstore::LandmarkObservation& o : landmark.observations) {
        const auto it = vertex_index.find(o.vertex_id);
        if (it != vertex_index.end()) observers.push_back(it->second);
      }
      std::sort(observers.begin(), observers.end());
      observers.erase(std::unique(observers.begin(), observers.end()), observers.end());
      for (int v : observers) index.sees[v].push_back(j);
      int first = observers.empty() ? 0 : observers.front();
      if (observers.empty()) {
        const auto it = vertex_index.find(landmark.store_vertex_id);
        if (it != vertex_index.end()) first = it->second;
      }
      index.first_observer.push_back(first);
      index.seen_by.push_back(std::move(observers));
    }
  }
  return index;  // sees[v] is sorted: candidates are appended in increasing j
}

std::size_t BudgetOf(const LandmarkSparsificationOptions& options, std::size_t good) {
  if (options.num_landmarks_to_keep > 0)
    return static_cast<std::size_t>(options.num_landmarks_to_keep);
  return static_cast<std::size_t>(std::llround(options.keep_fraction * static_cast<double>(good)));
}

// The ILP per partition (see the header). `keep` is filled in.
void SelectByIlp(const LandmarkSparsificationOptions& options, const CoverageIndex& index,
                 std::size_t budget, std::vector<char>* keep,
                 LandmarkSparsificationSummary* summary, ProgressObserver* progress) {
  const int num_vertices = static_cast<int>(index.vertices.size());
  const int num_candidates = static_cast<int>(index.candidates.size());
  std::vector<std::vector<int>> homed(num_vertices);
  for (int j = 0; j < num_candidates; ++j) homed[index.first_observer[j]].push_back(j);

  // Partitions: [begin, end) vertex ranges.
  std::vector<std::pair<int, int>> ranges;
  int begin = 0;
  std::size_t count = 0;
  for (int v = 0; v < num_vertices; ++v) {
    count += homed[v].size();
    if (count >= static_cast<std::size_t>(options.partition_max_landmarks) ||
        v + 1 == num_vertices) {
      ranges.emplace_back(begin, v + 1);
      begin = v + 1;
      count = 0;
    }
  }

  double max_score = 1.0;
  for (double s : index.scores) max_score = std::max(max_score, s);
  // Covering a keyframe's missing landmark is worth more than any landmark's own score.
  const double slack_penalty = 2.0 * max_score + 1.0;

  std::vector<int> kept_seen(num_vertices, 0);  // kept landmarks each vertex sees so far
  std::vector<int> local(num_candidates, -1);
  // Per vertex: candidates it sees in the parts not solved yet, and in the current part.
  std::vector<int> unsolved_seen(num_vertices), seen_here(num_vertices, 0);
  for (int v = 0; v < num_vertices; ++v) {
    unsolved_seen[v] = static_cast<int>(index.sees[v].size());
  }
  std::size_t budget_left = budget;
  std::size_t candidates_left = static_cast<std::size_t>(num_candidates);
  BeginProgress(progress, "landmark ILP", ranges.size());
  for (std::size_t p = 0; p < ranges.size(); ++p) {
    const auto [first_vertex, end_vertex] = ranges[p];
    std::vector<int> columns;
    for (int v = first_vertex; v < end_vertex; ++v) {
      columns.insert(columns.end(), homed[v].begin(), homed[v].end());
    }
    // The vertices that see this part's landmarks, in order.
    std::vector<int> touched;
    for (int j : columns) {
      for (int v : index.seen_by[j]) {
        if (seen_here[v]++ == 0) touched.push_back(v);
      }
    }
    std::sort(touched.begin(), touched.end());
    SparsificationPartition part;
    part.keyframes = static_cast<std::size_t>(end_vertex - first_vertex);
    part.candidates = columns.size();
    // The budget share of this partition's landmarks, rounded (unused budget carries on).
    part.budget = candidates_left == 0
                      ? 0
                      : static_cast<std::size_t>(std::llround(
                            static_cast<double>(budget_left) * static_cast<double>(columns.size()) /
                            static_cast<double>(candidates_left)));
    part.budget = std::min(part.budget, columns.size());
    std::vector<int> chosen;
    if (part.budget == columns.size()) {
      chosen = columns;
      part.status = "all kept";
    } else if (part.budget == 0) {
      part.status = "budget 0";
    } else {
      CoverageIlp problem;
      problem.slack_penalty = slack_penalty;
      problem.max_selected = static_cast<int>(part.budget);
      for (std::size_t c = 0; c < columns.size(); ++c) {
        local[columns[c]] = static_cast<int>(c);
        problem.scores.push_back(index.scores[columns[c]]);
      }
      // Rows: every vertex that sees a landmark of this part, wherever the vertex lies (after
      // loop closure a later mission's vertices see mostly the first mission's landmarks).
      // Its remaining demand is split over the parts not solved yet in proportion to its
      // candidates in each: share = ceil(demand * here / (here + later)).
      for (int v : touched) {
        const int demand = std::min<int>(options.min_landmarks_per_keyframe,
                                         static_cast<int>(index.sees[v].size())) -
                           kept_seen[v];
        if (demand <= 0) continue;
        std::vector<int> cover;
        for (int j : index.sees[v]) {
          if (local[j] >= 0) cover.push_back(local[j]);
        }
        const int share = static_cast<int>(
            (static_cast<int64_t>(demand) * static_cast<int64_t>(cover.size()) +
             unsolved_seen[v] - 1) /
            unsolved_seen[v]);
        problem.covers.push_back(std::move(cover));
        problem.minimums.push_back(share);
      }
      CoverageIlpOptions ilp_options;
      ilp_options.time_limit_s = options.time_limit_s;
      ilp_options.mip_gap = options.mip_gap;
      const CoverageIlpResult result = SolveCoverageIlp(problem, ilp_options);
      for (int j : columns) local[j] = -1;
      part.seconds = result.seconds;
      if (!result.ok()) {
        std::ostringstream why;
        why << "lsparsify: partition " << p << " of " << ranges.size() << " (" << columns.size()
            << " landmarks, " << part.keyframes << " keyframes): the ILP "
            << (result.status == CoverageIlpResult::Status::kTimeLimit
                    ? "reached its time limit of " + std::to_string(options.time_limit_s) +
                          " s; raise --lsparsify_time_limit_s, or lower "
                          "--lsparsify_partition_landmarks or raise --lsparsify_mip_gap"
                    : "failed: " + result.message)
            << "; the map is unchanged";
        throw std::runtime_error(why.str());
      }
      part.status = CoverageIlpStatusName(result.status);
      part.objective = result.objective;
      part.slack = result.slack_total;
      for (std::size_t c = 0; c < columns.size(); ++c) {
        if (result.selected[c]) chosen.push_back(columns[c]);
      }
    }
    for (int j : chosen) {
      (*keep)[j] = 1;
      for (int v : index.seen_by[j]) ++kept_seen[v];
    }
    for (int v : touched) {
      unsolved_seen[v] -= seen_here[v];
      seen_here[v] = 0;
    }
    part.kept = chosen.size();
    budget_left -= std::min(budget_left, part.kept);
    candidates_left -= columns.size();
    summary->partitions.push_back(part);
    ReportProgress(progress, p + 1);
  }
}

}  // namespace

std::vector<LandmarkId> SelectLandmarksToKeep(const LandmarkSparsificationOptions& options,
                                              const VIMap& map,
                                              LandmarkSparsificationSummary* summary,
                                              ProgressObserver* progress) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("lsparsify: " + problem);
  const auto t0 = std::chrono::steady_clock::now();
  LandmarkSparsificationSummary local_summary;
  if (summary == nullptr) summary = &local_summary;
  *summary = LandmarkSparsificationSummary();
  summary->method = options.method;

  const CoverageIndex index = IndexMap(map);
  const std::size_t num_candidates = index.candidates.size();
  summary->good_before = num_candidates;
  summary->keyframes = index.vertices.size();
  const std::size_t budget = std::min(BudgetOf(options, num_candidates), num_candidates);

  std::vector<char> keep(num_candidates, 0);
  if (budget == num_candidates) {
    std::fill(keep.begin(), keep.end(), 1);
  } else if (options.method == "ilp") {
    SelectByIlp(options, index, budget, &keep, summary, progress);
  } else {
    std::vector<int> order(num_candidates);
    for (std::size_t j = 0; j < num_candidates; ++j) order[j] = static_cast<int>(j);
    if (options.method == "most_observed") {
      std::stable_sort(order.begin(), order.end(),
                       [&](int a, int b) { return index.scores[a] > index.scores[b]; });
    } else {
      // Fisher-Yates with the raw 64-bit engine: the same draw on every platform (the
      // standard's distributions are implementation-defined).
      std::mt19937_64 rng(options.random_seed);
      for (std::size_t i = num_candidates; i > 1; --i) {
        std::swap(order[i - 1], order[rng() % i]);
      }
    }
    for (std::size_t k = 0; k < budget; ++k) keep[order[k]] = 1;
  }

  // Coverage after the selection.
  std::vector<int> kept_seen(index.vertices.size(), 0);
  std::vector<LandmarkId> kept;
  for (std::size_t j = 0; j < num_candidates; ++j) {
    if (!keep[j]) continue;
    kept.push_back(index.candidates[j]);
    for (int v : index.seen_by[j]) ++kept_seen[v];
  }
  for (std::size_t v = 0; v < index.vertices.size(); ++v) {
    const int available = static_cast<int>(index.sees[v].size());
    if (available == 0) continue;
    if (kept_seen[v] < std::min(options.min_landmarks_per_keyframe, available)) {
      ++summary->keyframes_below_minimum;
    }
    if (kept_seen[v] == 0) ++summary->keyframes_without_landmarks;
  }
  summary->landmarks_after = kept.size();
  summary->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return kept;
}

LandmarkSparsificationSummary SparsifyLandmarks(const LandmarkSparsificationOptions& options,
                                                VIMap* map, ProgressObserver* progress) {
  LandmarkSparsificationSummary summary;
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<LandmarkId> kept = SelectLandmarksToKeep(options, *map, &summary, progress);
  const VIMap::IdSet keep_set(kept.begin(), kept.end());
  VIMap::IdSet remove;
  for (const MissionId& m : map->mission_ids()) {
    for (const LandmarkId& l : map->landmark_ids(m)) {
      ++summary.landmarks_before;
      const std::size_t observations = map->landmark(l).observations.size();
      summary.observations_before += observations;
      if (keep_set.count(l) == 0) {
        remove.insert(l);
      } else {
        summary.observations_after += observations;
      }
    }
  }
  map->RemoveLandmarks(remove);
  summary.landmarks_after = kept.size();
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace vilma::mapping
