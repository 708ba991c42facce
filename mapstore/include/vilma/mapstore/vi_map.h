// The VI-map (architecture.md section 6, docs/vi-map.md): missions, each a graph of vertices
// (states with visual frames) and edges (IMU, loop closure, odometry, pose prior), plus
// landmarks stored in the vertex that first observed them.
//
// Frames: G global, M mission (VIO origin, gravity aligned), I IMU/body, C camera. A mission is
// anchored by T_G_M; vertices hold T_M_I; landmarks hold p_I in their store vertex's IMU frame
// (as maplab), so that moving a vertex moves the landmarks it stores and re-anchoring a mission
// touches neither. Quaternions are Hamilton (Eigen); times are int64 ns on the robot's clock.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/core/imu.h"
#include "vilma/core/rig.h"
#include "vilma/mapstore/id.h"
#include "vilma/mapstore/resources.h"

namespace vilma {
namespace mapstore {

struct Mission {
  MissionId id;
  std::string name;
  // Baseframe: T_G_M is meaningful only when known (after anchoring). Covariance of the
  // baseframe in the tangent space xi = [rho; phi] of T_G_M (geometry.h Exp convention).
  bool baseframe_known = false;
  Transformation T_G_M;
  Matrix6d T_G_M_covariance = Matrix6d::Zero();
  SensorRig rig;            // cameras empty: no rig recorded
  VertexId root_vertex_id;  // first vertex of the chain of IMU edges
  bool complete = false;    // false while streaming, or when recovered after a crash
};

// Measurement noise of a keypoint whose map does not record one (maps written before the
// field existed load with it): the detector's placement noise, optvi's former default [px].
inline constexpr double kDefaultKeypointSigmaPx = 1.0;

struct Keypoint {
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  // pixel position [px]
  double scale = 0.0;                            // size [px]
  double orientation = 0.0;                      // [rad]
  double score = 0.0;                            // detector response
  // Measurement noise of uv, per axis (isotropic) [px], finite and > 0: whitens the
  // keypoint's reprojection residual in optvi and weights it in triangulation (maplab keeps
  // a keypoint measurement uncertainty per observation too). The map builder writes the
  // detector's noise, or its track refinement's (docs/mapping.md "Track refinement").
  double sigma_px = kDefaultKeypointSigmaPx;
};

// Keypoints seen by one camera at one vertex. Parallel arrays indexed by keypoint index.
struct VisualFrame {
  std::vector<Keypoint> keypoints;
  // Descriptor type name ("BRISK", "ORB", ...) and size; `descriptors` holds
  // keypoints.size() * descriptor_size_bytes bytes, keypoint after keypoint.
  std::string descriptor_type = "BRISK";
  uint32_t descriptor_size_bytes = 64;  // 512 bits
  std::vector<uint8_t> descriptors;
  std::vector<int64_t> track_ids;        // -1: not tracked
  std::vector<LandmarkId> landmark_ids;  // invalid id: no landmark
  ResourceId image_resource_id;          // invalid: no image stored
  // Depth seen by this camera (ResourceType::kDepthMap, mapping/dense/depth_map.h format:
  // metric depth of a pinhole view that may be rectified, i.e. rotated against the camera);
  // invalid: none.
  ResourceId depth_resource_id;

  std::size_t size() const { return keypoints.size(); }
  const uint8_t* descriptor(std::size_t keypoint) const {
    return descriptors.data() + keypoint * descriptor_size_bytes;
  }
  // Empty if the parallel arrays agree and every keypoint's sigma_px is finite and > 0, else
  // what is wrong.
  std::string Validate() const;
};

struct Vertex {
  VertexId id;
  MissionId mission_id;
  int64_t t_ns = 0;  // state time [ns]
  Transformation T_M_I;
  Eigen::Vector3d v_M = Eigen::Vector3d::Zero();         // velocity [m/s]
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();  // [m/s^2]
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();   // [rad/s]
  std::vector<VisualFrame> frames;                       // one per rig camera
};

enum class EdgeType : uint8_t { kImu = 1, kLoopClosure = 2, kOdometry = 3, kPosePrior = 4 };
const char* EdgeTypeName(EdgeType type);

// One struct for every edge type; the fields a type does not use stay at their defaults.
//   kImu:         from -> to consecutive vertices of one mission; imu_samples cover
//                 [t_from, t_to] (raw measurements, sorted by time).
//   kLoopClosure: T_A_B = T_{I_from, I_to} measured, covariance over xi = [rho; phi], switch
//                 variable s in [0, 1] with its prior variance (Suenderhauf's switchable
//                 constraints, as maplab).
//   kOdometry:    T_A_B = T_{I_from, I_to} from a relative-pose sensor, covariance.
//   kPosePrior:   unary: from == to; T_A_B = prior on T_M_I of the vertex, covariance.
struct Edge {
  EdgeId id;
  EdgeType type = EdgeType::kImu;
  VertexId from;
  VertexId to;
  std::vector<ImuSample> imu_samples;
  Transformation T_A_B;
  Matrix6d covariance = Matrix6d::Zero();
  double switch_variable = 1.0;
  double switch_variable_variance = 0.0;
};

enum class LandmarkQuality : uint8_t { kUnknown = 0, kBad = 1, kGood = 2 };

// "Keypoint `keypoint` of camera `camera` at vertex `vertex_id` sees the landmark". The vertex
// may belong to another mission than the landmark's store vertex (after loop closure).
struct LandmarkObservation {
  VertexId vertex_id;
  uint32_t camera = 0;
  uint32_t keypoint = 0;
  bool operator==(const LandmarkObservation& o) const {
    return vertex_id == o.vertex_id && camera == o.camera && keypoint == o.keypoint;
  }
};

struct Landmark {
  LandmarkId id;
  VertexId store_vertex_id;  // the vertex that first observed it; p_I is in its IMU frame
  Eigen::Vector3d p_I = Eigen::Vector3d::Zero();            // [m]
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();     // of p_I [m^2]
  LandmarkQuality quality = LandmarkQuality::kUnknown;
  std::vector<LandmarkObservation> observations;
};

// The map. Elements are kept in insertion order per mission (the order they are saved in, so
// save -> load -> save writes identical files). Lookups by id are hashed.
// Adding an element whose id exists, or that refers to a missing mission / store vertex,
// throws std::invalid_argument (a broken invariant in the caller, not bad user input).
class VIMap {
 public:
  VIMap();
  VIMap(VIMap&&) noexcept;
  VIMap& operator=(VIMap&&) noexcept;
  ~VIMap();

  // --- building (also incrementally, as the map builder does) ---
  void AddMission(const Mission& mission);
  void AddVertex(Vertex vertex);  // vertex.mission_id must exist
  void AddEdge(Edge edge);        // `from` must exist (it gives the mission); `to` is checked
                                  // by CheckMapConsistency
  void AddLandmark(Landmark landmark);  // store vertex must exist
  // Upserts: replace the element with the same id or add it (mission stream deltas).
  void UpsertMission(const Mission& mission);
  void UpsertVertex(Vertex vertex);
  void UpsertEdge(Edge edge);
  void UpsertLandmark(Landmark landmark);

  // Adds an observation to the landmark and sets the vertex keypoint's landmark id, keeping
  // both directions of the reference in step. The vertex frame/keypoint must exist.
  void AddObservation(const LandmarkId& landmark_id, const LandmarkObservation& observation);

  // --- editing (offline tools: keyframing, landmark removal, mission removal, merge) ---
  // Every edit keeps both directions of the landmark <-> keypoint reference in step and the
  // per-mission id lists in insertion order. Batch forms take sets so that removing many
  // elements is linear in the map, not quadratic.
  using IdSet = std::unordered_set<Id, IdHash>;

  // Removes one observation from its landmark and clears the keypoint's landmark id. A
  // landmark left without observations stays (callers remove orphans they create).
  void RemoveObservation(const LandmarkId& landmark_id, const LandmarkObservation& observation);
  // Removes landmarks and clears the landmark id of every keypoint that observed them.
  void RemoveLandmarks(const IdSet& landmark_ids);
  void RemoveLandmark(const LandmarkId& id) { RemoveLandmarks({id}); }
  // Removes edges (any type).
  void RemoveEdges(const IdSet& edge_ids);
  void RemoveEdge(const EdgeId& id) { RemoveEdges({id}); }
  // Removes vertices and the observations they make (landmarks keep their other observations;
  // orphans stay for the caller). Throws std::invalid_argument (nothing changed) when an edge
  // still refers to one of them, a landmark is still stored in one of them, or one is its
  // mission's root vertex: callers re-link edges, move landmarks and set the root first.
  void RemoveVertices(const IdSet& vertex_ids);
  void RemoveVertex(const VertexId& id) { RemoveVertices({id}); }
  // Moves a landmark's store to another vertex (of any mission) keeping its position in G
  // (p_I re-expressed: p_I' = T_G_I'^-1 T_G_I p_I).
  void SetLandmarkStoreVertex(const LandmarkId& landmark_id, const VertexId& new_store_vertex);
  // Removes a mission with its vertices, edges and landmarks. Observations its vertices made
  // of other missions' landmarks are removed from those landmarks; keypoints of other
  // missions that observed its landmarks lose their landmark id; edges of other missions that
  // point into it (loop closures) are removed.
  void RemoveMission(const MissionId& id);
  // Moves every mission, vertex, edge, landmark and resource of `other` into this map (missions
  // appended in `other`'s order). Throws std::invalid_argument naming the id, with this map
  // unchanged, when an id of `other` is already used here (the same mission loaded twice).
  void MergeFrom(VIMap&& other);

  // A deep copy (resources: the same index and pending bytes, an empty cache). Console
  // commands that modify a map work on a clone and swap it in on success, so that a failed or
  // cancelled command leaves the loaded map as it was.
  VIMap Clone() const;

  // --- access ---
  bool HasMission(const MissionId& id) const;
  bool HasVertex(const VertexId& id) const;
  bool HasEdge(const EdgeId& id) const;
  bool HasLandmark(const LandmarkId& id) const;
  // These throw std::out_of_range for an unknown id.
  const Mission& mission(const MissionId& id) const;
  Mission& mission(const MissionId& id);
  const Vertex& vertex(const VertexId& id) const;
  Vertex& vertex(const VertexId& id);
  const Edge& edge(const EdgeId& id) const;
  Edge& edge(const EdgeId& id);
  const Landmark& landmark(const LandmarkId& id) const;
  Landmark& landmark(const LandmarkId& id);

  // Ids in insertion order.
  const std::vector<MissionId>& mission_ids() const { return mission_order_; }
  const std::vector<VertexId>& vertex_ids(const MissionId& mission_id) const;
  const std::vector<EdgeId>& edge_ids(const MissionId& mission_id) const;
  // Landmarks whose store vertex belongs to the mission.
  const std::vector<LandmarkId>& landmark_ids(const MissionId& mission_id) const;
  std::size_t num_vertices() const { return vertices_.size(); }
  std::size_t num_edges() const { return edges_.size(); }
  std::size_t num_landmarks() const { return landmarks_.size(); }

  // Mission an edge is listed (and saved) under: that of its `from` vertex when it was added.
  MissionId EdgeMission(const EdgeId& id) const;

  // The mission's vertices along the chain of IMU edges from the root vertex, in time order;
  // stops where the chain breaks (CheckMapConsistency reports why).
  std::vector<VertexId> VertexChain(const MissionId& mission_id) const;

  // Poses and positions in M and G. T_G_I uses the mission's T_G_M even when the baseframe
  // is unknown (then it is whatever the mission holds, identity by default).
  Transformation T_G_I(const VertexId& vertex_id) const;
  Eigen::Vector3d LandmarkPosition_M(const LandmarkId& id) const;
  Eigen::Vector3d LandmarkPosition_G(const LandmarkId& id) const;
  // Sets p_I from a position in the store vertex's mission frame.
  void SetLandmarkPosition_M(const LandmarkId& id, const Eigen::Vector3d& p_M);

  // --- resources (images, depth maps, point clouds, meshes) ---
  ResourceStore& resources() { return *resources_; }
  const ResourceStore& resources() const { return *resources_; }

 private:
  struct MissionEntry {
    Mission mission;
    std::vector<VertexId> vertices;
    std::vector<EdgeId> edges;
    std::vector<LandmarkId> landmarks;
  };
  MissionEntry& Entry(const MissionId& id);

  std::unordered_map<MissionId, MissionEntry, IdHash> missions_;
  std::vector<MissionId> mission_order_;
  std::unordered_map<VertexId, Vertex, IdHash> vertices_;
  std::unordered_map<EdgeId, Edge, IdHash> edges_;
  std::unordered_map<EdgeId, MissionId, IdHash> edge_mission_;
  std::unordered_map<LandmarkId, Landmark, IdHash> landmarks_;
  std::unordered_map<LandmarkId, MissionId, IdHash> landmark_mission_;
  std::unique_ptr<ResourceStore> resources_;
};

}  // namespace mapstore
}  // namespace vilma
