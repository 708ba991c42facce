#include "vilma/console/dense_kitti_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/eval/localization/kitti_localization.h"
#include "vilma/mapping/dense/dense_evaluation.h"
#include "vilma/mapping/dense/mesh_render.h"
#include "vilma/mapping/dense/stereo_depth.h"
#include "vilma/mapping/dense/tsdf_fusion.h"

namespace vilma::console {
namespace {

void PrintHelp(std::ostream& out) {
  out << "usage: vilma dense-kitti KITTI_DIR --out MESH.ply [--every N] [--voxel M]\n"
         "                         [--truncation M] [--max-depth M] [--num-disparities N]\n"
         "                         [--min-weight W] [--filter-neighbours N] [--render PNG]\n"
         "\n"
         "Dense reconstruction of a KITTI odometry stereo slice (calib.txt, poses.txt, image_l/,\n"
         "image_r/; e.g. ../shared/data/kitti_slices/KITTI_sequence_1) with its given poses:\n"
         "SGBM depth per frame, the neighbour-view depth filter, TSDF fusion (Open3D), a PLY\n"
         "mesh (docs/dense.md). Prints the depth consistency of neighbouring frames and timings.\n"
         "\n"
         "  --out FILE            PLY mesh to write (required)\n"
         "  --every N             every N-th frame (default 1)\n"
         "  --voxel M             TSDF voxel size [m] (default 0.10)\n"
         "  --truncation M        TSDF truncation distance [m] (default 0.30)\n"
         "  --max-depth M         depth beyond is dropped [m] (default 30)\n"
         "  --num-disparities N   SGBM search range, a multiple of 16 (default 128)\n"
         "  --min-weight W        surface seen by fewer frames is left out (default 2)\n"
         "  --filter-neighbours N depth checked against N frames before and after; 0: off\n"
         "                        (default 2)\n"
         "  --render PNG          also draw the mesh from above (render_mesh's top view, -y up)\n"
         "  -h, --help            this text\n"
         "\n"
         "exit codes: 0 ok, 1 input error, 2 usage error\n";
}

std::string Fixed(double x, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << x;
  return s.str();
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

int RunDenseKittiCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  std::string directory, mesh_path, render_path;
  int every = 1;
  mapping::StereoDepthOptions stereo;
  stereo.sgbm.num_disparities = 128;  // KITTI: f B = 387 px m, depth from 3 m on
  stereo.min_depth_m = 2.0;
  stereo.max_depth_m = 30.0;
  stereo.depth_unit_m = 0.001;
  mapping::TsdfOptions tsdf;
  tsdf.voxel_size_m = 0.10;
  tsdf.truncation_distance_m = 0.30;
  tsdf.mesh_min_weight = 2.0;
  tsdf.max_depth_m = 30.0;
  tsdf.min_depth_m = 2.0;
  try {
    for (ArgCursor arg(args); arg.Next();) {
      const std::string& name = arg.name();
      if (name == "--help" || name == "-h") {
        PrintHelp(out);
        return kExitOk;
      } else if (name == "--out") {
        mesh_path = arg.Value();
      } else if (name == "--every") {
        every = arg.IntValue();
      } else if (name == "--voxel") {
        tsdf.voxel_size_m = arg.DoubleValue();
      } else if (name == "--truncation") {
        tsdf.truncation_distance_m = arg.DoubleValue();
      } else if (name == "--max-depth") {
        tsdf.max_depth_m = stereo.max_depth_m = arg.DoubleValue();
      } else if (name == "--num-disparities") {
        stereo.sgbm.num_disparities = arg.IntValue();
      } else if (name == "--min-weight") {
        tsdf.mesh_min_weight = arg.DoubleValue();
      } else if (name == "--filter-neighbours") {
        tsdf.filter.neighbours = arg.IntValue();
      } else if (name == "--render") {
        render_path = arg.Value();
      } else if (!arg.is_option() && directory.empty()) {
        directory = name;
      } else {
        throw UsageError("unknown argument '" + name + "'");
      }
    }
    if (directory.empty()) throw UsageError("expected a KITTI_DIR");
    if (mesh_path.empty()) throw UsageError("--out: expected the PLY file to write");
    if (every < 1) throw UsageError("--every: expected N >= 1");
    if (!(stereo.max_depth_m > stereo.min_depth_m)) {
      throw UsageError("--max-depth: expected more than " + Fixed(stereo.min_depth_m, 1) +
                       " m (the nearest depth taken from SGBM)");
    }
    // The depth maps stay in memory as floats: the 16-bit unit of stored depth resources must
    // not cap --max-depth at 65.5 m (KITTI sees farther).
    stereo.depth_unit_m = std::max(stereo.depth_unit_m, stereo.max_depth_m / 65535.0);
    if (std::string e = stereo.Validate(); !e.empty()) throw UsageError(e);
    if (std::string e = tsdf.Validate(); !e.empty()) throw UsageError(e);
  } catch (const UsageError& e) {
    err << "vilma dense-kitti: " << e.what() << " (see --help)\n";
    return kExitUsage;
  }

  try {
    // Outputs whose folder does not exist fail now, not after minutes of computation.
    for (const std::string& path : {mesh_path, render_path}) {
      if (path.empty()) continue;
      const std::filesystem::path parent = std::filesystem::absolute(path).parent_path();
      std::error_code ec;
      if (!std::filesystem::is_directory(parent, ec)) {
        throw InputError(path + ": expected a file in an existing folder (" + parent.string() +
                         " is not one)");
      }
    }
    const eval::KittiSequence sequence = eval::LoadKittiSequence(directory);
    // Rectified already: a pinhole pair with the right camera at +B along x.
    const Transformation T_L_R(Eigen::Quaterniond::Identity(), Eigen::Vector3d(sequence.baseline_m, 0, 0));
    const mapping::StereoRectification rectification =
        mapping::ComputeStereoRectification(sequence.camera, sequence.camera, T_L_R);

    std::vector<mapping::DepthMap> depths;
    std::vector<Eigen::Matrix4d> poses;
    std::vector<double> depth_ms, integrate_ms;
    for (std::size_t k = 0; k < sequence.size(); k += static_cast<std::size_t>(every)) {
      const cv::Mat left = cv::imread(sequence.left_images[k], cv::IMREAD_GRAYSCALE);
      const cv::Mat right = cv::imread(sequence.right_images[k], cv::IMREAD_GRAYSCALE);
      if (left.empty() || right.empty()) {
        throw InputError(sequence.left_images[k] + ": expected a readable stereo pair");
      }
      const auto start = std::chrono::steady_clock::now();
      depths.push_back(mapping::ComputeStereoDepth(rectification, left, right, stereo));
      depth_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
      Eigen::Matrix4d T_W_D = sequence.T_W_C[k].matrix();
      T_W_D.topLeftCorner<3, 3>() = sequence.T_W_C[k].rotationMatrix() * rectification.R_L_D;
      poses.push_back(T_W_D);
    }

    std::vector<std::pair<mapping::PosedDepth, mapping::PosedDepth>> pairs;
    for (std::size_t i = 0; i + 1 < depths.size(); ++i) {
      pairs.push_back({{&depths[i], poses[i]}, {&depths[i + 1], poses[i + 1]}});
    }
    const mapping::DepthConsistency consistency = mapping::MeasureDepthConsistency(pairs);

    mapping::TsdfVolume volume(tsdf);
    long filtered = 0, fused = 0;
    for (std::size_t i = 0; i < depths.size(); ++i) {
      mapping::DepthMap depth = depths[i];
      depth.depth_m = depths[i].depth_m.clone();
      std::vector<mapping::PosedDepth> others;
      const std::size_t k = static_cast<std::size_t>(tsdf.filter.neighbours);
      for (std::size_t j = i >= k ? i - k : 0; j < std::min(depths.size(), i + k + 1); ++j) {
        if (j != i) others.push_back({&depths[j], poses[j]});
      }
      if (!others.empty()) filtered += mapping::FilterDepthByNeighbours(&depth, poses[i], others, tsdf.filter);
      fused += depth.ValidPixels();
      const auto start = std::chrono::steady_clock::now();
      volume.Integrate(depth.depth_m.ptr<float>(), nullptr, depth.width(), depth.height(), depth.fx,
                       depth.fy, depth.cx, depth.cy, poses[i]);
      integrate_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    const mapping::TriangleMesh mesh = volume.ExtractMesh();
    if (mesh.triangles.empty()) throw InputError(directory + ": the fused depth holds no surface");
    // The picture is drawn before anything is written: a mesh it cannot draw leaves no file.
    cv::Mat picture;
    int64_t triangles_drawn = 0;
    if (!render_path.empty()) {
      // KITTI's world is the first left camera (x right, y down, z ahead); the picture's views
      // take z as up, so the mesh is drawn turned by (x, y, z) -> (x, z, -y).
      mapping::TriangleMesh drawable{{}, mesh.triangles, {}};
      for (const Eigen::Vector3d& p : mesh.vertices) drawable.vertices.emplace_back(p.x(), p.z(), -p.y());
      mapping::MeshRenderOptions view;
      view.view = "top";
      const mapping::MeshRenderResult result = mapping::RenderMeshImage(drawable, view);
      picture = result.image;
      triangles_drawn = result.triangles_drawn;
    }
    mapping::WriteMeshPly(mesh, mesh_path);
    if (!picture.empty()) mapping::WritePngAtomically(render_path, picture);

    out << "frames                 " << depths.size() << " of " << sequence.size() << "\n"
        << "depth per frame        " << Fixed(Median(depth_ms), 1) << " ms median (SGBM, "
        << stereo.sgbm.num_disparities << " disparities)\n"
        << "integration per frame  " << Fixed(Median(integrate_ms), 1) << " ms median\n"
        << "depth consistency      " << consistency.BriefReport() << "\n"
        << "depth filter           " << filtered << " of " << (filtered + fused)
        << " pixels not confirmed by a neighbouring frame\n"
        << "TSDF                   " << volume.volume_units() << " volume units, "
        << Fixed(volume.memory_mb(), 1) << " MiB\n"
        << "mesh                   " << mesh.vertices.size() << " vertices, " << mesh.triangles.size()
        << " triangles -> " << mesh_path << "\n";
    if (!picture.empty()) {
      out << "picture                " << render_path << " (" << triangles_drawn
          << " triangles drawn)\n";
    }
    return kExitOk;
  } catch (const InputError& e) {
    err << "vilma dense-kitti: " << e.what() << "\n";
    return kExitInputError;
  }
}

}  // namespace vilma::console
