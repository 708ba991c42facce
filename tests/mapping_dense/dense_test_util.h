// Synthetic depth for the dense tests: perfect depth maps of a plane rendered through pinhole
// views, and small VI-maps (one mission, a pinhole rig) whose frames carry them as depth
// resources. Deterministic.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/error.h"
#include "vilma/core/geometry.h"
#include "vilma/mapping/dense/depth_map.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping::testing {

// The message of the InputError `f` throws ("(no exception)" / "(another exception)" otherwise).
template <typename F>
std::string InputErrorOf(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  } catch (...) {
    return "(another exception)";
  }
  return "(no exception)";
}

// The plane n . p_G = d (n unit).
struct Plane {
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  double d = 0.0;
  double Distance(const Eigen::Vector3d& p) const { return std::abs(n.dot(p) - d); }
};

// A tilted plane in front of views that look along +z of G, at an offset that is not a
// multiple of the test voxel sizes.
inline Plane TiltedPlane() {
  Plane plane;
  plane.n = Eigen::Vector3d(0.25, -0.2, 1.0).normalized();
  plane.d = 2.0137;
  return plane;
}

struct Pinhole {
  int width = 160, height = 120;
  double fx = 150.0, fy = 148.0, cx = 79.3, cy = 60.2;
};

// Depth (z along D's axis) of the plane at each pixel of the view with pose T_G_D; 0 where the
// ray misses it (behind the view). `scale` multiplies every depth (a biased sensor).
inline cv::Mat RenderPlaneDepth(const Pinhole& k, const Eigen::Matrix4d& T_G_D, const Plane& plane,
                                double scale = 1.0) {
  cv::Mat depth(k.height, k.width, CV_32FC1, cv::Scalar(0.0f));
  const Eigen::Matrix3d R_G_D = T_G_D.topLeftCorner<3, 3>();
  const Eigen::Vector3d o_G = T_G_D.topRightCorner<3, 1>();
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d ray_G = R_G_D * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      const double denominator = plane.n.dot(ray_G);
      if (std::abs(denominator) < 1e-9) continue;
      const double z = (plane.d - plane.n.dot(o_G)) / denominator;  // ray has unit z in D
      if (z > 0.0) depth.at<float>(v, u) = static_cast<float>(scale * z);
    }
  }
  return depth;
}

// A pose looking along +z of G from p_G, turned by small angles about x and y.
inline Eigen::Matrix4d LookingForward(const Eigen::Vector3d& p_G, double yaw, double pitch) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  T.topRightCorner<3, 1>() = p_G;
  return T;
}

struct PlaneMapOptions {
  int vertices = 5;
  Pinhole pinhole;
  Plane plane = TiltedPlane();
  // Rotation of the depth view D against the camera C (as stereo rectification makes).
  Eigen::Quaterniond q_C_D = Eigen::Quaterniond(Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitZ()));
  double depth_unit_m = 0.001;
  // Depth scale per vertex index (1: perfect); missing entries are 1.
  std::vector<double> depth_scale;
  bool depth = true;  // false: no depth resources
};

struct PlaneMap {
  mapstore::VIMap map;
  mapstore::MissionId mission;
  std::vector<mapstore::VertexId> vertices;
  std::vector<Eigen::Matrix4d> T_G_D;  // the true pose of each vertex's depth view
};

// T_G_D of vertex i: along a short arc in front of the plane.
inline Eigen::Matrix4d PlaneViewPose(int i) {
  return LookingForward(Eigen::Vector3d(-0.3 + 0.15 * i, 0.05 * (i % 2), 0.02 * i), 0.05 - 0.025 * i,
                        0.04 * ((i % 3) - 1));
}

// One mission (T_G_M not identity), one pinhole camera with a T_I_C that is not identity; the
// vertices' T_M_I are chosen so that camera 0's depth view has pose PlaneViewPose(i).
inline PlaneMap MakePlaneMap(const PlaneMapOptions& o = {}) {
  PlaneMap result;
  mapstore::Mission mission;
  mission.id = mapstore::IdGenerator(4242).Next();
  mission.name = "plane";
  mission.baseframe_known = true;
  mission.T_G_M = Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 0.5, 1.0).normalized())),
                                 Eigen::Vector3d(1.0, -2.0, 0.5));
  CameraConfig cam;
  cam.name = "cam0";
  cam.camera = Camera(o.pinhole.width, o.pinhole.height,
                      Eigen::Vector4d(o.pinhole.fx, o.pinhole.fy, o.pinhole.cx, o.pinhole.cy),
                      DistortionModel::kNone, Eigen::VectorXd());
  cam.T_I_C = Transformation(Eigen::Quaterniond(0.7123, -0.0077, 0.0105, 0.7018),
                             Eigen::Vector3d(-0.0216, -0.0647, 0.0098));
  mission.rig.cameras.push_back(cam);
  mission.complete = true;
  result.map.AddMission(mission);
  result.mission = mission.id;
  mapstore::IdGenerator ids = mapstore::IdGenerator::ForMission(mission.id);
  const Transformation R_C_D(o.q_C_D, Eigen::Vector3d::Zero());
  for (int i = 0; i < o.vertices; ++i) {
    const Eigen::Matrix4d T_G_D = PlaneViewPose(i);
    // T_G_D = T_G_M T_M_I T_I_C R_C_D  =>  T_M_I = T_G_M^-1 T_G_D R_C_D^-1 T_I_C^-1.
    const Transformation T_M_I =
        mission.T_G_M.inverse() * Transformation(T_G_D) * R_C_D.inverse() * cam.T_I_C.inverse();
    mapstore::Vertex v;
    v.id = ids.Next();
    v.mission_id = mission.id;
    v.t_ns = 1'305'031'102'175'304'000LL + static_cast<int64_t>(i) * 100'000'000LL;
    v.T_M_I = T_M_I;
    v.frames.resize(1);
    if (i == 0) result.map.mission(mission.id).root_vertex_id = v.id;
    if (o.depth) {
      DepthMap depth;
      depth.fx = o.pinhole.fx;
      depth.fy = o.pinhole.fy;
      depth.cx = o.pinhole.cx;
      depth.cy = o.pinhole.cy;
      depth.q_C_D = o.q_C_D;
      const double scale = i < static_cast<int>(o.depth_scale.size()) ? o.depth_scale[i] : 1.0;
      depth.depth_m = RenderPlaneDepth(o.pinhole, T_G_D, o.plane, scale);
      std::string bytes = EncodeDepthMap(depth, o.depth_unit_m);
      const mapstore::ResourceId id = DerivedResourceId(v.id, 0, "depth", bytes);
      result.map.resources().Add(mapstore::ResourceType::kDepthMap, id, kDepthMapExtension,
                                 std::move(bytes));
      v.frames[0].depth_resource_id = id;
    }
    result.vertices.push_back(v.id);
    result.T_G_D.push_back(T_G_D);
    result.map.AddVertex(std::move(v));
  }
  return result;
}

}  // namespace vilma::mapping::testing
