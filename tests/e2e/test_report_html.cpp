// report.html: the Markdown subset the reports use turned into one self-contained page (figures as data
// URIs, nothing loaded from elsewhere, the verdict set off), and a measured-data calibration that draws
// its figures into it. tests/browser/check_report.py opens such pages in a real browser.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <regex>

#include "orbcal/sim/io.hpp"
#include "orbcal/workflow/measured.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

/// Every src= and href= of the page: a self-contained page has only data: sources and no link out.
std::vector<std::string> references(const std::string& html) {
  std::vector<std::string> refs;
  const std::regex attr(R"re((src|href)="([^"]*)")re");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), attr); it != std::sregex_iterator(); ++it) refs.push_back((*it)[2]);
  return refs;
}

}  // namespace

TEST_CASE("base64: the test vectors of RFC 4648 section 10", "[report][html]") {
  CHECK(workflow::base64("") == "");
  CHECK(workflow::base64("f") == "Zg==");
  CHECK(workflow::base64("fo") == "Zm8=");
  CHECK(workflow::base64("foo") == "Zm9v");
  CHECK(workflow::base64("foob") == "Zm9vYg==");
  CHECK(workflow::base64("fooba") == "Zm9vYmE=");
  CHECK(workflow::base64("foobar") == "Zm9vYmFy");
  CHECK(workflow::base64(std::string("\xff\x00\x80", 3)) == "/wCA");  // high bytes are not sign-extended
}

TEST_CASE("report.html: headings, tables, lists, code, bold and figures of the reports' Markdown", "[report][html]") {
  const std::string dir = test::tempDir("report-html");
  const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + "not a real image";
  std::ofstream(dir + "/fig.png", std::ios::binary) << png;
  const std::string md =
      "# Calibration of `arm` <1>\n\n"
      "**The calibration is not accepted: too few samples.** model.yaml was not written.\n\n"
      "- reason one\n- reason two\n\n"
      "Text with `a<b` and **bold** and a [link](files.csv),\nwrapped.\n\n"
      "## Table\n\n"
      "| model | a \\| b | `x|y` |\n|---|---|---|\n| nominal | 1.5 | 2 * |\n| calibrated | 0.1 | 3 |\n\n"
      "- identification: 50 images\n  median 0.047 px\n- validation: 200 images\n\n"
      "1. first\n2. second\n\n"
      "```\n  joint 1: <theta> & alpha\n```\n\n"
      "**Bold after the first section is no verdict.**\n\n"
      "![held-out errors](fig.png)\n![absent](absent.png)\n(figures not drawn: --no-plots)\n";
  const std::string html = workflow::reportHtml(md, dir);
  CAPTURE(html);

  CHECK(html.find("<title>Calibration of arm &lt;1&gt;</title>") != std::string::npos);
  CHECK(html.find("<h1>Calibration of <code>arm</code> &lt;1&gt;</h1>") != std::string::npos);
  CHECK(html.find("<h2>Table</h2>") != std::string::npos);
  // The verdict: a bold paragraph before the first section and the list of its reasons, and only those.
  CHECK(count(html, "class=\"verdict\"") == 2);
  CHECK(html.find("<ul class=\"verdict\">\n<li>reason one</li>\n<li>reason two</li>\n</ul>") != std::string::npos);
  CHECK(html.find("<ul>\n<li>identification") != std::string::npos);  // a list after other text is no verdict
  CHECK(html.find("<p class=\"verdict\"><strong>The calibration is not accepted") != std::string::npos);
  CHECK(html.find("<p><strong>Bold after the first section") != std::string::npos);
  CHECK(html.find("<code>a&lt;b</code> and <strong>bold</strong> and a <a href=\"files.csv\">link</a>,<br>\nwrapped.") !=
        std::string::npos);
  // The table: one header row, two body rows, an escaped bar and a bar inside code kept in their cells.
  CHECK(html.find("<thead><tr><th>model</th><th>a | b</th><th><code>x|y</code></th></tr></thead>") != std::string::npos);
  CHECK(count(html, "<tr>") == 3);
  CHECK(html.find("<td>2 *</td>") != std::string::npos);
  // Lists: a continuation line belongs to its item, on a line of its own; ordered lists stay ordered.
  CHECK(html.find("<li>identification: 50 images<br>\nmedian 0.047 px</li>") != std::string::npos);
  CHECK(html.find("<ol>\n<li>first</li>\n<li>second</li>\n</ol>") != std::string::npos);
  CHECK(html.find("<pre><code>  joint 1: &lt;theta&gt; &amp; alpha\n</code></pre>") != std::string::npos);
  // The figure embedded byte for byte; the absent one said to be absent; the not-drawn line kept.
  CHECK(html.find("<img src=\"data:image/png;base64," + workflow::base64(png) + "\" alt=\"held-out errors\">") != std::string::npos);
  CHECK(html.find("<figcaption>held-out errors</figcaption>") != std::string::npos);
  CHECK(html.find("(figure absent.png could not be read)") != std::string::npos);
  CHECK(html.find("<p>(figures not drawn: --no-plots)</p>") != std::string::npos);
  // Self-contained and printable.
  for (const std::string& ref : references(html)) {
    CAPTURE(ref);
    CHECK((ref.rfind("data:image/png;base64,", 0) == 0 || ref == "files.csv"));
  }
  CHECK(html.find("@media print") != std::string::npos);
  CHECK(html.find("<script") == std::string::npos);
}

TEST_CASE("report.html: markup in the report's text is shown, never run", "[report][html]") {
  const std::string html = workflow::reportHtml("# x\n\nrobot `<script>alert(1)</script>` and <img src=x onerror=y>\n\n"
                                                "[click](javascript:alert(1))\n",
                                                ".");
  CHECK(html.find("<script") == std::string::npos);
  CHECK(html.find("<img") == std::string::npos);
  CHECK(html.find("javascript:") == std::string::npos);
  CHECK(html.find("&lt;img src=x onerror=y&gt;") != std::string::npos);
}

TEST_CASE("writeReport writes the Markdown and report.html beside it", "[report][html]") {
  const std::string dir = test::tempDir("report-html-write");
  workflow::writeReport(dir, "# Evaluation\n\nbody\n", "evaluation.md");
  CHECK(test::slurp(dir + "/evaluation.md") == "# Evaluation\n\nbody\n");
  CHECK(test::slurp(dir + "/report.html").find("<h1>Evaluation</h1>") != std::string::npos);
}

TEST_CASE("calibrate on measured data: held-out and parameter figures in report.md and report.html; --no-plots draws none",
          "[e2e][measured][report]") {
  const std::string dir = test::tempDir("measured-figures");
  sim::SimulationSpec s;  // one session of the iiwa7 with random DH errors: a geometric calibration is accepted
  s.samples = 60;
  s.sessions = 1;
  s.payload_kg = {0.0};
  s.seed = 5;
  const sim::SimulatedData d = workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s, dir + "/data");

  const test::OrbcalRun run = test::runOrbcal(dir, "calibrate '" + d.data.description + "' -o cal --quiet");
  CAPTURE(run.out, run.err);
  REQUIRE(run.status == 0);
  const std::string md = test::slurp(dir + "/cal/report.md");
  const std::string html = test::slurp(dir + "/cal/report.html");
  if (md.find("python3 with matplotlib is needed") != std::string::npos) ORBCAL_SKIP("python3 with matplotlib absent: no figures");
  CHECK(md.find("![held-out error per sample") != std::string::npos);
  CHECK(md.find("![parameter estimates with their 1-sigma](parameters.png)") != std::string::npos);
  CHECK(std::filesystem::file_size(dir + "/cal/heldout.png") > 1000);
  CHECK(std::filesystem::file_size(dir + "/cal/parameters.png") > 1000);
  CHECK(count(html, "<img src=\"data:image/png;base64,") == 2);
  CHECK(html.find("<p class=\"verdict\"><strong>Accepted") != std::string::npos);

  // heldout.csv: one row per held-out sample; the position floor is the same on every row and below the
  // calibrated errors' largest (a floor above every error would be no floor).
  std::ifstream csv(dir + "/cal/heldout.csv");
  std::string line;
  std::getline(csv, line);
  CHECK(line == "sample,session,before_mm,after_mm,floor_mm,before_deg,after_deg,floor_deg");
  int rows = 0;
  for (; std::getline(csv, line); ++rows) CHECK(std::count(line.begin(), line.end(), ',') == 7);
  CHECK(rows > 0);
  CHECK(run.out.find(std::to_string(rows) + " held out") != std::string::npos);

  const test::OrbcalRun quiet = test::runOrbcal(dir, "calibrate '" + d.data.description + "' -o cal2 --quiet --no-plots");
  REQUIRE(quiet.status == 0);
  CHECK_FALSE(std::filesystem::exists(dir + "/cal2/heldout.png"));
  CHECK(test::slurp(dir + "/cal2/report.md").find("(figures not drawn: --no-plots)") != std::string::npos);
  CHECK(test::slurp(dir + "/cal2/report.html").find("<img") == std::string::npos);
}
