// The plot of `vilma eval --plot`: the matched, aligned trajectories top-down and the errors
// over time, rendered by scripts/plot_trajectory.py (python3 + matplotlib) from a CSV.
#pragma once

#include <ostream>
#include <string>

#include "vilma/eval/trajectory_evaluation.h"

namespace vilma {

// The CSV the plot script reads:
// t_s,gt_x,gt_y,gt_z,est_x,est_y,est_z,translation_error_m,rotation_error_deg (t_s relative to
// the first matched pose; the pose index when there are no time stamps).
void WritePlotCsv(std::ostream& out, const EvalResult& result);

// The folder of plot_trajectory.py: $VILMA_SCRIPTS_DIR, else share/vilma/scripts beside the
// running executable's bin/ folder — <prefix>/share/vilma/scripts when installed (cmake
// --install), <build>/share/vilma/scripts in a build tree (eval/CMakeLists.txt copies the
// script there), so that no path of the source tree is compiled in.
std::string PlotScriptsDir();

// Writes the CSV to a temporary file and runs the script on it to write `png_path`. The
// interpreter: $VILMA_PYTHON if set, else python3 from PATH and then /usr/bin/python3 (a PATH
// python3 from pyenv/venv often lacks Debian's matplotlib), the first that imports matplotlib.
// InputError (naming png_path and "--plot") when the script is missing, no interpreter has
// matplotlib, or the script fails.
void RenderTrajectoryPlot(const TrajectoryEvalSummary& summary, const std::string& png_path);

}  // namespace vilma
