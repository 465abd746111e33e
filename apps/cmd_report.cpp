// `desslam report <run-dir> [--out report.html] [--groundtruth FILE]`: (re)makes the plots of a
// run folder (SVG beside report.json) and writes one self-contained report.html with them, the
// figures of report.json, the dense-map preview and the settings. Ground truth comes from the
// sequence folder report.json names, or --groundtruth; without it the plots that need it are left
// out and the page says why.
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "core/atomic_file.hpp"
#include "report/html_report.hpp"
#include "report/run_folder.hpp"
#include "report/run_plots.hpp"

namespace desslam::app {
namespace {

struct ReportArgs {
  std::string run_dir;
  std::string out;           // empty: <run-dir>/report.html
  std::string ground_truth;  // empty: <sequence>/groundtruth.txt from report.json
};

void writeReport(const ReportArgs& args) {
  namespace fs = std::filesystem;
  const report::RunFolder run = report::loadRunFolder(args.run_dir, args.ground_truth);
  const report::RunPlots plots = report::makeRunPlots(run.report, run.trajectory,
                                                      run.ground_truth ? &*run.ground_truth : nullptr,
                                                      run.no_ground_truth_reason);
  report::writeRunPlots(run.dir, plots);
  const fs::path out = args.out.empty() ? run.dir / "report.html" : fs::path(args.out);
  writeFileAtomically(out, report::renderHtmlReport(run, plots), "HTML report");
  std::cout << "wrote " << out.string() << " and " << plots.plots.size() << " plots (SVG) in " << run.dir.string() << "\n";
  for (const report::LeftOutPlot& p : plots.left_out) std::cout << "left out " << p.id << ": " << p.reason << "\n";
}

}  // namespace

void registerReportCommand(CLI::App& app) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "report", "Plots and one self-contained report.html (no network needed) for the output folder of a run");
  cmd->add_option("run-dir", args->run_dir, "The --out folder of a `desslam run` (holds report.json)")->required();
  cmd->add_option("--out,-o", args->out, "HTML file to write (default: <run-dir>/report.html)");
  cmd->add_option("--groundtruth", args->ground_truth,
                  "Ground truth (TUM format) instead of groundtruth.txt in the sequence folder report.json names");
  cmd->callback([args] { writeReport(*args); });
}

}  // namespace desslam::app
