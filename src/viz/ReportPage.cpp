#include "viz/ReportPage.h"

#include <string_view>

namespace vln::viz {

namespace {

// Everything but the data: the page is static, its script builds the table
// and the detail pane from the REPORT object and the location's hash.
constexpr std::string_view kStyle = R"CSS(
body { font: 14px/1.4 system-ui, sans-serif; margin: 0; color: #222; }
header { padding: 10px 16px; background: #f4f4f4; border-bottom: 1px solid #ddd; }
header h1 { font-size: 18px; margin: 0 0 4px; }
#summary span { margin-right: 14px; }
main { display: flex; gap: 16px; padding: 12px 16px; align-items: flex-start; }
#list { flex: 0 0 auto; max-height: calc(100vh - 90px); overflow: auto; }
#detail { flex: 1 1 auto; min-width: 0; }
table { border-collapse: collapse; font-variant-numeric: tabular-nums; }
th, td { padding: 3px 7px; border-bottom: 1px solid #e4e4e4; text-align: right; }
th { position: sticky; top: 0; background: #fff; cursor: pointer; user-select: none; }
th.sorted-asc::after { content: " \25B2"; } th.sorted-desc::after { content: " \25BC"; }
tr.episode-row { cursor: pointer; } tr.episode-row:hover { background: #f0f6ff; }
tr.selected { background: #dbe9ff !important; }
tr.has-detail td:first-child { font-weight: 600; }
#instruction { font-size: 15px; line-height: 1.9; margin: 6px 0 10px; }
#instruction .word { padding: 1px 2px; border-radius: 3px; }
#instruction .top-word { outline: 2px solid #c45a00; }
.views { display: flex; gap: 12px; flex-wrap: wrap; align-items: flex-start; }
#frame { image-rendering: pixelated; width: 384px; height: auto; border: 1px solid #ccc; }
#map-box { position: relative; width: min(640px, 100%); }
#map-box img { width: 100%; display: block; }
#map-box svg { position: absolute; left: 0; top: 0; width: 100%; height: 100%; pointer-events: none; }
#controls { margin: 8px 0; display: flex; gap: 8px; align-items: center; }
#step-slider { width: 320px; }
#metrics td:first-child { text-align: left; color: #555; }
.note { color: #777; font-style: italic; }
)CSS";

constexpr std::string_view kScript = R"JS(
"use strict";
window.addEventListener("error", e => {
  document.body.dataset.errors = (document.body.dataset.errors || "") + e.message + ";";
});
const R = REPORT;
const NAMES = { success: "SR", spl: "SPL", ndtw: "nDTW", distance_to_goal: "NE (m)",
  path_length: "TL (m)", oracle_success: "OS", steps_taken: "steps", sdtw: "SDTW",
  oracle_spl: "oracle SPL", oracle_navigation_error: "oracle NE (m)" };
const state = { episode: null, step: 0, sort: "index", order: "asc" };
const $ = id => document.getElementById(id);
const fmt = (v, name) => v === null || v === undefined ? "-" :
  (name === "steps_taken" || name === "index" ? String(Math.round(v)) : v.toFixed(3));

function readHash() {
  const p = new URLSearchParams(location.hash.slice(1));
  if (p.has("episode")) state.episode = p.get("episode");
  if (p.has("step")) state.step = Math.max(0, parseInt(p.get("step"), 10) || 0);
  if (p.has("sort")) state.sort = p.get("sort");
  if (p.has("order")) state.order = p.get("order") === "desc" ? "desc" : "asc";
}
function writeHash() {
  const p = new URLSearchParams();
  if (state.episode !== null) { p.set("episode", state.episode); p.set("step", state.step); }
  p.set("sort", state.sort); p.set("order", state.order);
  history.replaceState(null, "", "#" + p.toString());
}

function summary() {
  $("title").textContent = R.title;
  document.title = R.title;
  const parts = [R.episodes_scored + " of " + R.episodes_total + " episodes scored"];
  for (const m of R.columns) if (m !== "steps_taken") parts.push(NAMES[m] + " " + fmt(R.summary[m], m));
  $("summary").innerHTML = "";
  for (const t of parts) { const s = document.createElement("span"); s.textContent = t; $("summary").appendChild(s); }
}

function sortValue(e, key) {
  if (key === "index") return e.index;
  if (key === "id") return Number(e.id);
  const v = e.metrics[key];
  return v === null || v === undefined ? -Infinity : v;
}
function buildTable() {
  const head = $("episodes").tHead.rows[0];
  head.innerHTML = "";
  const keys = ["index", "id"].concat(R.columns);
  for (const k of keys) {
    const th = document.createElement("th");
    th.textContent = k === "index" ? "#" : k === "id" ? "episode" : NAMES[k] || k;
    th.dataset.key = k;
    if (k === state.sort) th.className = "sorted-" + state.order;
    th.addEventListener("click", () => {
      state.order = state.sort === k && state.order === "asc" ? "desc" : "asc";
      state.sort = k; writeHash(); buildTable();
    });
    head.appendChild(th);
  }
  const rows = R.episodes.slice().sort((a, b) => {
    const d = sortValue(a, state.sort) - sortValue(b, state.sort);
    return (state.order === "desc" ? -d : d) || a.index - b.index;
  });
  const body = $("episodes").tBodies[0];
  body.innerHTML = "";
  for (const e of rows) {
    const tr = document.createElement("tr");
    tr.className = "episode-row" + (e.detail ? " has-detail" : "") + (e.id === state.episode ? " selected" : "");
    tr.dataset.episode = e.id;
    const cells = [e.index, e.id].concat(R.columns.map(m => fmt(e.metrics[m], m)));
    for (const c of cells) { const td = document.createElement("td"); td.textContent = c; tr.appendChild(td); }
    tr.addEventListener("click", () => { state.episode = e.id; state.step = 0; writeHash(); buildTable(); showEpisode(); });
    body.appendChild(tr);
  }
}

function frameFile(d, k) { return d.frame_dir + "/step_" + String(k).padStart(3, "0") + ".jpg"; }

function showEpisode() {
  const e = R.episodes.find(x => x.id === state.episode);
  const pane = $("detail");
  if (!e) { pane.hidden = true; return; }
  pane.hidden = false;
  $("episode-title").textContent = "Episode " + e.id + (e.called_stop ? " (stopped)" : " (step limit)");
  const m = $("metrics").tBodies[0];
  m.innerHTML = "";
  for (const k of Object.keys(e.metrics)) {
    const tr = document.createElement("tr");
    tr.innerHTML = "<td></td><td></td>";
    tr.cells[0].textContent = NAMES[k] || k; tr.cells[1].textContent = fmt(e.metrics[k], k);
    m.appendChild(tr);
  }
  const d = R.details[e.id];
  $("views").hidden = !d;
  $("no-detail").hidden = !!d;
  const words = d ? d.words : e.instruction.split(/\s+/);
  const box = $("instruction");
  box.innerHTML = "";
  words.forEach((w, i) => {
    const s = document.createElement("span");
    s.className = "word"; s.dataset.index = i; s.textContent = w;
    box.appendChild(s); box.appendChild(document.createTextNode(" "));
  });
  if (!d) return;
  $("attention-note").hidden = !!d.attention;
  $("map").src = d.map;
  const svg = $("overlay");
  svg.setAttribute("viewBox", "0 0 " + d.map_size[0] + " " + d.map_picture_height);
  $("step-slider").max = d.frames - 1;
  state.step = Math.min(state.step, d.frames - 1);
  showStep();
}

function showStep() {
  const d = R.details[state.episode];
  if (!d) return;
  const k = state.step;
  $("step-slider").value = k;
  $("frame").src = frameFile(d, k);
  const action = k < d.actions.length ? d.actions[k] : "(end)";
  const dist = d.distance[k];
  $("step-text").textContent = "step " + k + " of " + (d.frames - 1) + ": next action " + action +
    (dist === null || dist === undefined ? "" : ", " + dist.toFixed(2) + " m to the goal");
  // the agent at this step on the map
  const p = d.path[Math.min(k, d.path.length - 1)];
  const h = d.headings.length ? d.headings[Math.min(k, d.headings.length - 1)] : 0;
  const len = 0.06 * Math.max(d.map_size[0], d.map_size[1]);
  // heading 0 looks along -Z, i.e. up the map; positive turns left
  const tip = [p[0] - len * Math.sin(h), p[1] - len * Math.cos(h)];
  const agent = $("agent");
  agent.setAttribute("cx", p[0]); agent.setAttribute("cy", p[1]);
  agent.setAttribute("r", 0.012 * Math.max(d.map_size[0], d.map_size[1]));
  const arrow = $("agent-heading");
  arrow.setAttribute("x1", p[0]); arrow.setAttribute("y1", p[1]);
  arrow.setAttribute("x2", tip[0]); arrow.setAttribute("y2", tip[1]);
  arrow.setAttribute("stroke-width", 0.006 * Math.max(d.map_size[0], d.map_size[1]));
  // attention that chose this step's action, shaded from its min to its max
  const spans = $("instruction").querySelectorAll(".word");
  const row = d.attention && k < d.attention.length ? d.attention[k] : null;
  let lo = Infinity, hi = -Infinity, top = -1;
  if (row) row.forEach((w, i) => { if (w < lo) lo = w; if (w > hi) { hi = w; top = i; } });
  spans.forEach((s, i) => {
    const w = row ? row[i] : null;
    const a = w === null || w === undefined ? 0 : hi > lo ? (w - lo) / (hi - lo) : 1;
    s.style.background = a > 0 ? "rgba(255, 140, 0, " + (0.85 * a).toFixed(3) + ")" : "";
    s.dataset.weight = w === null || w === undefined ? "" : w.toFixed(4);
    s.classList.toggle("top-word", i === top);
  });
  writeHash();
}

let timer = null;
function play() {
  if (timer) { clearInterval(timer); timer = null; $("play").textContent = "play"; return; }
  $("play").textContent = "pause";
  timer = setInterval(() => {
    const d = R.details[state.episode];
    if (!d || state.step >= d.frames - 1) { play(); return; }
    state.step++; showStep();
  }, 400);
}

function init() {
  readHash();
  summary();
  buildTable();
  if (state.episode === null) {
    const first = R.episodes.find(e => e.detail);
    if (first) state.episode = first.id;
  }
  showEpisode();
  $("step-slider").addEventListener("input", ev => { state.step = Number(ev.target.value); showStep(); });
  $("prev").addEventListener("click", () => { state.step = Math.max(0, state.step - 1); showStep(); });
  $("next").addEventListener("click", () => {
    const d = R.details[state.episode]; if (d) { state.step = Math.min(d.frames - 1, state.step + 1); showStep(); }
  });
  $("play").addEventListener("click", play);
  document.addEventListener("keydown", ev => {
    if (ev.key === "ArrowRight") $("next").click();
    if (ev.key === "ArrowLeft") $("prev").click();
  });
  window.addEventListener("hashchange", () => { readHash(); buildTable(); showEpisode(); });
  document.body.dataset.ready = "1";
}
init();
)JS";

constexpr std::string_view kBody = R"HTML(
<header><h1 id="title"></h1><div id="summary"></div></header>
<main>
  <div id="list"><table id="episodes"><thead><tr></tr></thead><tbody></tbody></table></div>
  <section id="detail" hidden>
    <h2 id="episode-title"></h2>
    <div id="instruction"></div>
    <p id="attention-note" class="note" hidden>This agent has no attention over the instruction.</p>
    <p id="no-detail" class="note" hidden>No frames were recorded for this episode (eval --report-episodes sets how many episodes get them).</p>
    <div id="views">
      <div id="controls">
        <button id="prev">&larr;</button><button id="play">play</button><button id="next">&rarr;</button>
        <input id="step-slider" type="range" min="0" max="0" value="0">
        <span id="step-text"></span>
      </div>
      <div class="views">
        <div><img id="frame" alt="RGB | depth at this step"></div>
        <div id="map-box"><img id="map" alt="top-down map">
          <svg id="overlay"><line id="agent-heading" stroke="black"/><circle id="agent" fill="#f58214" stroke="black"/></svg>
        </div>
      </div>
    </div>
    <table id="metrics"><tbody></tbody></table>
  </section>
</main>
)HTML";

std::string page(std::string_view title, std::string_view style,
                 std::string_view body, std::string_view script) {
  std::string html =
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta "
      "charset=\"utf-8\">\n<title>";
  html += title;
  html += "</title>\n<style>";
  html += style;
  html += "</style>\n</head>\n<body>";
  html += body;
  html += "<script>";
  html += script;
  html += "</script>\n</body>\n</html>\n";
  return html;
}

std::string escapeHtml(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace

std::string scriptSafeJson(const nlohmann::json& value) {
  const std::string text =
      value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    // "<" only occurs inside strings, where "\u003c" means the same
    if (text[i] == '<') {
      out += "\\u003c";
    } else {
      out += text[i];
    }
  }
  return out;
}

std::string reportPageHtml(const nlohmann::json& data) {
  std::string script = "const REPORT = " + scriptSafeJson(data) + ";\n";
  script += kScript;
  return page(escapeHtml(data.value("title", std::string("evaluation report"))),
              kStyle, kBody, script);
}

std::string reportIndexHtml(const nlohmann::json& reports) {
  constexpr std::string_view kIndexScript = R"JS(
"use strict";
const table = document.getElementById("reports");
const metrics = ["success", "spl", "ndtw", "distance_to_goal"];
for (const r of REPORTS) {
  const tr = document.createElement("tr");
  const a = document.createElement("a");
  a.href = r.href; a.textContent = r.title;
  const first = document.createElement("td"); first.appendChild(a); tr.appendChild(first);
  const n = document.createElement("td"); n.textContent = r.episodes_scored + " / " + r.episodes; tr.appendChild(n);
  for (const m of metrics) {
    const td = document.createElement("td");
    const v = r.summary ? r.summary[m] : null;
    td.textContent = v === null || v === undefined ? "-" : v.toFixed(3);
    tr.appendChild(td);
  }
  table.tBodies[0].appendChild(tr);
}
document.body.dataset.ready = "1";
)JS";
  constexpr std::string_view kIndexBody = R"HTML(
<header><h1>Evaluation reports</h1></header>
<main><table id="reports"><thead><tr><th>evaluation</th><th>episodes scored</th><th>SR</th><th>SPL</th><th>nDTW</th><th>NE (m)</th></tr></thead><tbody></tbody></table></main>
)HTML";
  std::string script = "const REPORTS = " + scriptSafeJson(reports) + ";\n";
  script += kIndexScript;
  return page("Evaluation reports", kStyle, kIndexBody, script);
}

}  // namespace vln::viz
