#include "vilma/mapping/loop_closure/anchoring.h"

#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "vilma/mapping/locmap/localization_map_builder.h"

namespace vilma::mapping {

using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

std::string AnchoringOptions::Validate() const {
  const std::string problem = localizer.Validate();
  if (!problem.empty()) return "localizer." + problem;
  if (aam_min_inliers < 4) return "aam_min_inliers: expected >= 4";
  if (aam_min_support < 1) return "aam_min_support: expected >= 1";
  if (!(aam_consensus_m > 0)) return "aam_consensus_m: expected > 0";
  if (!(aam_consensus_deg > 0)) return "aam_consensus_deg: expected > 0";
  if (aam_every_nth_vertex < 1) return "aam_every_nth_vertex: expected >= 1";
  return "";
}

std::string AnchoringSummary::BriefReport() const {
  std::ostringstream out;
  out << "aam: ";
  if (first_made_known) out << "no mission was known: the first anchors G; ";
  std::size_t anchored = 0;
  for (const MissionAnchoring& m : missions) anchored += m.anchored;
  out << anchored << " of " << missions.size() << " unknown missions anchored; " << seconds
      << " s";
  return out.str();
}

std::string AnchoringSummary::FullReport() const {
  std::ostringstream out;
  out << BriefReport() << "\n";
  for (const MissionAnchoring& m : missions) {
    out << "  mission " << m.mission.Hex().substr(0, 8) << ": " << m.vertices_tried
        << " vertices tried, " << m.localized << " localized, " << m.support << " agree -> "
        << (m.anchored ? "anchored" : "NOT anchored (stays unknown)");
    if (m.anchored) {
      out << ", T_G_M moved " << m.change_m << " m, " << m.change_deg << " deg";
    }
    out << "\n";
  }
  return out.str();
}

AnchoringSummary AnchorAllMissions(const AnchoringOptions& options, VIMap* map,
                                   ProgressObserver* progress) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("anchoring options: " + problem);
  AnchoringSummary s;
  std::vector<MissionId> known, unknown;
  for (const MissionId& m : map->mission_ids()) {
    (map->mission(m).baseframe_known ? known : unknown).push_back(m);
  }
  bool make_first_known = false;
  if (known.empty() && !unknown.empty()) {
    make_first_known = true;
    known.push_back(unknown.front());
    unknown.erase(unknown.begin());
  }
  s.first_made_known = make_first_known;
  if (unknown.empty()) {
    if (make_first_known) map->mission(known.front()).baseframe_known = true;
    s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return s;
  }
  auto db = std::make_shared<localizer::LocalizationMap>(
      BuildLocalizationMapOfMissions(*map, known, options.localizer.map));
  if (db->num_landmarks() == 0) {
    throw std::invalid_argument("aam: the known missions have no good landmarks (run elq?)");
  }
  const localizer::Localizer localizer(db, options.localizer);

  std::size_t total = 0;
  for (const MissionId& m : unknown) total += map->vertex_ids(m).size();
  BeginProgress(progress, "aam", total);
  std::size_t done = 0;
  const double consensus_rad = options.aam_consensus_deg * M_PI / 180.0;
  for (const MissionId& m : unknown) {
    MissionAnchoring a;
    a.mission = m;
    a.T_G_M = map->mission(m).T_G_M;
    const SensorRig& rig = map->mission(m).rig;
    std::vector<Transformation> candidates;
    const std::vector<VertexId> chain = map->VertexChain(m);
    for (std::size_t vi = 0; vi < chain.size(); ++vi) {
      ReportProgress(progress, ++done);
      if (vi % static_cast<std::size_t>(options.aam_every_nth_vertex) != 0) continue;
      const mapstore::Vertex& v = map->vertex(chain[vi]);
      ++a.vertices_tried;
      for (std::size_t c = 0; c < v.frames.size() && c < rig.cameras.size(); ++c) {
        const mapstore::VisualFrame& f = v.frames[c];
        if (f.keypoints.empty() || f.descriptor_size_bytes != db->descriptor_bytes) continue;
        std::vector<Eigen::Vector2d> keypoints;
        for (const mapstore::Keypoint& k : f.keypoints) keypoints.push_back(k.uv);
        const localizer::LocalizationResult r = localizer.Localize(
            rig.cameras[c].camera, rig.cameras[c].T_I_C, keypoints, f.descriptors.data());
        if (r.status != localizer::LocalizationStatus::kOk ||
            static_cast<int>(r.inliers.size()) < options.aam_min_inliers) {
          continue;
        }
        candidates.push_back(r.T_G_I * v.T_M_I.inverse());
        ++a.localized;
        break;  // one candidate per vertex
      }
    }
    // The candidate with the most agreeing others (ties: the earlier one).
    std::size_t best = 0, best_support = 0;
    auto agree = [&](const Transformation& x, const Transformation& y) {
      return (x.translation() - y.translation()).norm() <= options.aam_consensus_m &&
             AngleBetween(x.rotation(), y.rotation()) <= consensus_rad;
    };
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      std::size_t support = 0;
      for (const Transformation& other : candidates) support += agree(candidates[i], other);
      if (support > best_support) {
        best = i;
        best_support = support;
      }
    }
    a.support = best_support;
    if (static_cast<int>(best_support) >= options.aam_min_support) {
      Eigen::Vector3d p = Eigen::Vector3d::Zero();
      Eigen::Vector4d q = Eigen::Vector4d::Zero();
      const Eigen::Quaterniond& ref = candidates[best].rotation();
      for (const Transformation& other : candidates) {
        if (!agree(candidates[best], other)) continue;
        p += other.translation();
        const Eigen::Quaterniond& o = other.rotation();
        q += (o.coeffs().dot(ref.coeffs()) < 0 ? -1.0 : 1.0) * o.coeffs();
      }
      p /= static_cast<double>(best_support);
      Eigen::Quaterniond mean;
      mean.coeffs() = q.normalized();
      const Transformation T_G_M(mean, p);
      a.change_m = (T_G_M.translation() - a.T_G_M.translation()).norm();
      a.change_deg = AngleBetween(T_G_M.rotation(), a.T_G_M.rotation()) * 180.0 / M_PI;
      a.T_G_M = T_G_M;
      a.anchored = true;
    }
    s.missions.push_back(a);
  }
  // The map changes only here, after the last safe point.
  if (make_first_known) map->mission(known.front()).baseframe_known = true;
  for (const MissionAnchoring& a : s.missions) {
    if (!a.anchored) continue;
    map->mission(a.mission).T_G_M = a.T_G_M;
    map->mission(a.mission).baseframe_known = true;
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

}  // namespace vilma::mapping
