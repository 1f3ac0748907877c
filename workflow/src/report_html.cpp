#include "orbcal/workflow/report_html.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string_view>
#include <vector>

#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/urdf.hpp"

namespace orbcal::workflow {

namespace {

/// Screen: a readable column, tables that scroll sideways when wide. Print: the full width of an A4 or
/// Letter page, small table type, code wrapped, no table, figure or code block split across pages.
constexpr const char* kStyle = R"(
body { font: 15px/1.45 system-ui, "Segoe UI", "DejaVu Sans", Arial, sans-serif; color: #1a1a1a;
       max-width: 72rem; margin: 2rem auto; padding: 0 1.5rem; }
h1 { font-size: 1.6rem; border-bottom: 2px solid #333; padding-bottom: .2rem; }
h2 { font-size: 1.3rem; border-bottom: 1px solid #bbb; margin-top: 2rem; }
h3 { font-size: 1.1rem; }
.verdict { border-left: 6px solid #8a4b00; background: #fff4e0; padding: .6rem 1rem; }
ul.verdict, ol.verdict { padding-left: 2.5rem; }
.verdict + .verdict { margin-top: -1em; padding-top: 0; }
.table { overflow-x: auto; margin: 1rem 0; }
table { border-collapse: collapse; font-size: .9rem; font-variant-numeric: tabular-nums; }
th, td { border: 1px solid #bbb; padding: .25rem .5rem; text-align: left; vertical-align: top; }
th { background: #e8e8e8; }
tbody tr:nth-child(even) { background: #f6f6f6; }
code, pre { font-family: "DejaVu Sans Mono", Menlo, Consolas, monospace; font-size: .88em; }
pre { background: #f4f4f4; border: 1px solid #ddd; padding: .6rem .8rem; overflow-x: auto; }
figure { margin: 1rem 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: .85rem; color: #555; }
.missing { color: #a00000; }
footer { margin-top: 3rem; font-size: .8rem; color: #666; }
@media print {
  @page { margin: 15mm; }
  body { max-width: none; margin: 0; padding: 0; font-size: 10pt; }
  .table { overflow: visible; }
  table { font-size: 8pt; }
  pre { white-space: pre-wrap; overflow: visible; }
  h1, h2, h3 { break-after: avoid; }
  figure, tr, pre, .verdict { break-inside: avoid; }
  .verdict, th, tbody tr:nth-child(even) { print-color-adjust: exact; -webkit-print-color-adjust: exact; }
  a { color: inherit; text-decoration: none; }
}
)";

/// Markdown text as HTML: sim::xmlEscaped, the one escape of orbcal's markup writers.
std::string escape(std::string_view s) { return sim::xmlEscaped(s); }

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool startsWith(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

/// The media type of a figure file by its ending; empty for any other file.
std::string mediaType(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".png") return "image/png";
  if (ext == ".jpg" || ext == ".jpeg") return "image/jpeg";
  if (ext == ".svg") return "image/svg+xml";
  return "";
}

std::optional<std::string> readBytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return std::nullopt;
  return bytes;
}

std::string figureImg(std::string_view alt, std::string_view target, const std::string& folder) {
  const std::filesystem::path given{std::string(target)};
  const std::filesystem::path file = given.is_absolute() ? given : std::filesystem::path(folder) / given;
  const std::string type = mediaType(file);
  const std::optional<std::string> bytes = type.empty() ? std::nullopt : readBytes(file);
  if (!bytes) return "<span class=\"missing\">(figure " + escape(target) + " could not be read)</span>";
  return "<img src=\"data:" + type + ";base64," + base64(*bytes) + "\" alt=\"" + escape(alt) + "\">";
}

/// `[text](target)` or `![text](target)` at s[i]: the text, the target and the index after it.
struct Bracketed {
  std::string_view text, target;
  std::size_t end = 0;
};
std::optional<Bracketed> bracketed(std::string_view s, std::size_t i) {
  const std::size_t open = s[i] == '!' ? i + 1 : i;
  if (open >= s.size() || s[open] != '[') return std::nullopt;
  const std::size_t close = s.find(']', open + 1);
  if (close == std::string_view::npos || close + 1 >= s.size() || s[close + 1] != '(') return std::nullopt;
  const std::size_t end = s.find(')', close + 2);
  if (end == std::string_view::npos) return std::nullopt;
  return Bracketed{s.substr(open + 1, close - open - 1), s.substr(close + 2, end - close - 2), end + 1};
}

/// Code spans, bold, figures and links; everything else escaped.
std::string inlineHtml(std::string_view s, const std::string& folder) {
  std::string out;
  std::size_t i = 0;
  while (i < s.size()) {
    if (s[i] == '`') {
      const std::size_t j = s.find('`', i + 1);
      if (j != std::string_view::npos) {
        out += "<code>" + escape(s.substr(i + 1, j - i - 1)) + "</code>";
        i = j + 1;
        continue;
      }
    }
    if (startsWith(s.substr(i), "**")) {
      const std::size_t j = s.find("**", i + 2);
      if (j != std::string_view::npos && j > i + 2) {
        out += "<strong>" + inlineHtml(s.substr(i + 2, j - i - 2), folder) + "</strong>";
        i = j + 2;
        continue;
      }
    }
    if (s[i] == '!' || s[i] == '[') {
      if (const std::optional<Bracketed> b = bracketed(s, i)) {
        if (s[i] == '!') {
          out += figureImg(b->text, b->target, folder);
        } else if (startsWith(trim(b->target), "javascript:")) {  // a report's page runs no script
          out += inlineHtml(b->text, folder);
        } else {
          out += "<a href=\"" + escape(b->target) + "\">" + inlineHtml(b->text, folder) + "</a>";
        }
        i = b->end;
        continue;
      }
    }
    out += escape(s.substr(i, 1));
    ++i;
  }
  return out;
}

/// The reports write a paragraph's lines as lines (a summary, then its details): each stays a line.
std::string lineBreaks(const std::string& html) {
  std::string out;
  for (char c : html) out += c == '\n' ? std::string("<br>\n") : std::string(1, c);
  return out;
}

/// A line that is one figure and nothing else: shown as a figure with its caption.
bool isFigureLine(std::string_view line) {
  line = trim(line);
  if (!startsWith(line, "![")) return false;
  const std::optional<Bracketed> b = bracketed(line, 0);
  return b && b->end == line.size();
}

int headingLevel(std::string_view line) {
  int n = 0;
  while (n < static_cast<int>(line.size()) && line[static_cast<std::size_t>(n)] == '#') ++n;
  return n >= 1 && n <= 6 && static_cast<std::size_t>(n) < line.size() && line[static_cast<std::size_t>(n)] == ' ' ? n : 0;
}

bool isTableLine(std::string_view line) { return startsWith(trim(line), "|"); }
bool isFence(std::string_view line) { return startsWith(trim(line), "```"); }

/// The length of a list item's marker ("- ", "* ", "12. ") at the start of `line`; 0: not an item.
std::size_t itemMarker(std::string_view line, bool* ordered = nullptr) {
  std::size_t i = 0;
  while (i < line.size() && i < 3 && line[i] == ' ') ++i;
  if (i + 1 < line.size() && (line[i] == '-' || line[i] == '*') && line[i + 1] == ' ') {
    if (ordered) *ordered = false;
    return i + 2;
  }
  std::size_t j = i;
  while (j < line.size() && std::isdigit(static_cast<unsigned char>(line[j]))) ++j;
  if (j > i && j + 1 < line.size() && line[j] == '.' && line[j + 1] == ' ') {
    if (ordered) *ordered = true;
    return j + 2;
  }
  return 0;
}

/// A line that starts a block of its own (and so ends a paragraph or a list).
bool startsBlock(std::string_view line) {
  return headingLevel(line) > 0 || isFence(line) || isTableLine(line) || isFigureLine(line);
}

/// The cells of a table row: split at '|' outside code spans; "\|" is a literal bar.
std::vector<std::string> cells(std::string_view row) {
  row = trim(row);
  if (startsWith(row, "|")) row.remove_prefix(1);
  if (!row.empty() && row.back() == '|' && !(row.size() >= 2 && row[row.size() - 2] == '\\')) row.remove_suffix(1);
  std::vector<std::string> out(1);
  bool code = false;
  for (std::size_t i = 0; i < row.size(); ++i) {
    if (row[i] == '\\' && i + 1 < row.size() && row[i + 1] == '|') {
      out.back() += '|';
      ++i;
    } else if (row[i] == '|' && !code) {
      out.emplace_back();
    } else {
      if (row[i] == '`') code = !code;
      out.back() += row[i];
    }
  }
  for (std::string& c : out) c = std::string(trim(c));
  return out;
}

bool isSeparatorRow(std::string_view row) {
  bool dash = false;
  for (char c : row) {
    if (c == '-') dash = true;
    else if (c != '|' && c != ':' && c != ' ') return false;
  }
  return dash;
}

std::string tableHtml(const std::vector<std::string_view>& rows, const std::string& folder) {
  const bool header = rows.size() >= 2 && isSeparatorRow(rows[1]);
  std::string out = "<div class=\"table\"><table>\n";
  for (std::size_t r = 0; r < rows.size(); ++r) {
    if (header && r == 1) continue;
    const char* cell = header && r == 0 ? "th" : "td";
    if (header && r == 0) out += "<thead>";
    if (r == (header ? 2 : 0)) out += "<tbody>";
    out += "<tr>";
    for (const std::string& c : cells(rows[r])) out += std::string("<") + cell + ">" + inlineHtml(c, folder) + "</" + cell + ">";
    out += "</tr>";
    if (header && r == 0) out += "</thead>";
    out += "\n";
  }
  if (rows.size() > (header ? 2u : 0u)) out += "</tbody>";
  return out + "</table></div>\n";
}

/// The Markdown body as HTML, and the text of its first "# " heading.
struct Body {
  std::string html, title;
};

Body bodyHtml(const std::vector<std::string_view>& lines, const std::string& folder) {
  Body body;
  bool in_sections = false;  // past the first "## ": bold paragraphs are no longer the verdict
  bool verdict_open = false;  // the last block was the verdict: a list right after it is its list
  std::size_t i = 0;
  const auto blank = [&](std::size_t k) { return trim(lines[k]).empty(); };
  while (i < lines.size()) {
    const std::string_view line = lines[i];
    const bool after_verdict = verdict_open;
    verdict_open = verdict_open && blank(i);
    if (blank(i)) {
      ++i;
    } else if (isFence(line)) {
      std::string code;
      for (++i; i < lines.size() && !isFence(lines[i]); ++i) code += escape(lines[i]) + "\n";
      body.html += "<pre><code>" + code + "</code></pre>\n";
      ++i;  // the closing fence
    } else if (const int level = headingLevel(line)) {
      const std::string_view text = trim(line.substr(static_cast<std::size_t>(level)));
      if (level == 1 && body.title.empty()) {
        for (char c : text) body.title += c == '`' || c == '*' ? "" : std::string(1, c);
      }
      in_sections = in_sections || level == 2;
      const std::string h = "h" + std::to_string(level);
      body.html += "<" + h + ">" + inlineHtml(text, folder) + "</" + h + ">\n";
      ++i;
    } else if (isTableLine(line)) {
      std::vector<std::string_view> rows;
      for (; i < lines.size() && isTableLine(lines[i]); ++i) rows.push_back(lines[i]);
      body.html += tableHtml(rows, folder);
    } else if (isFigureLine(line)) {
      const std::optional<Bracketed> b = bracketed(trim(line), 0);
      body.html += "<figure>" + figureImg(b->text, b->target, folder) + "<figcaption>" + inlineHtml(b->text, folder) +
                   "</figcaption></figure>\n";
      ++i;
    } else if (bool ordered = false; itemMarker(line, &ordered) > 0) {
      std::vector<std::string> items;
      for (; i < lines.size() && !blank(i) && (items.empty() || !startsBlock(lines[i])); ++i) {
        const std::size_t marker = itemMarker(lines[i]);
        if (marker > 0) items.emplace_back(lines[i].substr(marker));
        else items.back() += "\n" + std::string(trim(lines[i]));
      }
      verdict_open = after_verdict;
      const std::string list = ordered ? "ol" : "ul";
      body.html += "<" + list + (after_verdict ? " class=\"verdict\">\n" : ">\n");
      for (const std::string& item : items) body.html += "<li>" + lineBreaks(inlineHtml(item, folder)) + "</li>\n";
      body.html += "</" + list + ">\n";
    } else {
      std::string text;
      for (; i < lines.size() && !blank(i) && (text.empty() || (!startsBlock(lines[i]) && itemMarker(lines[i]) == 0)); ++i) {
        text += (text.empty() ? "" : "\n") + std::string(trim(lines[i]));
      }
      const bool verdict = !in_sections && startsWith(text, "**");
      verdict_open = verdict;
      body.html += (verdict ? "<p class=\"verdict\">" : "<p>") + lineBreaks(inlineHtml(text, folder)) + "</p>\n";
    }
  }
  return body;
}

}  // namespace

std::string base64(const std::string& bytes) {
  static constexpr char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    unsigned v = 0;
    for (std::size_t k = 0; k < 3; ++k) v = (v << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kDigits[(v >> (18 - 6 * k)) & 0x3f] : '=';
  }
  return out;
}

std::string reportHtml(const std::string& markdown, const std::string& folder) {
  std::vector<std::string_view> lines;
  const std::string_view md(markdown);
  for (std::size_t start = 0; start <= md.size();) {
    std::size_t end = md.find('\n', start);
    if (end == std::string_view::npos) end = md.size();
    lines.push_back(md.substr(start, end - start));
    start = end + 1;
  }
  const Body body = bodyHtml(lines, folder);
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
         "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
         "<meta name=\"generator\" content=\"orbcal " ORBCAL_VERSION "\">\n<title>" +
         escape(body.title.empty() ? std::string("orbcal report") : body.title) + "</title>\n<style>" + kStyle +
         "</style>\n</head>\n<body>\n" + body.html + "<footer>Written by orbcal " ORBCAL_VERSION
         "; the same report as Markdown is beside this file.</footer>\n</body>\n</html>\n";
}

void writeReport(const std::string& folder, const std::string& markdown, const std::string& markdown_name) {
  sim::writeFileAtomic(folder + "/" + markdown_name, markdown);
  sim::writeFileAtomic(folder + "/report.html", reportHtml(markdown, folder));
}

}  // namespace orbcal::workflow
