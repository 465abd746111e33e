// The program as a user runs it: `desslam run` writes the plots beside report.json, `desslam
// report <run-dir>` writes one self-contained report.html naming every figure; without ground
// truth the page says why; bad run folders are named.
#include <filesystem>
#include <regex>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/expect_contains.hpp"
#include "support/temp_dir.hpp"
#include "support/xml_check.hpp"
#include "system/system_support.hpp"

namespace desslam {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::shellQuote;

const std::vector<std::string> kPlotIds = {"trajectory_top", "trajectory_side", "ate_over_time",
                                           "rpe_over_time",  "dynamic_features", "stage_timings"};
const std::vector<std::string> kGroundTruthPlots = {"trajectory_top", "trajectory_side", "ate_over_time",
                                                    "rpe_over_time"};

class DesslamReport : public ::testing::Test {
 protected:
  fs::path sequence() const { return dir_ / "sequence"; }
  fs::path out() const { return dir_ / "out"; }
  CommandResult desslam(const std::string& arguments) {
    return test::runCommand(shellQuote(test::desslamBinary()) + " " + arguments, dir_ / "logs");
  }
  // A deterministic run of the synthetic room (45 frames), with the dense map for its preview.
  CommandResult runSynthetic() {
    test::writeSyntheticSequence(sequence(), 45);
    dir_.write("synthetic.yaml", test::syntheticConfigYaml());
    return desslam("run " + shellQuote(sequence().string()) + " --config " + shellQuote((dir_ / "synthetic.yaml").string()) +
                   " --out " + shellQuote(out().string()) + " --deterministic --quiet --set dense.enabled=true");
  }
  nlohmann::json report() const { return nlohmann::json::parse(test::readText(out() / "report.json")); }

  test::TempDir dir_;
};

TEST_F(DesslamReport, RunWritesThePlotsAndReportWritesASelfContainedPageNamingEveryFigure) {
  const CommandResult run = runSynthetic();
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // The run: every plot beside report.json, listed there.
  const nlohmann::json r = report();
  ASSERT_TRUE(r.contains("plots")) << r.dump(2).substr(0, 2000);
  EXPECT_EQ(r["plots"]["files"].size(), kPlotIds.size()) << r["plots"].dump(2);
  EXPECT_TRUE(r["plots"]["left_out"].empty()) << r["plots"].dump(2);
  for (const std::string& id : kPlotIds) {
    const fs::path svg = out() / (id + ".svg");
    ASSERT_TRUE(fs::is_regular_file(svg)) << svg;
    const std::string text = test::readText(svg);
    EXPECT_EQ(test::xmlProblem(text), "") << svg;
    EXPECT_CONTAINS(text, "id=\"" + id + "\"");
  }
  // The per-frame stage times the timing plot needs are in report.json.
  const nlohmann::json& frame = r["statistics"]["per_frame"][10];
  for (const char* key : {"extraction_ms", "pose_tracking_ms", "mask_wait_ms", "total_ms"})
    EXPECT_TRUE(frame.contains(key) && frame[key].is_number()) << key << ": " << frame.dump();

  // The page.
  fs::remove(out() / "ate_over_time.svg");  // `report` remakes the plots
  const CommandResult page = desslam("report " + shellQuote(out().string()));
  ASSERT_EQ(page.exit_code, 0) << page.err;
  EXPECT_CONTAINS(page.out, "report.html");
  const fs::path html_file = out() / "report.html";
  ASSERT_TRUE(fs::is_regular_file(html_file));
  EXPECT_TRUE(fs::is_regular_file(out() / "ate_over_time.svg"));
  const std::string html = test::readText(html_file);
  EXPECT_EQ(test::xmlProblem(html, {"meta", "br", "img"}), "");
  for (const std::string& id : kPlotIds) {
    EXPECT_CONTAINS(html, "<figure id=\"figure-" + id + "\">");
    EXPECT_CONTAINS(html, "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" id=\"" + id + "\"");
    // Its title, as the SVG file beside it has it.
    const std::string svg = test::readText(out() / (id + ".svg"));
    const size_t begin = svg.find("<title>"), end = svg.find("</title>");
    ASSERT_NE(begin, std::string::npos);
    EXPECT_CONTAINS(html, svg.substr(begin, end - begin));
  }
  const std::regex external("(src|href)\\s*=\\s*\"(https?:)?//|url\\(\\s*['\"]?(https?:)?//|@import");
  EXPECT_FALSE(std::regex_search(html, external)) << "the page fetches nothing";
  ASSERT_TRUE(fs::is_regular_file(out() / "dense_map.png"));
  EXPECT_CONTAINS(html, "src=\"data:image/png;base64,iVBORw0KGgo");  // the PNG signature, base64
  EXPECT_CONTAINS(html, "ATE RMSE");
  EXPECT_CONTAINS(html, "synthetic.yaml");

  // --out elsewhere; --overwrite of a new run removes the plots and the page with the rest.
  const CommandResult elsewhere = desslam("report " + shellQuote(out().string()) + " --out " +
                                          shellQuote((dir_ / "page.html").string()));
  ASSERT_EQ(elsewhere.exit_code, 0) << elsewhere.err;
  EXPECT_TRUE(fs::is_regular_file(dir_ / "page.html"));
  const CommandResult again = desslam("run " + shellQuote(sequence().string()) + " --config " +
                                      shellQuote((dir_ / "synthetic.yaml").string()) + " --out " +
                                      shellQuote(out().string()) + " --deterministic --quiet --overwrite --max-frames 30");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_FALSE(fs::exists(out() / "report.html")) << "an earlier run's page is not left beside a new run";
  EXPECT_TRUE(fs::is_regular_file(out() / "ate_over_time.svg"));
}

TEST_F(DesslamReport, WithoutGroundTruthThePlotsThatNeedItAreLeftOutAndThePageSaysWhy) {
  // 40 frames (1.3 s): enough for RPE's 1 s windows once the ground truth is given below.
  test::writeSyntheticSequence(sequence(), 40);
  fs::remove(sequence() / "groundtruth.txt");
  dir_.write("synthetic.yaml", test::syntheticConfigYaml());
  const CommandResult run = desslam("run " + shellQuote(sequence().string()) + " --config " +
                                    shellQuote((dir_ / "synthetic.yaml").string()) + " --out " +
                                    shellQuote(out().string()) + " --deterministic --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json r = report();
  EXPECT_EQ(r["plots"]["left_out"].size(), kGroundTruthPlots.size()) << r["plots"].dump(2);
  for (const std::string& id : kGroundTruthPlots) EXPECT_FALSE(fs::exists(out() / (id + ".svg"))) << id;
  EXPECT_TRUE(fs::is_regular_file(out() / "dynamic_features.svg"));
  EXPECT_TRUE(fs::is_regular_file(out() / "stage_timings.svg"));

  const CommandResult page = desslam("report " + shellQuote(out().string()));
  ASSERT_EQ(page.exit_code, 0) << page.err;
  EXPECT_CONTAINS(page.out, "left out trajectory_top: no ground truth");
  const std::string html = test::readText(out() / "report.html");
  EXPECT_CONTAINS(html, "groundtruth.txt does not exist");
  EXPECT_CONTAINS(html, "no dense_map.png in the run folder (dense.enabled was false)");
  EXPECT_CONTAINS(html, "id=\"dynamic_features\"");

  // The ground truth given on the command line instead.
  test::writeSyntheticSequence(dir_ / "with_gt", 40);
  const CommandResult given = desslam("report " + shellQuote(out().string()) + " --groundtruth " +
                                      shellQuote((dir_ / "with_gt" / "groundtruth.txt").string()));
  ASSERT_EQ(given.exit_code, 0) << given.err;
  EXPECT_EQ(given.out.find("left out"), std::string::npos) << given.out;
  EXPECT_CONTAINS(test::readText(out() / "report.html"), "id=\"trajectory_top\"");
}

TEST_F(DesslamReport, BadRunFoldersAreNamed) {
  const CommandResult missing = desslam("report " + shellQuote((dir_ / "nothing").string()));
  EXPECT_EQ(missing.exit_code, 1) << missing.err;
  EXPECT_CONTAINS(missing.err, "nothing: no such folder");
  fs::create_directories(out());
  const CommandResult empty = desslam("report " + shellQuote(out().string()));
  EXPECT_EQ(empty.exit_code, 1);
  EXPECT_CONTAINS(empty.err, "report.json not found");
  dir_.write("out/report.json", "{ truncated");
  const CommandResult broken = desslam("report " + shellQuote(out().string()));
  EXPECT_EQ(broken.exit_code, 1);
  EXPECT_CONTAINS(broken.err, "report.json is not valid JSON");
  const CommandResult no_dir = desslam("report");
  EXPECT_EQ(no_dir.exit_code, 2) << "usage";
}

}  // namespace
}  // namespace desslam
