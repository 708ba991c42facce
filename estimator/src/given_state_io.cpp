#include "vilma/estimator/given_state_io.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <vector>

#include "vilma/core/error.h"
#include "vilma/eval/trajectory.h"

namespace vilma::estimator {
namespace {

constexpr int64_t kMaxGapNs = 100'000'000;  // the poses around t must be this close
constexpr int64_t kDifferenceNs = 50'000'000;  // half the velocity difference interval

struct Rates {
  int64_t t_ns = 0;
  Eigen::Vector3d v, b_g, b_a;
};

// The velocity and bias columns of an ASL ground-truth CSV (t, p, q, v, b_g, b_a).
std::vector<Rates> ReadRateColumns(const std::string& path) {
  std::ifstream in(path);
  std::vector<Rates> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || !std::isdigit(static_cast<unsigned char>(line[0]))) {
      continue;
    }
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    double value[17];
    int64_t t = 0;
    fields >> t;
    for (int i = 1; i < 17; ++i) fields >> value[i];
    if (!fields) {
      throw InputError(FormatInputError(path, "", "17 numbers per line (t, p, q, v, b_g, b_a)"));
    }
    rows.push_back({t, Eigen::Vector3d(value[8], value[9], value[10]),
                    Eigen::Vector3d(value[11], value[12], value[13]),
                    Eigen::Vector3d(value[14], value[15], value[16])});
  }
  return rows;
}

// Index i with t[i] <= t < t[i + 1] (or t == t.back()); -1 if outside.
long Bracket(const std::vector<int64_t>& t, int64_t at) {
  if (t.empty() || at < t.front() || at > t.back()) return -1;
  const auto it = std::upper_bound(t.begin(), t.end(), at);
  const long i = static_cast<long>(it - t.begin()) - 1;
  return std::min<long>(i, static_cast<long>(t.size()) - 2);
}

}  // namespace

GivenState LoadGivenState(const std::string& path, int64_t t_ns, GivenStateSource* source) {
  TrajectoryReadReport report;
  const Trajectory trajectory = ReadTrajectoryFile(path, &report);
  if (!trajectory.has_timestamps || trajectory.size() < 2) {
    throw InputError(FormatInputError(path, "", "at least 2 time-stamped poses (TUM or EuRoC)"));
  }
  const std::string at = "the first frame's time " + std::to_string(t_ns) + " ns";
  const long i = Bracket(trajectory.t_ns, t_ns);
  if (i < 0) {
    throw InputError(FormatInputError(path, "", "poses around " + at + " (the file covers " +
                                                    std::to_string(trajectory.t_ns.front()) +
                                                    " .. " +
                                                    std::to_string(trajectory.t_ns.back()) +
                                                    " ns)"));
  }
  const std::size_t k = static_cast<std::size_t>(i);
  const int64_t t0 = trajectory.t_ns[k], t1 = trajectory.t_ns[k + 1];
  if (t_ns - t0 > kMaxGapNs || t1 - t_ns > kMaxGapNs) {
    throw InputError(FormatInputError(path, "", "poses within 100 ms on each side of " + at));
  }
  auto pose_at = [&](int64_t t) {
    const long j = Bracket(trajectory.t_ns, t);
    const std::size_t m = static_cast<std::size_t>(j);
    const double alpha = static_cast<double>(t - trajectory.t_ns[m]) /
                         static_cast<double>(trajectory.t_ns[m + 1] - trajectory.t_ns[m]);
    return Interpolate(trajectory.T_W_B[m], trajectory.T_W_B[m + 1], alpha);
  };
  const Transformation T = pose_at(t_ns);
  GivenState state;
  state.t_ns = t_ns;
  state.q_M_I = T.rotation().normalized();
  state.p_M_I = T.translation();
  GivenStateSource src;
  if (report.format == TrajectoryFormat::kEuroc && report.columns == 17) {
    const std::vector<Rates> rows = ReadRateColumns(path);
    std::vector<int64_t> stamps;
    for (const Rates& r : rows) stamps.push_back(r.t_ns);
    const long j = Bracket(stamps, t_ns);
    if (j >= 0) {
      const Rates& a = rows[static_cast<std::size_t>(j)];
      const Rates& b = rows[static_cast<std::size_t>(j) + 1];
      const double alpha =
          static_cast<double>(t_ns - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
      state.v_M = (1 - alpha) * a.v + alpha * b.v;
      state.b_g = (1 - alpha) * a.b_g + alpha * b.b_g;
      state.b_a = (1 - alpha) * a.b_a + alpha * b.b_a;
      src.velocity_from_file = src.biases_from_file = true;
    }
  }
  if (!src.velocity_from_file) {
    // Central difference over +-50 ms, clamped to the file.
    const int64_t ta = std::max(trajectory.t_ns.front(), t_ns - kDifferenceNs);
    const int64_t tb = std::min(trajectory.t_ns.back(), t_ns + kDifferenceNs);
    if (tb <= ta) throw InputError(FormatInputError(path, "", "poses to difference"));
    state.v_M = (pose_at(tb).translation() - pose_at(ta).translation()) /
                (static_cast<double>(tb - ta) * 1e-9);
    state.sigma_velocity = 0.1;
  }
  if (!src.biases_from_file) {
    state.sigma_gyro_bias = 0.02;
    state.sigma_accel_bias = 0.1;
  }
  if (source != nullptr) *source = src;
  return state;
}

}  // namespace vilma::estimator
