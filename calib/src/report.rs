//! The commissioning report: markdown and self-contained HTML (inline SVG).
//!
//! Holds an xy chromaticity plot (CIE 1931 spectral locus, every display's gamut, the
//! common gamut and the white), a bar chart of per-display channel usage for the
//! common white (like Kresse 2003, Abb. 27), and tables of primaries, white, black,
//! readings and additivity.

use std::fmt::Write as _;

use lumiwall_core::Channel;
use lumiwall_devices::Xyz;
use lumiwall_profiles::{DisplayProfile, Eye};

use crate::measure::MeasuredDisplay;
use crate::measure::meter_offset::MeterCorrection;
use crate::solve::{SolveOptions, WallSolution};

/// What the report is made of.
#[derive(Debug, Clone, Copy)]
pub struct ReportInputs<'a> {
    /// Wall name.
    pub wall: &'a str,
    /// Every display's measurement, in wall order.
    pub measured: &'a [MeasuredDisplay],
    /// The solve.
    pub solution: &'a WallSolution,
    /// Options of the solve.
    pub solve: &'a SolveOptions,
    /// The meter's xy correction, if one was applied.
    pub meter_correction: Option<&'a MeterCorrection>,
    /// The first display's white re-read at the end of the run, if any.
    pub drift: Option<&'a crate::measure::drift::DriftCheck>,
}

/// The CIE 1931 spectral locus 380–700 nm (xy), from the shared observer table.
pub fn cie1931_locus() -> Vec<(f64, [f64; 2])> {
    lumiwall_core::observer::cie1931()
        .map(|o| o.spectral_locus(380.0, 700.0))
        .unwrap_or_default()
        .into_iter()
        .map(|(wl, xy)| (wl, xy.to_array()))
        .collect()
}

fn xy(x: Xyz) -> [f64; 2] {
    x.xy().unwrap_or([f64::NAN, f64::NAN])
}

fn sub_black(p: &DisplayProfile, c: usize) -> Xyz {
    Xyz::from_array(p.primaries_xyz_cd_m2[c])
}

fn eye_colour(eye: Eye) -> &'static str {
    match eye {
        Eye::Left => "#c0392b",
        Eye::Right => "#1e8449",
        Eye::Mono => "#555555",
    }
}

/// Wavelengths (nm) labelled on the spectral locus.
const LOCUS_LABELS_NM: [f64; 9] = [
    460.0, 480.0, 500.0, 520.0, 540.0, 560.0, 580.0, 600.0, 620.0,
];

/// Placement of the xy diagram in the SVG: x 0..0.8, y 0..0.85.
#[derive(Clone, Copy)]
struct XyPlot {
    x0: f64,
    y0: f64,
    scale: f64,
}

impl XyPlot {
    /// SVG coordinates of a chromaticity.
    fn px(self, p: [f64; 2]) -> (f64, f64) {
        (self.x0 + p[0] * self.scale, self.y0 - p[1] * self.scale)
    }

    /// SVG `points` of a polyline through chromaticities.
    fn points(self, pts: impl IntoIterator<Item = [f64; 2]>) -> String {
        pts.into_iter()
            .map(|p| {
                let (a, b) = self.px(p);
                format!("{a:.1},{b:.1}")
            })
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// Grid lines every 0.1 with their labels, and the axis names.
    fn axes(self, s: &mut String) {
        let (x0, y0, scale) = (self.x0, self.y0, self.scale);
        for i in 0..=8 {
            let v = f64::from(i) * 0.1;
            let (gx, _) = self.px([v, 0.0]);
            let (_, gy) = self.px([0.0, v]);
            let _ = write!(
                s,
                "<line x1=\"{gx:.1}\" y1=\"{:.1}\" x2=\"{gx:.1}\" y2=\"{y0:.1}\" stroke=\"#eee\"/>\
                 <text x=\"{gx:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{v:.1}</text>",
                y0 - 0.85 * scale,
                y0 + 16.0
            );
            let _ = write!(
                s,
                "<line x1=\"{x0:.1}\" y1=\"{gy:.1}\" x2=\"{:.1}\" y2=\"{gy:.1}\" stroke=\"#eee\"/>\
                 <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{v:.1}</text>",
                x0 + 0.8 * scale,
                x0 - 6.0,
                gy + 4.0
            );
        }
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">x</text><text x="14" y="{:.1}">y</text>"#,
            x0 + 0.4 * scale,
            y0 + 34.0,
            y0 - 0.42 * scale
        );
    }

    /// Spectral locus, closed by the purple line, with wavelength labels.
    fn spectral_locus(self, s: &mut String) {
        let locus = cie1931_locus();
        if locus.is_empty() {
            return;
        }
        let _ = write!(
            s,
            r##"<polygon points="{}" fill="none" stroke="#333" stroke-width="1.2"/>"##,
            self.points(locus.iter().map(|(_, p)| *p))
        );
        for (nm, p) in &locus {
            if LOCUS_LABELS_NM.contains(nm) {
                let (a, b) = self.px(*p);
                let _ = write!(
                    s,
                    r##"<text x="{:.1}" y="{:.1}" fill="#777" font-size="10">{nm:.0}</text>"##,
                    a + 4.0,
                    b - 2.0
                );
            }
        }
    }

    /// Every display's gamut, the common gamut and the white.
    fn gamuts(self, s: &mut String, r: &ReportInputs<'_>) {
        for p in &r.solution.profiles {
            let _ = write!(
                s,
                r#"<polygon points="{}" fill="none" stroke="{}" stroke-opacity="0.45" stroke-width="0.8"/>"#,
                self.points(Channel::ALL.map(|c| xy(sub_black(p, c.index())))),
                eye_colour(p.display.eye)
            );
        }
        let _ = write!(
            s,
            r##"<polygon points="{}" fill="#3498db" fill-opacity="0.12" stroke="black" stroke-width="2"/>"##,
            self.points(r.solution.common_primaries_xy)
        );
        let (a, b) = self.px(xy(r.solution.white_xyz_cd_m2));
        let _ = write!(
            s,
            r#"<circle cx="{a:.1}" cy="{b:.1}" r="4" fill="white" stroke="black" stroke-width="1.5"/>"#
        );
    }
}

/// The legend of the xy diagram, with the white's chromaticity.
fn gamut_legend(s: &mut String, white_xy: [f64; 2]) {
    let legend = [
        ("#c0392b", "left-eye displays"),
        ("#1e8449", "right-eye displays"),
        ("#555555", "mono displays"),
        ("black", "common gamut"),
    ];
    for (i, (c, t)) in legend.iter().enumerate() {
        let ly = 20.0 + 18.0 * i as f64;
        let _ = write!(
            s,
            r#"<line x1="330" y1="{ly}" x2="356" y2="{ly}" stroke="{c}" stroke-width="2"/><text x="362" y="{:.1}">{t}</text>"#,
            ly + 4.0
        );
    }
    let _ = write!(
        s,
        r#"<circle cx="343" cy="92" r="4" fill="white" stroke="black" stroke-width="1.5"/><text x="362" y="96">white x {:.4} y {:.4}</text>"#,
        white_xy[0], white_xy[1]
    );
}

/// The xy chromaticity diagram as an SVG element.
pub fn gamut_svg(r: &ReportInputs<'_>) -> String {
    let (w, h) = (580.0, 600.0);
    let plot = XyPlot {
        x0: 50.0,
        y0: 560.0,
        scale: 640.0,
    };
    let mut s = String::new();
    let _ = write!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#
    );
    s.push_str(r#"<rect width="100%" height="100%" fill="white"/>"#);
    plot.axes(&mut s);
    plot.spectral_locus(&mut s);
    plot.gamuts(&mut s, r);
    gamut_legend(&mut s, xy(r.solution.white_xyz_cd_m2));
    s.push_str("</svg>");
    s
}

/// Bar chart of the channel usage of every display for the common white (Kresse
/// Abb. 27) as an SVG element.
pub fn usage_svg(r: &ReportInputs<'_>) -> String {
    let n = r.solution.profiles.len().max(1);
    let bar = 5.0;
    let group = 3.0 * bar + 4.0;
    let (x0, y0, hgt) = (50.0, 240.0, 200.0);
    let w = x0 + group * n as f64 + 20.0;
    let h = 290.0;
    let mut s = String::new();
    let _ = write!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0}" height="{h}" viewBox="0 0 {w:.0} {h}" font-family="sans-serif" font-size="11">"#
    );
    s.push_str(r#"<rect width="100%" height="100%" fill="white"/>"#);
    for i in 0..=4 {
        let v = f64::from(i) * 0.25;
        let y = y0 - v * hgt;
        let _ = write!(
            s,
            "<line x1=\"{x0}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"#ddd\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{:.0} %</text>",
            w - 20.0,
            x0 - 4.0,
            y + 4.0,
            v * 100.0
        );
    }
    let headroom_y = y0 - r.solve.headroom * hgt;
    let _ = write!(
        s,
        r#"<line x1="{x0}" y1="{headroom_y:.1}" x2="{:.1}" y2="{headroom_y:.1}" stroke="black" stroke-dasharray="4 3"/>"#,
        w - 20.0
    );
    let colours = ["#d62728", "#2ca02c", "#1f77b4"];
    for (i, p) in r.solution.profiles.iter().enumerate() {
        let gx = x0 + 2.0 + group * i as f64;
        for (c, colour) in colours.iter().enumerate() {
            let u = p.channel_usage[c].clamp(0.0, 1.5);
            let _ = write!(
                s,
                r#"<rect x="{:.1}" y="{:.1}" width="{bar}" height="{:.1}" fill="{colour}"><title>{} {}: {:.1} %</title></rect>"#,
                gx + bar * c as f64,
                y0 - u * hgt,
                u * hgt,
                p.display.file_stem(),
                Channel::ALL[c].name(),
                p.channel_usage[c] * 100.0
            );
        }
        if n <= 12 || i % 4 == 0 {
            let _ = write!(
                s,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
                gx + 1.5 * bar,
                y0 + 14.0,
                p.display.display
            );
        }
    }
    let _ = write!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">display (dashed: headroom {:.0} %)</text>"#,
        x0 + group * n as f64 / 2.0,
        y0 + 32.0,
        r.solve.headroom * 100.0
    );
    s.push_str(r#"<text x="12" y="20">channel usage for the common white</text></svg>"#);
    s
}

fn fmt_xy(x: Xyz) -> String {
    let p = xy(x);
    format!("{:.4}, {:.4}", p[0], p[1])
}

/// Summary lines and tables in markdown (shared by both formats).
fn tables_markdown(r: &ReportInputs<'_>) -> String {
    let mut s = String::new();
    summary_table(&mut s, r);
    warnings_list(&mut s, r.solution);
    primaries_table(&mut s, r);
    usage_table(&mut s, r);
    s
}

/// The summary table: white, black, common primaries, limiting channel, readings and
/// the meter correction.
fn summary_table(s: &mut String, r: &ReportInputs<'_>) {
    let sol = r.solution;
    let w = sol.white_xyz_cd_m2;
    let _ = writeln!(s, "| quantity | value |\n|---|---|");
    let _ = writeln!(s, "| displays | {} |", sol.profiles.len());
    let _ = writeln!(s, "| white target | {:?} |", r.solve.white);
    let _ = writeln!(
        s,
        "| common white | xy {} , Y {:.2} cd/m² |",
        fmt_xy(w),
        w.y
    );
    let _ = writeln!(
        s,
        "| common black ({:?} mode) | xy {} , Y {:.4} cd/m² |",
        r.solve.black_mode,
        fmt_xy(sol.common_black_xyz_cd_m2),
        sol.common_black_xyz_cd_m2.y
    );
    for (c, p) in Channel::ALL.iter().zip(&sol.common_primaries_xy) {
        let _ = writeln!(
            s,
            "| common {} primary | xy {:.4}, {:.4} |",
            c.name(),
            p[0],
            p[1]
        );
    }
    let ld = sol.limiting.display;
    let limiting = sol
        .profiles
        .get(ld)
        .map(|p| p.display.file_stem())
        .unwrap_or_else(|| ld.to_string());
    let _ = writeln!(
        s,
        "| limiting channel | {limiting} {} at headroom {:.0} % |",
        sol.limiting.channel.name(),
        r.solve.headroom * 100.0
    );
    let total: u32 = r.measured.iter().map(|m| m.measurement.readings).sum();
    let max = r
        .measured
        .iter()
        .map(|m| m.measurement.readings)
        .max()
        .unwrap_or(0);
    let _ = writeln!(
        s,
        "| meter readings | {total} in all, at most {max} per display |"
    );
    if let Some(d) = r.drift {
        let _ = writeln!(s, "| drift over the run | {} |", d.summary());
    }
    if let Some(c) = r.meter_correction {
        let _ = writeln!(
            s,
            "| meter xy correction | {} offset x {:+.4} y {:+.4} from the additivity of {} displays (median additivity error {:.2} % → {:.2} %) |",
            c.instrument,
            c.xy_offset[0],
            c.xy_offset[1],
            c.displays_used,
            c.additivity_before * 100.0,
            c.additivity_after * 100.0
        );
    }
}

/// The solve's warnings as a list (nothing when there are none).
fn warnings_list(s: &mut String, sol: &WallSolution) {
    if !sol.warnings.is_empty() {
        s.push_str("\n**Warnings**\n\n");
        for w in &sol.warnings {
            let _ = writeln!(s, "- {w}");
        }
    }
}

/// Per display: black-subtracted primaries, measured white and black.
fn primaries_table(s: &mut String, r: &ReportInputs<'_>) {
    let sol = r.solution;
    s.push_str("\n## Measured primaries (black subtracted), white and black\n\n");
    s.push_str(
        "| display | eye | R xy | R Y cd/m² | G xy | G Y cd/m² | B xy | B Y cd/m² | W xy (meas.) | W Y cd/m² | black xy | black Y cd/m² |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (p, m) in sol.profiles.iter().zip(r.measured) {
        let mm = &m.measurement;
        let wcell = mm
            .white
            .map(|w| (fmt_xy(w), format!("{:.2}", w.y)))
            .unwrap_or_else(|| ("–".into(), "–".into()));
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2} | {} | {:.2} | {} | {:.2} | {} | {} | {} | {:.4} |",
            p.display.file_stem(),
            p.display.eye,
            fmt_xy(sub_black(p, 0)),
            p.primaries_xyz_cd_m2[0][1],
            fmt_xy(sub_black(p, 1)),
            p.primaries_xyz_cd_m2[1][1],
            fmt_xy(sub_black(p, 2)),
            p.primaries_xyz_cd_m2[2][1],
            wcell.0,
            wcell.1,
            fmt_xy(mm.black),
            mm.black.y
        );
    }
}

/// Per display: channel usage, readings, ramp samples, low-light handling, additivity.
fn usage_table(s: &mut String, r: &ReportInputs<'_>) {
    let sol = r.solution;
    s.push_str("\n## Channel usage, readings and additivity\n\n");
    s.push_str(
        "| display | R usage % | G usage % | B usage % | readings | ramp samples R/G/B | low-light averaged | skipped | retries | additivity error % |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (p, m) in sol.profiles.iter().zip(r.measured) {
        let mm = &m.measurement;
        let add = p
            .measurement
            .additivity_error
            .map(|e| format!("{:.2}", e * 100.0))
            .unwrap_or_else(|| "–".into());
        let _ = writeln!(
            s,
            "| {} | {:.1} | {:.1} | {:.1} | {} | {}/{}/{} | {} | {} | {} | {} |",
            p.display.file_stem(),
            p.channel_usage[0] * 100.0,
            p.channel_usage[1] * 100.0,
            p.channel_usage[2] * 100.0,
            mm.readings,
            mm.ramps[0].len(),
            mm.ramps[1].len(),
            mm.ramps[2].len(),
            m.log.averaged(),
            m.log.skipped(),
            m.log.retries,
            add
        );
    }
}

/// The report as markdown; the plots are referenced as `gamut.svg` and `usage.svg`
/// (written beside it by [`crate::commission`]).
pub fn markdown(r: &ReportInputs<'_>) -> String {
    let mut s = format!("# Commissioning report: {}\n\n", r.wall);
    s.push_str(&tables_markdown(r));
    s.push_str("\n## Plots\n\n![xy chromaticity: every display's gamut, the common gamut and the white](gamut.svg)\n\n");
    s.push_str(
        "![channel usage per display for the common white (cf. Kresse 2003, Abb. 27)](usage.svg)\n",
    );
    s
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Minimal markdown-table → HTML conversion for the report's own tables.
fn md_to_html(md: &str) -> String {
    let mut out = String::new();
    let mut in_table = false;
    let mut header = true;
    for line in md.lines() {
        let t = line.trim();
        if t.starts_with('|') {
            let cells: Vec<&str> = t.trim_matches('|').split('|').map(str::trim).collect();
            if cells.iter().all(|c| c.chars().all(|ch| ch == '-')) {
                continue;
            }
            if !in_table {
                out.push_str("<table>\n");
                in_table = true;
                header = true;
            }
            let tag = if header { "th" } else { "td" };
            out.push_str("<tr>");
            for c in cells {
                let _ = write!(out, "<{tag}>{}</{tag}>", escape(c));
            }
            out.push_str("</tr>\n");
            header = false;
            continue;
        }
        if in_table {
            out.push_str("</table>\n");
            in_table = false;
        }
        if let Some(h) = t.strip_prefix("## ") {
            let _ = writeln!(out, "<h2>{}</h2>", escape(h));
        } else if let Some(item) = t.strip_prefix("- ") {
            let _ = writeln!(out, "<p>• {}</p>", escape(item));
        } else if let Some(b) = t.strip_prefix("**").and_then(|x| x.strip_suffix("**")) {
            let _ = writeln!(out, "<p><b>{}</b></p>", escape(b));
        } else if !t.is_empty() {
            let _ = writeln!(out, "<p>{}</p>", escape(t));
        }
    }
    if in_table {
        out.push_str("</table>\n");
    }
    out
}

/// `page` (a report from [`html`]) with one more section before its end: `md`, its
/// picture lines (`![..](..)`) left out, and `figures` (caption, inline SVG) as one row
/// of plots. This is how a later stage (the camera's) extends the report.
pub fn html_with_section(page: &str, md: &str, figures: &[(&str, &str)]) -> String {
    let text: String = md
        .lines()
        .filter(|l| !l.trim_start().starts_with("!["))
        .map(|l| format!("{l}\n"))
        .collect();
    let mut section = md_to_html(&text);
    if !figures.is_empty() {
        section.push_str("<div class=\"plots\">");
        for (caption, svg) in figures {
            let _ = write!(
                section,
                "<figure>{svg}<figcaption>{}</figcaption></figure>",
                escape(caption)
            );
        }
        section.push_str("</div>");
    }
    match page.rfind("</body>") {
        Some(end) => format!("{}{section}{}", &page[..end], &page[end..]),
        None => format!("{page}{section}"),
    }
}

/// The report as one self-contained HTML page with inline SVG plots.
pub fn html(r: &ReportInputs<'_>) -> String {
    let mut s = String::from("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\">");
    let _ = write!(
        s,
        "<title>Commissioning report: {}</title>\
         <style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse;font-size:12px}}\
         td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}th{{background:#f4f4f4}}\
         .plots{{display:flex;flex-wrap:wrap;gap:2em;align-items:flex-start}}</style></head><body>",
        escape(r.wall)
    );
    let _ = write!(s, "<h1>Commissioning report: {}</h1>", escape(r.wall));
    s.push_str("<div class=\"plots\"><figure>");
    s.push_str(&gamut_svg(r));
    s.push_str("<figcaption>CIE 1931 xy: every display's gamut (thin), the common gamut (bold) and the white</figcaption></figure><figure>");
    s.push_str(&usage_svg(r));
    s.push_str("<figcaption>Channel usage per display for the common white (cf. Kresse 2003, Abb. 27)</figcaption></figure></div>");
    s.push_str(&md_to_html(&tables_markdown(r)));
    s.push_str("</body></html>\n");
    s
}
