// TsdfOptions::threads reaches Open3D's integration: Open3D 0.16 asks for num_threads(<physical
// cores>) unless OMP_NUM_THREADS or OMP_DYNAMIC is set, so omp_set_num_threads alone did not
// keep it to one thread (on a loaded 2-core machine its spinning threads made an integration
// 20-60 times slower). The caller's OpenMP settings are left as they were.
#include <omp.h>

#include <catch2/catch.hpp>
#include <filesystem>

#include "mapping_dense/dense_test_util.h"
#include "vilma/mapping/dense/tsdf_fusion.h"

namespace vilma::mapping {
namespace {

int ThreadsOfThisProcess() {
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/task")) {
    (void)entry;
    ++n;
  }
  return n;
}

TEST_CASE("TSDF integration with threads = 1 runs on the calling thread", "[tsdf_fusion]") {
  const testing::Pinhole k;
  const Eigen::Matrix4d T_G_D = testing::PlaneViewPose(0);
  const cv::Mat depth = testing::RenderPlaneDepth(k, T_G_D, testing::TiltedPlane());
  TsdfOptions options;
  options.color = false;
  REQUIRE(options.threads == 1);
  omp_set_num_threads(3);
  const int levels = omp_get_max_active_levels();
  const int threads_before = ThreadsOfThisProcess();
  TsdfVolume volume(options);
  volume.Integrate(depth.ptr<float>(), nullptr, k.width, k.height, k.fx, k.fy, k.cx, k.cy, T_G_D);
  CHECK(volume.volume_units() > 0);
  // The caller's settings are back.
  CHECK(omp_get_max_threads() == 3);
  CHECK(omp_get_max_active_levels() == levels);
  // No OpenMP worker was started (a process whose earlier tests started threads can't tell).
  if (threads_before == 1) CHECK(ThreadsOfThisProcess() == 1);
  // And its parallel regions still get the caller's threads.
  int team = 0;
#pragma omp parallel
  {
#pragma omp single
    team = omp_get_num_threads();
  }
  CHECK(team == 3);
}

}  // namespace
}  // namespace vilma::mapping
