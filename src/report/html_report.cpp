#include "report/html_report.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <sstream>

#include "plot/svg.hpp"
#include "report/maps_apart.hpp"

namespace desslam::report {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

std::string esc(std::string_view text) { return plot::xmlEscape(text); }

// The value at a JSON pointer ("/ate/translation_m/rmse"), or null when any step is missing.
const json& at(const json& j, const std::string& pointer) {
  static const json null_value;
  try {
    const json::json_pointer p(pointer);
    return j.contains(p) ? j.at(p) : null_value;
  } catch (const json::exception&) {
    return null_value;
  }
}

std::string fixed(double v, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, v);
  return text;
}

// A JSON value as table text: numbers with `decimals` (integers as they are), strings bare.
std::string show(const json& v, int decimals = 3) {
  if (v.is_null()) return "-";
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number()) return fixed(v.get<double>(), decimals);
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

std::string percent(const json& v) { return v.is_number() ? fixed(100.0 * v.get<double>(), 1) + " %" : "-"; }

struct Table {
  std::ostringstream html;
  explicit Table(const std::string& caption = "") {
    html << "<table>";
    if (!caption.empty()) html << "<caption>" << esc(caption) << "</caption>";
    html << "\n";
  }
  void header(const std::vector<std::string>& cells) {
    html << "<tr>";
    for (const std::string& c : cells) html << "<th>" << esc(c) << "</th>";
    html << "</tr>\n";
  }
  void row(const std::vector<std::string>& cells) {
    html << "<tr>";
    for (size_t k = 0; k < cells.size(); ++k) html << (k == 0 ? "<th>" : "<td>") << esc(cells[k]) << (k == 0 ? "</th>" : "</td>");
    html << "</tr>\n";
  }
  std::string str() { return html.str() + "</table>\n"; }
};

std::string readBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The page's style: no web fonts, nothing fetched.
constexpr const char* kStyle = R"(
body { font-family: sans-serif; margin: 24px auto; max-width: 1000px; color: #222; line-height: 1.4; }
h1 { font-size: 24px; margin-bottom: 4px; }
h2 { font-size: 19px; margin-top: 32px; border-bottom: 1px solid #ccc; padding-bottom: 3px; }
h3 { font-size: 15px; margin: 22px 0 6px; }
.sub { color: #555; font-size: 13px; word-break: break-all; }
table { border-collapse: collapse; margin: 8px 0 12px; font-size: 13px; }
caption { text-align: left; font-weight: bold; padding: 4px 0; }
th, td { border: 1px solid #d0d0d0; padding: 3px 8px; text-align: left; vertical-align: top; }
th { background: #f3f3f3; font-weight: normal; }
td.num { text-align: right; }
.figures { display: flex; flex-wrap: wrap; gap: 0 24px; }
.status { padding: 8px 12px; border-radius: 4px; margin: 12px 0; }
.ok { background: #e8f5e9; border: 1px solid #a5d6a7; }
.bad { background: #fdecea; border: 1px solid #f5a9a1; }
.note { background: #fff8e1; border: 1px solid #ffe082; }
figure { margin: 0 0 18px; }
figure svg { max-width: 100%; height: auto; border: 1px solid #e4e4e4; }
figcaption { font-size: 13px; color: #444; margin-top: 4px; }
img.dense { max-width: 100%; border: 1px solid #e4e4e4; }
.settings td { font-family: monospace; font-size: 12px; }
nav a { margin-right: 12px; font-size: 13px; }
)";

std::string statusBlock(const json& r) {
  std::ostringstream out;
  const auto block = [&out](const char* cls, const std::string& text) {
    out << "<div class=\"status " << cls << "\">" << esc(text) << "</div>\n";
  };
  bool trouble = false;
  if (at(r, "/error").is_string()) {
    block("bad", "The run failed: " + at(r, "/error").get<std::string>());
    trouble = true;
  }
  if (at(r, "/interrupted").is_boolean() && at(r, "/interrupted").get<bool>()) {
    const json& i = at(r, "/interruption");
    block("bad", "Interrupted by " + show(at(i, "/signal")) + " during " + show(at(i, "/stage")) + " after " +
                     show(at(i, "/frames_processed")) + " of " + show(at(i, "/frames_in_run")) +
                     " frames (final global BA " + show(at(i, "/final_global_ba")) + ").");
    trouble = true;
  }
  if (at(r, "/nothing_tracked").is_string()) {
    block("bad", at(r, "/nothing_tracked").get<std::string>());
    trouble = true;
  }
  if (at(r, "/evaluation_error").is_string()) block("note", "No ATE/RPE: " + at(r, "/evaluation_error").get<std::string>());
  if (at(r, "/plots/error").is_string()) block("note", "The run could not draw its plots: " + at(r, "/plots/error").get<std::string>());
  if (!trouble)
    block("ok", "The run ended normally (exit status " + show(at(r, "/exit_code")) + ", " +
                    show(at(r, "/statistics/mode")) + " mode).");
  return out.str();
}

std::string keyFigures(const json& r) {
  Table t("Key figures");
  const json& c = at(r, "/statistics/counts");
  const json& atlas = at(r, "/statistics/atlas");
  const double frames = at(c, "/frames").is_number() ? at(c, "/frames").get<double>() : 0;
  const auto share = [frames](const json& n) {
    return n.is_number() && frames > 0 ? show(n) + " (" + fixed(100.0 * n.get<double>() / frames, 1) + " %)" : show(n);
  };
  t.row({"frames processed", show(at(c, "/frames"))});
  t.row({"tracked by features", share(at(c, "/frames_tracked"))});
  t.row({"with a pose (tracked or predicted)", share(at(c, "/frames_with_pose"))});
  t.row({"predicted poses", show(at(c, "/predicted_poses"))});
  if (at(r, "/ate").is_object()) {
    const json& a = at(r, "/ate/translation_m");
    t.row({"ATE RMSE / mean / median / max (m)", show(at(a, "/rmse"), 4) + " / " + show(at(a, "/mean"), 4) + " / " +
                                                     show(at(a, "/median"), 4) + " / " + show(at(a, "/max"), 4)});
    t.row({"ATE poses matched (of ground truth)", show(at(r, "/ate/matched")) + " (" + show(at(r, "/ate/gt_poses")) + ")"});
    t.row({"RPE translation RMSE (m per " + show(at(r, "/rpe/delta_s"), 1) + " s)", show(at(r, "/rpe/translation_m/rmse"), 4)});
    t.row({"RPE rotation RMSE (deg per " + show(at(r, "/rpe/delta_s"), 1) + " s)", show(at(r, "/rpe/rotation_deg/rmse"), 3)});
    t.row({"frames with ground truth that have a pose: main map / any map",
           percent(at(r, "/tracked_share_of_associated_frames")) + " / " + percent(at(r, "/tracked_share_any_map"))});
  } else {
    t.row({"ATE / RPE", "none (no ground truth)"});
  }
  t.row({"frames per second (wall)", show(at(r, "/frames_per_second"), 2) + " (" + show(at(r, "/wall_seconds"), 1) + " s)"});
  t.row({"tracking per frame, median / p95 (ms)",
         show(at(r, "/statistics/timings_ms/tracking/median"), 1) + " / " + show(at(r, "/statistics/timings_ms/tracking/p95"), 1)});
  t.row({"tracking losses / relocalisations", show(at(c, "/tracking_losses")) + " / " + show(at(c, "/relocalisations"))});
  t.row({"atlas: maps started / merges / main map (its frames)",
         show(at(atlas, "/maps_started")) + " / " + show(at(atlas, "/merges")) + " / " + show(at(atlas, "/main_map")) +
             " (" + show(at(atlas, "/frames_in_main_map")) + ")"});
  if (const auto apart = mapsApartWarning(at(r, "/statistics")); apart) t.row({"frames outside the main map", *apart});
  t.row({"loops closed", show(at(r, "/statistics/loop_closing/loops_closed"))});
  t.row({"keyframes / map points", show(at(c, "/keyframes")) + " / " + show(at(c, "/map_points"))});
  const json& d = at(r, "/statistics/dynamic");
  t.row({"dynamic mode; features in mask / removed by mask / stage 1 / stage 2",
         show(at(d, "/mode")) + "; " + show(at(d, "/features_in_mask")) + " / " + show(at(d, "/removed_by_mask")) + " / " +
             show(at(d, "/removed_stage1")) + " / " + show(at(d, "/removed_stage2"))});
  const json& dense = at(r, "/dense");
  if (dense.is_object() && dense.value("enabled", true))
    t.row({"dense map", dense.contains("note") ? show(dense["note"])
                                               : show(dense.value("map_points", json())) + " points from " +
                                                     show(dense.value("keyframes", json())) + " keyframes"});
  else
    t.row({"dense map", "off"});
  t.row({"interrupted / error", show(at(r, "/interrupted")) + " / " + (at(r, "/error").is_string() ? show(at(r, "/error")) : "none")});
  t.row({"exit status", show(at(r, "/exit_code"))});
  return t.str();
}

std::string atlasTable(const json& r) {
  const json& maps = at(r, "/statistics/atlas/maps");
  if (!maps.is_array() || maps.empty()) return "";
  Table t("Maps of the atlas");
  t.header({"map", "reason", "frames", "keyframes", "time span (s)", "merged into", "merged at (s)"});
  const json& first = at(r, "/statistics/per_frame/0/timestamp");
  const double t0 = first.is_number() ? first.get<double>() : 0;
  for (const json& m : maps) {
    const json& span = at(m, "/time_span");
    const std::string span_text = span.is_array() && span.size() == 2 && span[0].is_number()
                                      ? fixed(span[0].get<double>() - t0, 2) + " - " + fixed(span[1].get<double>() - t0, 2)
                                      : "-";
    const json& merged_at = at(m, "/merged_at");
    t.row({show(at(m, "/id")), show(at(m, "/reason")), show(at(m, "/frames")), show(at(m, "/keyframes")), span_text,
           show(at(m, "/merged_into")), merged_at.is_number() ? fixed(merged_at.get<double>() - t0, 2) : "-"});
  }
  return t.str();
}

std::string timingsTable(const json& r) {
  const json& timings = at(r, "/statistics/timings_ms");
  if (!timings.is_object()) return "";
  Table t("Per-frame stage timings (ms)");
  t.header({"stage", "median", "p95", "mean", "frames"});
  for (const auto& [name, s] : timings.items())
    t.row({name, show(at(s, "/median"), 2), show(at(s, "/p95"), 2), show(at(s, "/mean"), 2), show(at(s, "/count"))});
  return t.str();
}

std::string settingsTable(const json& r) {
  std::ostringstream out;
  out << "<table class=\"settings\">\n";
  out << "<tr><th>config</th><td>" << esc(show(at(r, "/config"))) << "</td></tr>\n";
  out << "<tr><th>overrides (--set)</th><td>" << esc(at(r, "/overrides").is_array() ? at(r, "/overrides").dump() : "-")
      << "</td></tr>\n";
  const json& settings = at(r, "/settings");
  if (settings.is_object())
    for (const auto& [section, values] : settings.items()) {
      out << "<tr><th>" << esc(section) << "</th><td>";
      if (values.is_object()) {
        bool first = true;
        for (const auto& [key, value] : values.items()) {
          // Strings bare (empty ones as "" so that "key = " is not read as a missing value).
          const std::string text = value.is_string() && !value.get<std::string>().empty() ? value.get<std::string>()
                                                                                          : value.dump();
          out << (first ? "" : "; ") << esc(key) << " = " << esc(text);
          first = false;
        }
      } else {
        out << esc(values.dump());
      }
      out << "</td></tr>\n";
    }
  out << "</table>\n";
  return out.str();
}

std::string warningsList(const json& r) {
  const json& warnings = at(r, "/input_warnings");
  if (!warnings.is_array() || warnings.empty()) return "";
  std::ostringstream out;
  out << "<h2 id=\"warnings\">Input warnings (" << warnings.size() << ")</h2>\n<ul>\n";
  size_t shown = 0;
  for (const json& w : warnings) {
    if (++shown > 20) break;
    out << "<li>" << esc(show(w)) << "</li>\n";
  }
  out << "</ul>\n";
  if (warnings.size() > 20) out << "<p>... and " << warnings.size() - 20 << " more (report.json input_warnings).</p>\n";
  return out.str();
}

}  // namespace

std::string base64Encode(std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const size_t n = std::min<size_t>(3, bytes.size() - i);
    uint32_t group = 0;
    for (size_t k = 0; k < 3; ++k)
      group = (group << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    for (size_t k = 0; k < 4; ++k) out += k <= n ? kAlphabet[(group >> (18 - 6 * k)) & 0x3f] : '=';
  }
  return out;
}

std::string renderHtmlReport(const RunFolder& run, const RunPlots& plots) {
  const json& r = run.report;
  std::ostringstream out;
  out << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      << "<title>DeS-SLAM run: " << esc(fs::path(show(at(r, "/sequence"))).filename().string()) << "</title>\n"
      << "<style>" << kStyle << "</style>\n</head>\n<body>\n";
  out << "<h1>DeS-SLAM run report</h1>\n";
  out << "<div class=\"sub\">sequence " << esc(show(at(r, "/sequence"))) << "<br>run folder " << esc(run.dir.string())
      << "<br>ground truth " << esc(run.ground_truth ? run.ground_truth_file.string() : "none") << "</div>\n";
  out << "<nav><a href=\"#figures\">figures</a><a href=\"#plots\">plots</a><a href=\"#dense\">dense map</a>"
      << "<a href=\"#atlas\">atlas and timings</a><a href=\"#settings\">settings</a></nav>\n";
  out << statusBlock(r);

  out << "<h2 id=\"figures\">Figures of report.json</h2>\n" << keyFigures(r);

  out << "<h2 id=\"plots\">Plots</h2>\n";
  for (const RunPlot& plot : plots.plots) {
    out << "<figure id=\"figure-" << esc(plot.id) << "\">\n";
    // Inline SVG: the same document as the .svg file beside report.json, minus the XML prolog
    // (there is none) - the browser draws it without fetching anything.
    out << plot.svg;
    out << "<figcaption>" << esc(plot.caption) << " (<code>" << esc(plot.fileName()) << "</code>)</figcaption>\n</figure>\n";
  }
  if (!plots.left_out.empty()) {
    out << "<div class=\"status note\">Left out:<ul>\n";
    for (const LeftOutPlot& p : plots.left_out) out << "<li><b>" << esc(p.id) << "</b>: " << esc(p.reason) << "</li>\n";
    out << "</ul></div>\n";
  }
  for (const std::string& note : run.notes) out << "<div class=\"status note\">" << esc(note) << "</div>\n";

  out << "<h2 id=\"dense\">Dense map preview</h2>\n";
  const fs::path preview = run.dir / "dense_map.png";
  std::error_code ec;
  if (fs::is_regular_file(preview, ec)) {
    out << "<img class=\"dense\" alt=\"dense map preview (dense_map.png)\" src=\"data:image/png;base64,"
        << base64Encode(readBytes(preview)) << "\">\n";
  } else {
    const json& dense = at(r, "/dense");
    std::string why = "no dense_map.png in the run folder";
    if (dense.is_object() && dense.contains("enabled") && dense["enabled"].is_boolean() && !dense["enabled"].get<bool>())
      why += " (dense.enabled was false)";
    else if (dense.is_object() && dense.contains("note"))
      why += " (" + show(dense["note"]) + ")";
    out << "<div class=\"status note\">" << esc(why) << "</div>\n";
  }

  out << "<h2 id=\"atlas\">Atlas and timings</h2>\n" << atlasTable(r) << timingsTable(r);
  out << "<h2 id=\"settings\">Settings</h2>\n" << settingsTable(r);
  out << warningsList(r);
  out << "</body>\n</html>\n";
  return out.str();
}

}  // namespace desslam::report
