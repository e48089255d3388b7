#pragma once
// The HTML of the episode report (EpisodeReport.h) and of the index of
// reports: self-contained pages (inline CSS, script and data; images
// beside them) that open from disk in any browser.

#include <string>

#include <nlohmann/json.hpp>

namespace vln::viz {

/// The report page for `data` (the object EpisodeReport::write() builds:
/// title, summary, columns, episodes, details).
std::string reportPageHtml(const nlohmann::json& data);

/// The index page for `reports` (an array of report.json objects, each
/// with an "href" to its page).
std::string reportIndexHtml(const nlohmann::json& reports);

/// `value` as JSON that can sit inside an HTML <script> element ("</" and
/// "<!--" cannot end or comment it out).
std::string scriptSafeJson(const nlohmann::json& value);

}  // namespace vln::viz
