// The path checks of the apps (io::OutputPlan). See path_checks.h.
#include "path_checks.h"

#include "dbacov/app/covariance_app.h"
#include "visual_cli.h"

namespace dbacov::app::detail {

std::vector<std::string> graphOutputFiles(const std::string& prefix) {
  const std::size_t slash = prefix.rfind('/');
  const std::string last = slash == std::string::npos ? prefix : prefix.substr(slash + 1);
  if (last.empty() || last == "." || last == "..")
    throw InputError("--graph " + prefix +
                     ": PREFIX names a directory, not a file prefix (it would write hidden files "
                     "such as '" +
                     prefix + (last.empty() ? "" : "/") + ".graphbin'); give e.g. --graph " +
                     (last.empty() ? prefix : prefix + "/") + "graph");
  return {prefix + ".graphbin", prefix + ".graph", prefix + ".g2o", prefix + ".nodes.csv"};
}

void addInputs(io::OutputPlan& plan, const std::vector<std::string>& paths,
               const std::string& option, const std::string& dir_extension) {
  for (const std::string& p : paths) plan.input(p, option, dir_extension);
}

void checkCovariancePaths(const CovarianceAppOptions& opt) {
  io::OutputPlan plan;
  addInputs(plan, opt.inputs, "-i", ".npz");
  plan.output(opt.csv_path, "--csv");
  plan.output(opt.relative_csv_path, "--relative-csv");
  plan.output(opt.rawlog_path, "-o");
  plan.output(opt.self_calibration.edge_csv, "--edge-csv");
  if (!opt.graph_prefix.empty())
    for (const std::string& f : graphOutputFiles(opt.graph_prefix)) plan.output(f, "--graph");
  plan.outputDirectory(opt.depth_sigma_dir, "--depth-sigma");
  plan.output(opt.scene.scene_path, "--scene");
  plan.output(opt.scene.png_path, "--snapshot");
  if (!opt.plots_dir.empty()) {
    plan.outputDirectory(opt.plots_dir, "--plots");
    for (const char* f : {"/covariance_covisibility.png", "/pose_sigmas.png"})
      plan.output(opt.plots_dir + f, "--plots");
  }
  plan.check();
}

}  // namespace dbacov::app::detail
