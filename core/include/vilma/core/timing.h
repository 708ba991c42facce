// Measurement helpers of the programs' timing reports (wall and thread CPU time, percentiles).
// Timing is reported, never used by an algorithm.
#pragma once

#include <chrono>
#include <vector>

namespace vilma {

// Wall time since t0 [ms] (steady clock).
double MsSince(std::chrono::steady_clock::time_point t0);

// CPU time of the calling thread [ms] (CLOCK_THREAD_CPUTIME_ID). On a shared machine the wall
// time of a step also counts the time its thread waited for a core; this does not.
double ThreadCpuMs();

// The q-quantile (q in [0, 1]) of `values` by nearest rank: the sorted element at index
// round(q * (n - 1)); 0 for no values.
double Percentile(std::vector<double> values, double q);

}  // namespace vilma
