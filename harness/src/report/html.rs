//! The offline HTML report, `index.html` beside a run's outputs: the machine and the date, what
//! was skipped or failed, every table (columns sort on a click), its plots and its image figure.
//! A click on a figure's cell opens a viewer that shows the variant's image, the reference and
//! the error map at 1:1 pixels and flips between them on a click or a key.
//!
//! One self-contained file: the style and the script are inline and small, nothing is fetched
//! (it works from `file://`); the images it shows are the PNGs beside it.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use algorithms::{Error, Result};
use serde::{Deserialize, Serialize};

use super::figure::Figure;
use crate::rows::Row;
use crate::table::Table;

/// One section of the report: a table with its plots and figure, or a line saying why there is
/// none.
#[derive(Serialize, Deserialize, Debug, Clone, Default)]
pub struct Section {
    pub id: String,
    pub title: String,
    pub about: String,
    /// One line: measured when, skipped why, not run yet.
    pub status: String,
    pub columns: Vec<String>,
    /// Parallel to `columns`: true where the value depends on the machine.
    pub hardware: Vec<bool>,
    pub rows: Vec<Vec<String>>,
    pub notes: Vec<String>,
    /// PNG plots, relative to the report's folder.
    pub plots: Vec<String>,
    pub figure: Option<Figure>,
    /// The failed measurements, one line each (`dataset variant: message`).
    pub failed: Vec<String>,
    /// Other files of the section (the table's CSV and Markdown), relative to the folder.
    pub files: Vec<String>,
    /// True when the section was skipped (its status says why).
    pub skipped: bool,
}

impl Section {
    /// Fills the table part from a [`Table`].
    pub fn with_table(mut self, t: &Table) -> Section {
        self.columns = t.columns.clone();
        self.hardware = t.hardware.clone();
        self.rows = t.rows.clone();
        // The plots and the image figure are shown as images; their Markdown links are not
        // repeated.
        self.notes = t
            .notes
            .iter()
            .filter(|n| !n.starts_with("Plot: ") && !n.starts_with("Images: "))
            .cloned()
            .collect();
        self
    }

    /// Keeps the PNGs among `plots`, relative to `dir`.
    pub fn with_plots(mut self, plots: &[PathBuf], dir: &Path) -> Section {
        self.plots = plots
            .iter()
            .filter(|p| p.extension().is_some_and(|e| e == "png"))
            .map(|p| relative(p, dir))
            .collect();
        self
    }

    /// One line per distinct failure among `rows`.
    pub fn with_failures(mut self, rows: &[Row]) -> Section {
        for r in rows.iter().filter(|r| crate::sweep::failed(r)) {
            let line = format!("{} {}: {}", r.dataset, r.variant, r.note);
            if !self.failed.contains(&line) {
                self.failed.push(line);
            }
        }
        self
    }

    /// Saves the section as JSON (a later run rebuilds the report from every saved section).
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string(self)
            .map_err(|e| Error::Internal(format!("{}: {e}", path.display())))?;
        if let Some(d) = path.parent() {
            std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
        }
        algorithms::io::atomic_write(path, |w| std::io::Write::write_all(w, text.as_bytes()))
    }

    /// Reads a saved section; None when there is none (or it is unreadable: an older run).
    pub fn load(path: &Path) -> Option<Section> {
        let text =
            algorithms::io::read_input_string(path, algorithms::io::files::MAX_SETTINGS_BYTES)
                .ok()?;
        serde_json::from_str(&text).ok()
    }
}

/// `p` relative to `dir`, with `/` separators (a URL path).
pub fn relative(p: &Path, dir: &Path) -> String {
    p.strip_prefix(dir)
        .unwrap_or(p)
        .to_string_lossy()
        .replace('\\', "/")
}

/// The whole report.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// The command that made it (`tetbench reproduce --quick`).
    pub title: String,
    /// `name: value` facts about the run: machine, date, threads, GPU, …
    pub facts: Vec<(String, String)>,
    pub sections: Vec<Section>,
}

/// Writes `DIR/index.html` (through a temporary file) and returns its path.
pub fn write(report: &Report, dir: &Path) -> Result<PathBuf> {
    let path = dir.join("index.html");
    let html = render(report);
    algorithms::io::atomic_write(&path, |w| std::io::Write::write_all(w, html.as_bytes()))?;
    Ok(path)
}

/// HTML-escapes text (for element content and attribute values).
fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

/// The little Markdown the tables' notes use: `code`, **bold**, [text](link), ![alt](image).
fn inline_md(s: &str) -> String {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find(['`', '[', '!', '*']) {
        out.push_str(&esc(&rest[..i]));
        let tail = &rest[i..];
        if let Some(code) = tail.strip_prefix('`') {
            if let Some(end) = code.find('`') {
                let _ = write!(out, "<code>{}</code>", esc(&code[..end]));
                rest = &code[end + 1..];
                continue;
            }
        } else if let Some(b) = tail.strip_prefix("**") {
            if let Some(end) = b.find("**") {
                let _ = write!(out, "<b>{}</b>", esc(&b[..end]));
                rest = &b[end + 2..];
                continue;
            }
        } else if let Some((text, link, n)) = md_link(tail.strip_prefix('!').unwrap_or(tail)) {
            let n = n + usize::from(tail.starts_with('!'));
            if tail.starts_with('!') {
                let _ = write!(out, "<img src=\"{}\" alt=\"{}\">", esc(link), esc(text));
            } else {
                let _ = write!(out, "<a href=\"{}\">{}</a>", esc(link), esc(text));
            }
            rest = &tail[n..];
            continue;
        }
        out.push_str(&esc(&tail[..1]));
        rest = &tail[1..];
    }
    out.push_str(&esc(rest));
    out
}

/// `[text](link)` at the start of `s`: text, link and the bytes it takes.
fn md_link(s: &str) -> Option<(&str, &str, usize)> {
    let body = s.strip_prefix('[')?;
    let close = body.find("](")?;
    let text = &body[..close];
    let after = &body[close + 2..];
    let end = after.find(')')?;
    let link = &after[..end];
    if text.contains('[') || link.contains(char::is_whitespace) {
        return None;
    }
    Some((text, link, 1 + close + 2 + end + 1))
}

fn anchor(id: &str) -> String {
    id.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect()
}

/// The page.
pub fn render(r: &Report) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<header>\n<h1>{}</h1>\n<dl class=\"facts\">\n",
        esc(&r.title),
        esc(&r.title)
    );
    for (k, v) in &r.facts {
        let _ = writeln!(h, "<dt>{}</dt><dd>{}</dd>", esc(k), esc(v));
    }
    h.push_str("</dl>\n</header>\n<nav>\n<h2>Contents</h2>\n<ul>\n");
    for s in &r.sections {
        let mark = if s.skipped {
            " <span class=\"skip\">skipped</span>"
        } else if !s.failed.is_empty() {
            " <span class=\"fail\">failed rows</span>"
        } else {
            ""
        };
        let _ = writeln!(
            h,
            "<li><a href=\"#{}\">{}</a>{mark}: {}</li>",
            anchor(&s.id),
            esc(&s.id),
            esc(&s.status)
        );
    }
    h.push_str("</ul>\n");
    let trouble: Vec<&Section> = r
        .sections
        .iter()
        .filter(|s| s.skipped || !s.failed.is_empty())
        .collect();
    if trouble.is_empty() {
        h.push_str("<p>Nothing was skipped and no measurement failed.</p>\n");
    } else {
        h.push_str("<h2>Skipped or failed</h2>\n<ul class=\"trouble\">\n");
        for s in trouble {
            if s.skipped {
                let _ = writeln!(h, "<li><b>{}</b>: {}</li>", esc(&s.id), esc(&s.status));
            }
            for f in &s.failed {
                let _ = writeln!(h, "<li><b>{}</b> failed: {}</li>", esc(&s.id), esc(f));
            }
        }
        h.push_str("</ul>\n");
    }
    h.push_str("</nav>\n<main>\n");
    let mut fig_index = 0;
    for s in &r.sections {
        section(&mut h, s, &mut fig_index);
    }
    h.push_str("</main>\n");
    h.push_str(VIEWER);
    let _ = write!(h, "<script>{SCRIPT}</script>\n</body>\n</html>\n");
    h
}

fn section(h: &mut String, s: &Section, fig_index: &mut usize) {
    let _ = writeln!(
        h,
        "<section id=\"{}\">\n<h2>{}</h2>\n<p class=\"about\">{}</p>\n<p class=\"status\">{}{}</p>",
        anchor(&s.id),
        esc(if s.title.is_empty() { &s.id } else { &s.title }),
        inline_md(&s.about),
        esc(&s.status),
        s.files
            .iter()
            .map(|f| format!(" · <a href=\"{0}\">{0}</a>", esc(f)))
            .collect::<String>()
    );
    if !s.columns.is_empty() {
        h.push_str("<div class=\"scroll\"><table class=\"sortable\">\n<thead><tr>");
        for (i, c) in s.columns.iter().enumerate() {
            let hw = s.hardware.get(i).copied().unwrap_or(false);
            let _ = write!(
                h,
                "<th title=\"sort\">{}{}</th>",
                esc(c),
                if hw { " †" } else { "" }
            );
        }
        h.push_str("</tr></thead>\n<tbody>\n");
        for row in &s.rows {
            h.push_str("<tr>");
            for c in row {
                let class = if c.starts_with("failed") {
                    " class=\"fail\""
                } else {
                    ""
                };
                let _ = write!(h, "<td{class}>{}</td>", esc(c));
            }
            h.push_str("</tr>\n");
        }
        h.push_str("</tbody></table></div>\n");
        if s.hardware.iter().any(|&x| x) {
            h.push_str("<p class=\"small\">† depends on the hardware (times and rates). Click a column's head to sort by it.</p>\n");
        }
    }
    if !s.notes.is_empty() {
        h.push_str("<ul class=\"notes\">\n");
        for n in &s.notes {
            let _ = writeln!(h, "<li>{}</li>", inline_md(n));
        }
        h.push_str("</ul>\n");
    }
    for p in &s.plots {
        let _ = writeln!(
            h,
            "<figure class=\"plot\"><a href=\"{0}\"><img src=\"{0}\" alt=\"{0}\"></a></figure>",
            esc(p)
        );
    }
    if let Some(f) = &s.figure {
        let hits = serde_json::to_string(&f.hits).unwrap_or_else(|_| "[]".into());
        let _ = writeln!(
            h,
            "<figure class=\"images\"><img class=\"fig\" id=\"fig{}\" src=\"{}\" width=\"{}\" height=\"{}\" alt=\"image figure of {}\" data-hits=\"{}\" data-scale=\"{:e} to {:e}\"><figcaption>{}<br>Click a cell to see it at 1:1 (<a href=\"{}\">SVG</a>).</figcaption></figure>",
            fig_index,
            esc(&f.png),
            f.width,
            f.height,
            esc(&s.id),
            esc(&hits),
            f.scale[0],
            f.scale[1],
            esc(&f.caption),
            esc(&f.svg)
        );
        *fig_index += 1;
    }
    h.push_str("</section>\n");
}

const STYLE: &str = "
body{font:15px/1.45 system-ui,sans-serif;margin:0 auto;max-width:1400px;padding:0 16px;color:#111;background:#fff}
h1{font-size:26px}h2{font-size:20px;margin-top:28px}
dl.facts{display:grid;grid-template-columns:max-content 1fr;gap:2px 12px}dt{font-weight:600}dd{margin:0}
.scroll{overflow-x:auto}
table{border-collapse:collapse;font-size:13px;margin:8px 0}
th,td{border:1px solid #ccc;padding:3px 6px;text-align:left;vertical-align:top}
th{background:#f0f0f0;cursor:pointer;user-select:none;position:sticky;top:0}
th[data-dir=asc]::after{content:' \\25B2'}th[data-dir=desc]::after{content:' \\25BC'}
tbody tr:nth-child(even){background:#fafafa}
td.fail,.fail{color:#b41e1e}.skip{color:#8a6d00}
.small,.status,.about{font-size:13px}.status{color:#444}
ul.notes{font-size:13px}ul.notes img{max-width:100%;height:auto}
figure{margin:12px 0}figure.plot img{max-width:100%;height:auto;border:1px solid #ddd}
img.fig{max-width:100%;height:auto;cursor:zoom-in;border:1px solid #ddd}
figcaption{font-size:13px;color:#333}
#viewer{position:fixed;inset:0;background:#141414;color:#eee;display:flex;flex-direction:column;z-index:9}
#viewer[hidden]{display:none}
#vbar{padding:8px 12px;display:flex;gap:8px;align-items:center;flex-wrap:wrap;font-size:14px}
#vbar button{background:#333;color:#eee;border:1px solid #666;padding:4px 10px;cursor:pointer;font:inherit}
#vbar button.on{background:#eee;color:#111}
#vbox{flex:1;overflow:auto;display:flex;align-items:flex-start;justify-content:center;padding:8px}
#vimg{image-rendering:pixelated;cursor:pointer}
";

const VIEWER: &str = "<div id=\"viewer\" hidden>
<div id=\"vbar\"><span id=\"vlabel\"></span>
<button data-m=\"0\">image (1)</button><button data-m=\"1\">reference (2)</button><button data-m=\"2\">error map (3)</button>
<button id=\"vprev\">&larr; cell</button><button id=\"vnext\">cell &rarr;</button><button id=\"vclose\">close (Esc)</button>
<span class=\"small\">click the image or press space to flip</span></div>
<div id=\"vbox\"><img id=\"vimg\" alt=\"\"></div>
</div>
";

const SCRIPT: &str = r#"
"use strict";
function cellKey(td){const t=td.textContent.trim();if(t===""||t.startsWith("\u2014"))return null;const n=Number(t.replace(/[,\u00a0]/g,"").replace(/ ?[KM]$/,""));return isNaN(n)?t.toLowerCase():n;}
document.querySelectorAll("table.sortable th").forEach(function(th,i){th.addEventListener("click",function(){
const tb=th.closest("table").tBodies[0];const dir=th.dataset.dir==="asc"?"desc":"asc";
th.parentNode.querySelectorAll("th").forEach(function(x){delete x.dataset.dir;});th.dataset.dir=dir;
const rows=Array.from(tb.rows);rows.sort(function(a,b){const x=cellKey(a.cells[i]),y=cellKey(b.cells[i]);
if(x===null||y===null)return(x===null)-(y===null);let c;if(typeof x===typeof y)c=x<y?-1:x>y?1:0;else c=typeof x==="number"?-1:1;return dir==="asc"?c:-c;});
rows.forEach(function(r){tb.appendChild(r);});});});
const V={hits:[],i:0,m:0,scale:""},viewer=document.getElementById("viewer"),vimg=document.getElementById("vimg"),vlabel=document.getElementById("vlabel");
const NAMES=["image","reference","error map"];
function srcs(h){return[h.image,h.reference,h.error];}
function show(){const h=V.hits[V.i],s=srcs(h);if(!s[V.m])V.m=0;vimg.src=s[V.m];
vlabel.textContent=h.dataset+" \u00b7 "+h.variant+" \u00b7 "+NAMES[V.m]+(V.m===2?" (log scale "+V.scale+", black: exact)":"")+(h.rmse!==null&&h.rmse!==undefined?" \u00b7 RMSE "+h.rmse.toExponential(2):"");
viewer.querySelectorAll("button[data-m]").forEach(function(b){const m=Number(b.dataset.m);b.classList.toggle("on",m===V.m);b.disabled=!s[m];});}
vimg.addEventListener("load",function(){vimg.style.width=(vimg.naturalWidth/(window.devicePixelRatio||1))+"px";});
function open(img,i,m){const hits=JSON.parse(img.dataset.hits);if(!hits.length)return;V.hits=hits;V.scale=img.dataset.scale;V.i=Math.max(0,Math.min(i,hits.length-1));V.m=m;viewer.hidden=false;show();}
function flip(d){const s=srcs(V.hits[V.i]);for(let k=1;k<=3;k++){const m=(V.m+d*k+3)%3;if(s[m]){V.m=m;break;}}show();}
function step(d){V.i=(V.i+d+V.hits.length)%V.hits.length;show();}
const figs=Array.from(document.querySelectorAll("img.fig"));
figs.forEach(function(img){const hits=JSON.parse(img.dataset.hits);img.addEventListener("click",function(e){
const s=img.naturalWidth/img.clientWidth,x=e.offsetX*s,y=e.offsetY*s;
const k=hits.findIndex(function(h){return x>=h.x&&x<h.x+h.w&&y>=h.y&&y<h.y+h.h;});if(k>=0)open(img,k,0);});});
vimg.addEventListener("click",function(){flip(1);});
viewer.querySelectorAll("button[data-m]").forEach(function(b){b.addEventListener("click",function(){V.m=Number(b.dataset.m);show();});});
document.getElementById("vprev").addEventListener("click",function(){step(-1);});
document.getElementById("vnext").addEventListener("click",function(){step(1);});
document.getElementById("vclose").addEventListener("click",function(){viewer.hidden=true;});
document.addEventListener("keydown",function(e){if(viewer.hidden)return;
if(e.key==="Escape")viewer.hidden=true;else if(e.key===" "||e.key==="f"){flip(1);e.preventDefault();}
else if(e.key==="1"||e.key==="2"||e.key==="3"){V.m=Number(e.key)-1;flip(0);}
else if(e.key==="ArrowRight")step(1);else if(e.key==="ArrowLeft")step(-1);});
const m=/^#view=(\d+)\/(\d+)(?:\/(\d))?$/.exec(location.hash);
if(m&&figs[Number(m[1])])open(figs[Number(m[1])],Number(m[2]),Number(m[3]||0));
"#;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notes_markdown_and_escaping() {
        assert_eq!(
            inline_md("a `x<y` and [t](u.md), ![p](p.png) **b** 2*3"),
            "a <code>x&lt;y</code> and <a href=\"u.md\">t</a>, <img src=\"p.png\" alt=\"p\"> <b>b</b> 2*3"
        );
        assert_eq!(inline_md("[not a link"), "[not a link");
        assert_eq!(esc("<\"&'>"), "&lt;&quot;&amp;&#39;&gt;");
    }

    #[test]
    fn a_tables_plot_and_figure_notes_are_not_repeated() {
        let t = Table {
            notes: vec![
                "Plot: ![p](t-p.png)".into(),
                "Images: ![f](t-images.png)".into(),
                "Kept.".into(),
            ],
            ..Default::default()
        };
        assert_eq!(Section::default().with_table(&t).notes, vec!["Kept."]);
    }

    #[test]
    fn a_report_holds_its_sections_and_no_outside_reference() {
        let s = Section {
            id: "t1".into(),
            title: "Table <1>".into(),
            status: "measured".into(),
            columns: vec!["a".into(), "b".into()],
            hardware: vec![false, true],
            rows: vec![vec!["x".into(), "1.5".into()]],
            failed: vec!["spx cpu-pt: boom".into()],
            ..Default::default()
        };
        let r = Report {
            title: "tetbench reproduce".into(),
            facts: vec![("machine".into(), "m".into())],
            sections: vec![s],
        };
        let html = render(&r);
        assert!(html.contains("<h2>Table &lt;1&gt;</h2>"));
        assert!(html.contains("<th title=\"sort\">b †</th>"));
        assert!(html.contains("spx cpu-pt: boom"));
        assert!(!html.contains("http://") && !html.contains("https://"));
    }
}
