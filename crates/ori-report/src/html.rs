//! The report's pages: static HTML, pictures beside them; the index holds the summary of
//! every asset and the first assets' sections, further pages the others'.

use std::fmt::Write;

use rayon::prelude::*;

use crate::{AssetSummary, ReportSummary, count_colour, error_colour};

/// `name` percent-encoded for a URL fragment (what JavaScript's `decodeURIComponent` reads).
fn url_fragment(name: &str) -> String {
    name.bytes()
        .map(|b| match b {
            b'a'..=b'z' | b'A'..=b'Z' | b'0'..=b'9' | b'-' | b'_' | b'.' | b'~' | b'/' => {
                char::from(b).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A figure as shown, and as sorted (-1 when absent).
fn opt(v: Option<f64>, digits: usize) -> (String, f64) {
    match v {
        Some(v) => (format!("{v:.digits$}"), v),
        None => ("–".into(), -1.0),
    }
}

fn rgb(c: [u8; 3]) -> String {
    format!("rgb({},{},{})", c[0], c[1], c[2])
}

const STYLE: &str = "
body { font: 14px/1.45 system-ui, sans-serif; margin: 24px; color: #222; background: #fafafa; }
h1 { margin: 0 0 4px; } h2 { margin: 32px 0 8px; border-bottom: 1px solid #ccc; }
h3 { margin: 16px 0 6px; font-size: 15px; }
.muted { color: #666; }
.scroll { overflow-x: auto; max-width: 100%; }
table.summary { border-collapse: collapse; background: white; font-variant-numeric: tabular-nums; }
table.summary th, table.summary td { border: 1px solid #ddd; padding: 3px 6px; font-size: 13px; text-align: right; white-space: nowrap; }
table.summary th { background: #eee; cursor: pointer; user-select: none; }
table.summary th:hover { background: #e0e0ff; }
table.summary td:first-child, table.summary th:first-child { text-align: left; }
tr.failed td { background: #fee; }
.grid { display: grid; grid-template-columns: repeat(3, 258px) 1fr; gap: 6px; align-items: start; }
.grid img, .pics img { border: 1px solid #ccc; background: white; image-rendering: pixelated; }
.grid .label { align-self: center; color: #444; }
.pics { display: flex; flex-wrap: wrap; gap: 16px; align-items: flex-start; }
figure { margin: 0; } figcaption { color: #555; font-size: 12px; max-width: 380px; }
.legend span { display: inline-block; width: 18px; height: 12px; margin-right: 2px; vertical-align: middle; border: 1px solid #999; }
.note { background: #fff6d5; border: 1px solid #e6d27a; padding: 6px 10px; display: inline-block; }
.error { background: #fee; border: 1px solid #e99; padding: 6px 10px; display: inline-block; white-space: pre-wrap; }
";

/// Shows the summary table a page of rows at a time from the rows embedded as JSON (every
/// asset, so sorting by a column orders the whole catalogue), and records for tests whether
/// every picture loaded and whether any script error happened.
const SCRIPT: &str = "
var errors = 0;
window.addEventListener('error', function () { errors++; });
(function () {
  var data = document.getElementById('summary-rows');
  var table = document.querySelector('table.summary');
  if (!data || !table) { return; }
  var rows = JSON.parse(data.textContent);
  var body = table.tBodies[0], per = ROWS_SHOWN, first = 0;
  var info = document.getElementById('summary-info');
  function show() {
    body.innerHTML = rows.slice(first, first + per).map(function (r) { return r[0]; }).join('');
    info.textContent = 'rows ' + (rows.length ? first + 1 : 0) + ' to ' +
      Math.min(first + per, rows.length) + ' of ' + rows.length;
  }
  document.getElementById('summary-prev').addEventListener('click', function () {
    first = Math.max(0, first - per); show();
  });
  document.getElementById('summary-next').addEventListener('click', function () {
    if (first + per < rows.length) { first += per; } show();
  });
  table.querySelectorAll('th').forEach(function (th, col) {
    th.addEventListener('click', function () {
      var up = th.dataset.dir !== 'up';
      th.dataset.dir = up ? 'up' : 'down';
      rows.sort(function (a, b) {
        var x = a[col + 1], y = b[col + 1];
        var r = (typeof x === 'number' && typeof y === 'number') ? x - y
          : String(x).localeCompare(String(y));
        return up ? r : -r;
      });
      first = 0; show();
    });
  });
  show();
})();
window.addEventListener('load', function () {
  var imgs = Array.from(document.images);
  var failed = imgs.filter(function (i) { return !i.complete || i.naturalWidth === 0; }).length;
  document.body.dataset.check = 'images=' + imgs.length + ' failed=' + failed + ' errors=' + errors;
});
";

/// The page's script, with its constants.
fn script() -> String {
    SCRIPT.replace("ROWS_SHOWN", &ROWS_SHOWN.to_string())
}

/// Summary rows shown at a time (and written as static rows, for a reader without scripts).
pub const ROWS_SHOWN: usize = 100;

/// The report's first page: the summary of every asset, then the first assets' sections.
pub const INDEX: &str = "index.html";

/// Asset sections per page: a catalogue's pictures are split over pages that open quickly.
pub const ASSETS_PER_PAGE: usize = 50;

/// The file of page `k` (1: the index).
pub fn page_file(k: usize) -> String {
    if k <= 1 {
        INDEX.to_string()
    } else {
        format!("assets-{k}.html")
    }
}

/// Where asset `i`'s section is, from the index (which holds the summary table): an anchor
/// on the index itself for the first page's assets, so following it keeps the table's sort.
fn asset_link(i: usize) -> String {
    match i / ASSETS_PER_PAGE + 1 {
        1 => format!("#asset{i}"),
        k => format!("{}#asset{i}", page_file(k)),
    }
}

/// The code that makes the pages, as their stamps cover it: a page kept from a report made by
/// other code is made again, with no version to bump by hand.
static LAYOUT: std::sync::LazyLock<blake3::Hash> = std::sync::LazyLock::new(|| {
    let mut h = blake3::Hasher::new();
    h.update(include_str!("html.rs").as_bytes());
    h.update(include_str!("pictures.rs").as_bytes());
    h.finalize()
});

/// How many pages a report of `assets` assets has.
pub fn page_count(assets: usize) -> usize {
    assets.div_ceil(ASSETS_PER_PAGE).max(1)
}

/// The assets whose sections page `k` holds.
fn sections(k: usize, assets: usize) -> std::ops::Range<usize> {
    ((k - 1) * ASSETS_PER_PAGE).min(assets)..(k * ASSETS_PER_PAGE).min(assets)
}

/// What page `k` of `count` is made from: its layout and the rows it shows, each given as its
/// summary's JSON (`rows[i]` for asset `i`): every row for the index, which holds the summary
/// table, and its own sections' for the other pages. Equal stamps, equal pages.
pub fn page_stamp(k: usize, count: usize, rows: &[Vec<u8>]) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    h.update(LAYOUT.as_bytes());
    for v in [k, count, rows.len(), ROWS_SHOWN, ASSETS_PER_PAGE] {
        h.update(&(v as u64).to_le_bytes());
    }
    let shown = if k == 1 {
        0..rows.len()
    } else {
        sections(k, rows.len())
    };
    for row in &rows[shown] {
        h.update(&(row.len() as u64).to_le_bytes());
        h.update(row);
    }
    *h.finalize().as_bytes()
}

/// Every page of the report: (file name, HTML), the index first.
#[cfg(test)]
fn pages(report: &ReportSummary) -> Vec<(String, String)> {
    let count = page_count(report.assets.len());
    (1..=count)
        .map(|k| (page_file(k), page(report, k, count)))
        .collect()
}

/// Links to every page of asset sections.
fn page_links(h: &mut String, report: &ReportSummary, current: usize, count: usize) {
    if count <= 1 {
        return;
    }
    h.push_str("<p class=\"pages\">Assets: ");
    for k in 1..=count {
        let first = (k - 1) * ASSETS_PER_PAGE;
        let last = (k * ASSETS_PER_PAGE).min(report.assets.len());
        let label = format!("{}-{last}", first + 1);
        if k == current {
            let _ = write!(h, "<b>{label}</b> ");
        } else {
            let _ = write!(h, "<a href=\"{}\">{label}</a> ", page_file(k));
        }
    }
    h.push_str("</p>\n");
}

/// Page `k` of `count` (1: the index).
pub fn page(report: &ReportSummary, k: usize, count: usize) -> String {
    let mut h = String::new();
    let n = report.assets.len();
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>ORI build report</title><style>{STYLE}</style></head><body>\n\
         <h1>ORI build report</h1>\n"
    );
    let sections = sections(k, n);
    if k == 1 {
        let failed = report.assets.iter().filter(|a| a.status != "ok").count();
        let missed = report.assets.iter().filter(|a| !a.gate.is_empty()).count();
        let _ = writeln!(
            h,
            "<p class=\"muted\">{n} asset(s), {failed} failed, {missed} missed the quality \
             gate. \
             Coverage error: pixels the mesh covers and the ORI misses, % of s0 x s0, at the \
             held-out directions (none of which a stage chose anything at; table: at the 320 \
             directions of the selection table). PLT: the largest on-screen size (pixels) the \
             ORI may be drawn at, from the worst held-out view. p_dif: mean colour error \
             (0-765) over the four comparison views. \
             Click a column to sort.</p>"
        );
        summary_table(&mut h, report);
    } else {
        let _ = writeln!(
            h,
            "<p class=\"muted\"><a href=\"{INDEX}\">Summary of all {n} assets</a>; \
             this page: assets {} to {}.</p>",
            sections.start + 1,
            sections.end
        );
    }
    page_links(&mut h, report, k, count);
    for i in sections {
        asset_section(&mut h, i, &report.assets[i]);
    }
    page_links(&mut h, report, k, count);
    let _ = writeln!(h, "<script>{}</script>\n</body></html>", script());
    h
}

fn summary_table(h: &mut String, report: &ReportSummary) {
    let stages: Vec<String> = {
        let mut s: Vec<String> = Vec::new();
        for a in &report.assets {
            for (stage, _, _) in &a.jobs {
                if !s.contains(stage) {
                    s.push(stage.clone());
                }
            }
        }
        s
    };
    h.push_str("<div class=\"scroll\"><table class=\"summary\"><thead><tr>");
    for c in [
        "asset",
        "faces",
        "impostors",
        "resolution",
        "package bytes",
        "texture bytes",
        "PLT",
        "cov. max %",
        "cov. avg %",
        "impostors / view",
        "table cov. max %",
        "table cov. avg %",
        "table impostors / view",
        "p_dif",
    ] {
        let _ = write!(h, "<th>{c}</th>");
    }
    for s in &stages {
        let _ = write!(h, "<th>{} s</th>", esc(s));
    }
    h.push_str("<th>built</th></tr></thead><tbody>\n");
    // Every row as its HTML and its sort keys (a number where the column has one).
    let rows: Vec<serde_json::Value> = report
        .assets
        .par_iter()
        .enumerate()
        .map(|(i, a)| summary_row(i, a, &stages))
        .collect();
    for row in rows.iter().take(ROWS_SHOWN) {
        h.push_str(row[0].as_str().unwrap_or_default());
    }
    h.push_str("</tbody></table></div>\n");
    let _ = writeln!(
        h,
        "<p class=\"muted\"><button id=\"summary-prev\">previous</button> \
         <span id=\"summary-info\">rows 1 to {} of {}</span> \
         <button id=\"summary-next\">next</button></p>",
        rows.len().min(ROWS_SHOWN),
        rows.len()
    );
    // `</` is escaped so that no string can end the script element.
    let json = serde_json::to_string(&rows)
        .expect("rows serialise")
        .replace("</", "<\\/");
    let _ = writeln!(
        h,
        "<script type=\"application/json\" id=\"summary-rows\">{json}</script>"
    );
}

/// One asset's summary row: `[html, sort key per column...]`.
fn summary_row(i: usize, a: &AssetSummary, stages: &[String]) -> serde_json::Value {
    let mut h = String::new();
    let mut keys = vec![serde_json::Value::from(a.name.clone())];
    let class = if a.status == "ok" && a.gate.is_empty() {
        ""
    } else {
        " class=\"failed\""
    };
    let _ = write!(
        h,
        "<tr{class}><td><a href=\"{}\">{}</a></td>",
        asset_link(i),
        esc(&a.name)
    );
    let int = |v: Option<u64>| opt(v.map(|v| v as f64), 0);
    let cells = [
        int(a.faces),
        int(a.impostors.map(|v| v as u64)),
        int(a.resolution.map(u64::from)),
        int(a.package_bytes),
        int(a.texture_bytes),
        opt(a.plt, 1),
        opt(a.held_out_coverage_error_max_percent, 3),
        opt(a.held_out_coverage_error_avg_percent, 3),
        opt(a.held_out_impostors_per_view, 2),
        opt(a.coverage_error_max_percent, 3),
        opt(a.coverage_error_avg_percent, 3),
        opt(a.impostors_per_view, 2),
        opt(a.p_dif, 1),
    ];
    for (text, v) in cells {
        let _ = write!(h, "<td>{text}</td>");
        keys.push(v.into());
    }
    for s in stages {
        match a.jobs.iter().find(|j| &j.0 == s) {
            Some((_, status, secs)) if status == "ran" => {
                let _ = write!(h, "<td>{secs:.2}</td>");
                keys.push((*secs).into());
            }
            Some((_, status, _)) => {
                let _ = write!(h, "<td class=\"muted\">{}</td>", esc(status));
                keys.push(0.0.into());
            }
            None => {
                h.push_str("<td>–</td>");
                keys.push((-1.0).into());
            }
        }
    }
    let ran = a.jobs.iter().filter(|j| j.1 == "ran").count();
    let built = if a.status != "ok" {
        "failed".to_string()
    } else if !a.gate.is_empty() {
        "missed the gate".to_string()
    } else if ran == 0 {
        "cached".to_string()
    } else {
        format!("rebuilt ({ran} of {} jobs)", a.jobs.len())
    };
    let _ = write!(h, "<td>{built}</td></tr>");
    keys.push(built.into());
    let mut row = vec![serde_json::Value::from(h)];
    row.extend(keys);
    serde_json::Value::Array(row)
}

fn img(h: &mut String, a: &AssetSummary, role: &str, alt: &str) {
    if let Some((_, file)) = a.pictures.iter().find(|p| p.0 == role) {
        let _ = write!(h, "<img src=\"{}\" alt=\"{}\">", esc(file), esc(alt));
    }
}

fn asset_section(h: &mut String, i: usize, a: &AssetSummary) {
    let _ = writeln!(h, "<h2 id=\"asset{i}\">{}</h2>", esc(&a.name));
    if a.package.is_some() {
        let _ = writeln!(
            h,
            "<p><a href=\"{}#{}\">Open in the interactive viewer</a> (orbit, zoom, the \
             reference mesh and the difference, drawn from the package in your browser)</p>",
            crate::viewer::VIEWER,
            url_fragment(&a.name)
        );
    }
    if let Some(e) = &a.error {
        let _ = writeln!(h, "<p class=\"error\">{}</p>", esc(e));
    }
    for missed in &a.gate {
        let _ = writeln!(h, "<p class=\"error\">quality gate: {}</p>", esc(missed));
    }
    for note in &a.notes {
        let _ = writeln!(h, "<p class=\"note\">{}</p>", esc(note));
    }
    if a.has_reference_pictures() {
        h.push_str(
            "<h3>Reference mesh, ORI, difference</h3>\n<p class=\"muted\">Shaded with the \
             evaluator's light. Difference: red = the mesh covers, the ORI misses; blue = the \
             ORI covers, the mesh does not; grey = both.</p>\n<div class=\"grid\">\
             <div class=\"label\">mesh</div><div class=\"label\">ORI (as packaged)</div>\
             <div class=\"label\">difference</div><div></div>",
        );
        for view in ["front", "side", "top", "oblique"] {
            img(h, a, &format!("{view} reference"), &format!("{view}: mesh"));
            img(h, a, &format!("{view} ori"), &format!("{view}: ORI"));
            img(
                h,
                a,
                &format!("{view} error"),
                &format!("{view}: difference"),
            );
            let _ = write!(h, "<div class=\"label\">{view}</div>");
        }
        h.push_str("</div>\n");
    }
    h.push_str("<div class=\"pics\">");
    if let Some((role, _)) = a.pictures.iter().find(|p| p.0.starts_with("worst view")) {
        let role = role.clone();
        h.push_str("<figure>");
        img(h, a, &role, "worst view");
        let _ = write!(
            h,
            "<figcaption>The worst of the 320 directions ({}), missed pixels in red \
             (the paper's Figure 3).</figcaption></figure>",
            esc(role
                .trim_start_matches("worst view ")
                .trim_matches(['(', ')']))
        );
    }
    for view in ["front", "oblique"] {
        let role = format!("sampling {view}");
        if a.pictures.iter().any(|p| p.0 == role) {
            h.push_str("<figure>");
            img(h, a, &role, &role);
            let _ = write!(
                h,
                "<figcaption>Sampling coverage ({view}): each triangle coloured by how many \
                 impostors see it (the paper's Figure 2). <span class=\"legend\">"
            );
            for k in 0..=10u32 {
                let label = if k == 10 {
                    "10+".to_string()
                } else {
                    k.to_string()
                };
                let _ = write!(
                    h,
                    "<span style=\"background:{}\" title=\"{label}\"></span>",
                    rgb(count_colour(k))
                );
            }
            h.push_str("</span> 0 (black) to 10+</figcaption></figure>");
        }
    }
    if !a.views_by_impostor_count.is_empty() {
        h.push_str("<figure>");
        histogram(h, &a.views_by_impostor_count);
        h.push_str(
            "<figcaption>Impostors drawn per view, over the 320 directions.</figcaption></figure>",
        );
    }
    if a.pictures.iter().any(|p| p.0 == "sphere") {
        h.push_str("<figure>");
        img(h, a, "sphere", "coverage error over the sphere");
        let _ = write!(
            h,
            "<figcaption>Coverage error over the sphere of view directions (longitude across, \
             up at the top): <span class=\"legend\"><span style=\"background:{}\"></span>0 \
             <span style=\"background:{}\"></span>goal <span style=\"background:{}\">\
             </span>4 x goal or more</span></figcaption></figure>",
            rgb(error_colour(0.0, 1.0)),
            rgb(error_colour(1.0, 1.0)),
            rgb(error_colour(4.0, 1.0)),
        );
    }
    h.push_str("</div>\n");
    if !a.comparison.is_empty() {
        comparison(h, a);
    }
    if a.pictures.iter().any(|p| p.0.starts_with("maps-")) {
        h.push_str("<h3>Baked relief maps (as packaged)</h3><div class=\"pics\">");
        for (file, caption) in [
            ("maps-albedo.png", "albedo (BC1)"),
            ("maps-normal.png", "normal (BC5; x, y, rebuilt z as RGB)"),
            ("maps-depth.png", "depth (near light, far dark, empty navy)"),
        ] {
            h.push_str("<figure>");
            img(h, a, file, caption);
            let _ = write!(h, "<figcaption>{caption}</figcaption></figure>");
        }
        h.push_str("</div>\n");
    }
}

/// The ORI and its rivals at the ORI's texture bytes (`[compare] enabled`).
fn comparison(h: &mut String, a: &AssetSummary) {
    h.push_str(
        "<h3>Rivals at equal bytes</h3>\n<p class=\"muted\">Every technique baked from the \
         model within the ORI's texture bytes and measured like it at held-out directions \
         (<code>cargo xtask compare</code>).</p>\n<table><thead><tr><th>technique</th>\
         <th>bytes</th><th>coverage error avg %</th><th>max %</th><th>inverse coverage avg \
         %</th><th>p_dif</th><th>drawn per view</th><th>layout</th></tr></thead><tbody>",
    );
    for r in &a.comparison {
        let drawn = r.drawn.name();
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td>\
             <td>{:.1}</td><td>{:.2} {drawn}</td><td>{}</td></tr>",
            r.technique.name(),
            r.bytes,
            r.coverage_error_avg_percent,
            r.coverage_error_max_percent,
            r.inverse_coverage_avg_percent,
            r.p_dif_avg,
            r.drawn_per_view,
            esc(&r.layout)
        );
    }
    h.push_str("</tbody></table>\n");
}

/// Bars for 1, 2, ... impostors per view (index 0, no impostor, only when non-zero).
fn histogram(h: &mut String, counts: &[u64]) {
    let first = if counts.first().copied().unwrap_or(0) > 0 {
        0
    } else {
        1
    };
    let bars = &counts[first.min(counts.len())..];
    let max = bars.iter().copied().max().unwrap_or(1).max(1);
    let (bw, height) = (34.0, 120.0);
    let width = bw * bars.len() as f64 + 10.0;
    let _ = write!(
        h,
        "<svg width=\"{width}\" height=\"{}\" role=\"img\" aria-label=\"histogram\">",
        height + 36.0
    );
    for (k, &c) in bars.iter().enumerate() {
        let bh = height * c as f64 / max as f64;
        let x = 5.0 + bw * k as f64;
        let _ = write!(
            h,
            "<rect x=\"{x}\" y=\"{}\" width=\"{}\" height=\"{bh}\" fill=\"#5b7bd5\"/>\
             <text x=\"{}\" y=\"{}\" font-size=\"11\" text-anchor=\"middle\">{c}</text>\
             <text x=\"{}\" y=\"{}\" font-size=\"12\" text-anchor=\"middle\">{}</text>",
            height - bh + 14.0,
            bw - 6.0,
            x + (bw - 6.0) / 2.0,
            height - bh + 12.0,
            x + (bw - 6.0) / 2.0,
            height + 30.0,
            k + first
        );
    }
    h.push_str("</svg>");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_catalogue_is_split_into_pages_and_every_link_finds_its_asset() {
        let n = 2 * ASSETS_PER_PAGE + 3;
        let report = ReportSummary {
            assets: (0..n)
                .map(|i| AssetSummary {
                    name: format!("f/{i:04}.obj"),
                    status: "ok".into(),
                    ..AssetSummary::default()
                })
                .collect(),
        };
        let pages = pages(&report);
        assert_eq!(pages.len(), 3);
        assert_eq!(pages[0].0, INDEX);
        let index = &pages[0].1;
        // Every row is in the embedded rows, the first ROWS_SHOWN also written out.
        let json = index.split("id=\"summary-rows\">").nth(1).unwrap();
        let json = json.split("</script>").next().unwrap();
        let rows: Vec<serde_json::Value> = serde_json::from_str(json).unwrap();
        assert_eq!(rows.len(), n);
        assert!(n > ROWS_SHOWN);
        for (i, row) in rows.iter().enumerate() {
            let link = asset_link(i);
            let href = format!("href=\"{link}\"");
            assert!(row[0].as_str().unwrap().contains(&href), "{link}");
            assert_eq!(index.contains(&href), i < ROWS_SHOWN, "{link}");
            assert_eq!(row[1], format!("f/{i:04}.obj").as_str());
            let (file, anchor) = link.split_once('#').unwrap();
            let file = if file.is_empty() { INDEX } else { file };
            let holders: Vec<&str> = pages
                .iter()
                .filter(|(_, html)| html.contains(&format!("id=\"{anchor}\"")))
                .map(|(f, _)| f.as_str())
                .collect();
            assert_eq!(holders, [file], "asset {i}");
        }
        // One page, as before, for a small build.
        let small = ReportSummary {
            assets: report.assets[..3].to_vec(),
        };
        let pages = super::pages(&small);
        assert_eq!(pages.len(), 1);
        assert!(!pages[0].1.contains("assets-2.html"));
    }
}
