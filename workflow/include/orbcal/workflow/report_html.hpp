#pragma once
// Reports as one file a reader can open, print or mail: every command that writes report.md writes
// report.html beside it, made from the same Markdown, with its figures embedded (data URIs), its style
// inline and a print stylesheet; it loads nothing from elsewhere.
#include <string>

namespace orbcal::workflow {

/// The HTML page of a report in the Markdown subset orbcal's reports use: ATX headings (# to ######),
/// paragraphs (a line break inside one is kept), pipe tables (a header row, a |---| row, body rows), "- " and "1. " lists (lines that
/// follow an item without a blank line continue it), ``` fenced code, `code`, **bold**, [links](url) and
/// ![figures](file.png). A figure's file, relative to `folder` (or absolute), is embedded as a base64
/// data URI (PNG, JPEG, SVG by its ending); one that cannot be read is shown as a line saying so. Bold
/// paragraphs before the first "## " heading are the report's verdict and are set off as such, with a
/// list that follows one directly (its reasons). The
/// page title is the first "# " heading. Everything else is HTML-escaped: the page runs no script.
std::string reportHtml(const std::string& markdown, const std::string& folder);

/// Writes folder/`markdown_name` and folder/report.html (reportHtml), each atomically
/// (sim::writeFileAtomic): a reader sees the previous file or the whole new one.
void writeReport(const std::string& folder, const std::string& markdown, const std::string& markdown_name = "report.md");

/// RFC 4648 base64 of `bytes` (with '=' padding).
std::string base64(const std::string& bytes);

}  // namespace orbcal::workflow
