//! The station app's views, drawn from [`WallData`]: the wall map, the gamut plot and
//! channel usage, drift charts with the forecast.

use eframe::egui;
use egui::{
    Align2, Color32, FontId, Painter, Pos2, Rect, Sense, Stroke, StrokeKind, Ui, Vec2, pos2, vec2,
};
use lumiwall_calib::verify::Tolerances;
use lumiwall_devices::DisplayInfo;
use lumiwall_profiles::store::{Crossing, DisplayForecast, LampReading};
use lumiwall_profiles::{DisplayKey, Eye};

use super::data::WallData;

/// What colours the wall map.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum MapColour {
    /// The last verification's largest ΔE2000 per display.
    Verification,
    /// The reserve left for the common white (1 − most used channel).
    Reserve,
    /// Change of the native white since the first stored reading.
    Drift,
}

impl MapColour {
    pub(crate) const ALL: [MapColour; 3] = [Self::Verification, Self::Reserve, Self::Drift];

    pub(crate) fn label(self) -> &'static str {
        match self {
            Self::Verification => "verification ΔE2000",
            Self::Reserve => "reserve",
            Self::Drift => "drift",
        }
    }
}

pub(crate) const GOOD: Color32 = Color32::from_rgb(70, 160, 90);
const WARN: Color32 = Color32::from_rgb(220, 170, 50);
const BAD: Color32 = Color32::from_rgb(200, 70, 60);
const NONE: Color32 = Color32::from_gray(110);

/// A value and its colour on the map (`None`: nothing known).
pub(crate) fn status(d: &WallData, key: &DisplayKey, by: MapColour) -> (Option<f64>, Color32) {
    let grade = |v: f64, good: f64, warn: f64| {
        if v <= good {
            GOOD
        } else if v <= warn {
            WARN
        } else {
            BAD
        }
    };
    match by {
        MapColour::Verification => match d.verified(key.display, key.eye) {
            Some(s) => (
                Some(s.max_de),
                grade(s.max_de, Tolerances::default().max_de, 3.0),
            ),
            None => (None, NONE),
        },
        MapColour::Reserve => match d.profile(key.display, key.eye) {
            Some(p) => {
                let r = 1.0
                    - p.channel_usage
                        .iter()
                        .copied()
                        .fold(f64::NEG_INFINITY, f64::max);
                (Some(r), grade(-r, -0.10, -0.03))
            }
            None => (None, NONE),
        },
        MapColour::Drift => match d.drift_pct(key) {
            Some(v) => (Some(v), grade(v.abs(), 2.0, 5.0)),
            None => (None, NONE),
        },
    }
}

/// The wall's tiles, each eye coloured by `by`; a click selects a display. Returns the
/// display clicked.
pub(crate) fn wall_map(
    ui: &mut Ui,
    d: &WallData,
    by: MapColour,
    selected: Option<&DisplayKey>,
) -> Option<DisplayKey> {
    let [cols, rows] = d.tiles;
    if cols == 0 || rows == 0 {
        ui.label("no wall loaded");
        return None;
    }
    let tile = tile_size(ui.available_size(), d);
    let (response, painter) = ui.allocate_painter(
        vec2(tile.x * cols as f32, tile.y * rows as f32),
        Sense::click(),
    );
    let mut clicked = None;
    for info in &d.displays {
        let key = display_key(d, info);
        let rect = eye_rect(response.rect.min, tile, info);
        let (value, colour) = status(d, &key, by);
        painter.rect_filled(rect, 3.0, colour);
        if selected == Some(&key) {
            let white = Stroke::new(3.0, Color32::WHITE);
            painter.rect_stroke(rect, 3.0, white, StrokeKind::Inside);
        }
        let font = FontId::proportional((tile.y / 6.0).clamp(9.0, 14.0));
        let text = tile_label(info, value, by);
        painter.text(
            rect.center(),
            Align2::CENTER_CENTER,
            text,
            font,
            Color32::WHITE,
        );
        let hit = response
            .interact_pointer_pos()
            .is_some_and(|p| rect.contains(p));
        if response.clicked() && hit {
            clicked = Some(key);
        }
    }
    clicked
}

/// One tile's size on screen: the tiles' aspect, as large as `avail` allows.
fn tile_size(avail: Vec2, d: &WallData) -> Vec2 {
    let [cols, rows] = d.tiles;
    let aspect = if d.tile_aspect.is_finite() && d.tile_aspect > 0.0 {
        d.tile_aspect
    } else {
        1.0
    };
    let h = (avail.x / (cols as f32 * aspect))
        .min((avail.y - 24.0) / rows as f32)
        .max(20.0);
    vec2(h * aspect, h)
}

fn display_key(d: &WallData, info: &DisplayInfo) -> DisplayKey {
    DisplayKey {
        wall: d.name.clone(),
        display: info.id.0,
        tile_col: info.tile_col,
        tile_row: info.tile_row,
        eye: info.eye,
    }
}

/// Where a display is drawn: its tile, or the tile's left or right half for an eye.
fn eye_rect(origin: Pos2, tile: Vec2, info: &DisplayInfo) -> Rect {
    let offset = vec2(info.tile_col as f32 * tile.x, info.tile_row as f32 * tile.y);
    let cell = Rect::from_min_size(origin + offset, tile).shrink(2.0);
    match info.eye {
        Eye::Mono => cell,
        Eye::Left => Rect::from_min_max(cell.min, pos2(cell.center().x - 1.0, cell.max.y)),
        Eye::Right => Rect::from_min_max(pos2(cell.center().x + 1.0, cell.min.y), cell.max),
    }
}

/// `#7 L` and the value the map is coloured by.
fn tile_label(info: &DisplayInfo, value: Option<f64>, by: MapColour) -> String {
    let eye = match info.eye {
        Eye::Mono => "",
        Eye::Left => " L",
        Eye::Right => " R",
    };
    match value {
        Some(v) if by == MapColour::Drift => format!("#{}{eye}\n{v:+.1} %", info.id.0),
        Some(v) => format!("#{}{eye}\n{v:.2}", info.id.0),
        None => format!("#{}{eye}\n–", info.id.0),
    }
}

/// Maps CIE xy (0..0.8, 0..0.9) into `rect`.
fn xy_to(rect: Rect, xy: [f64; 2]) -> Pos2 {
    pos2(
        rect.min.x + rect.width() * (xy[0] / 0.8) as f32,
        rect.max.y - rect.height() * (xy[1] / 0.9) as f32,
    )
}

fn xy_of(xyz: [f64; 3]) -> Option<[f64; 2]> {
    let s = xyz[0] + xyz[1] + xyz[2];
    (s > 0.0).then(|| [xyz[0] / s, xyz[1] / s])
}

/// Every display's primaries (thin), the common gamut (thick) and the common white in
/// CIE 1931 xy; the selected display's triangle in white.
pub(crate) fn gamut_plot(ui: &mut Ui, d: &WallData, selected: Option<&DisplayKey>) {
    let side = ui
        .available_width()
        .min(ui.available_height())
        .clamp(200.0, 520.0);
    let (response, painter) = ui.allocate_painter(vec2(side, side), Sense::hover());
    let rect = response.rect.shrink(24.0);
    xy_axes(&painter, rect);
    for p in &d.profiles {
        let pts: Vec<Pos2> = p
            .primaries_xyz_cd_m2
            .iter()
            .filter_map(|c| xy_of(*c))
            .map(|xy| xy_to(rect, xy))
            .collect();
        let (w, c) = if selected == Some(&p.display) {
            (2.0, Color32::WHITE)
        } else {
            (1.0, Color32::from_gray(120))
        };
        painter.add(egui::Shape::closed_line(pts, Stroke::new(w, c)));
    }
    if let Some(p) = d.profiles.first() {
        common_gamut_and_white(&painter, rect, p);
    }
}

/// The frame and ticks of the xy diagram.
fn xy_axes(painter: &Painter, rect: Rect) {
    let grey = Stroke::new(1.0, Color32::GRAY);
    painter.rect_stroke(rect, 0.0, grey, StrokeKind::Inside);
    let small = FontId::proportional(10.0);
    for i in 1..8 {
        let v = f64::from(i) * 0.1;
        let (x, y) = (xy_to(rect, [v, 0.0]), xy_to(rect, [0.0, v]));
        let label = format!("{v:.1}");
        painter.text(
            x + vec2(0.0, 4.0),
            Align2::CENTER_TOP,
            &label,
            small.clone(),
            Color32::GRAY,
        );
        painter.text(
            y - vec2(4.0, 0.0),
            Align2::RIGHT_CENTER,
            &label,
            small.clone(),
            Color32::GRAY,
        );
    }
    let font = FontId::proportional(12.0);
    let x_at = rect.right_bottom() + vec2(0.0, 4.0);
    painter.text(x_at, Align2::RIGHT_TOP, "x", font.clone(), Color32::GRAY);
    let y_at = rect.left_top() - vec2(4.0, 0.0);
    painter.text(y_at, Align2::RIGHT_TOP, "y", font, Color32::GRAY);
}

/// The wall's common gamut (thick) and its white (a dot with its xy).
fn common_gamut_and_white(painter: &Painter, rect: Rect, p: &lumiwall_profiles::DisplayProfile) {
    let common: Vec<Pos2> = p
        .common_primaries_xy
        .iter()
        .map(|xy| xy_to(rect, *xy))
        .collect();
    let blue = Stroke::new(2.5, Color32::from_rgb(90, 170, 255));
    painter.add(egui::Shape::closed_line(common, blue));
    if let Some(w) = xy_of(p.target_white_xyz_cd_m2) {
        let at = xy_to(rect, w);
        painter.circle_filled(at, 4.0, Color32::YELLOW);
        let label = format!("white {:.3}, {:.3}", w[0], w[1]);
        let font = FontId::proportional(11.0);
        painter.text(
            at + vec2(6.0, -6.0),
            Align2::LEFT_BOTTOM,
            label,
            font,
            Color32::YELLOW,
        );
    }
}

/// Each display's channel usage for the common white, with its headroom.
pub(crate) fn usage_bars(ui: &mut Ui, d: &WallData) {
    let n = d.profiles.len().max(1);
    let width = ui.available_width().max(200.0);
    let (response, painter) = ui.allocate_painter(vec2(width, 140.0), Sense::hover());
    let rect = response.rect.shrink2(vec2(4.0, 16.0));
    let slot = rect.width() / n as f32;
    let colours = [
        Color32::from_rgb(220, 80, 70),
        Color32::from_rgb(80, 190, 90),
        Color32::from_rgb(80, 120, 230),
    ];
    for (i, p) in d.profiles.iter().enumerate() {
        let x0 = rect.min.x + slot * i as f32;
        let bar = ((slot - 2.0) / 3.0).max(1.0);
        for (c, colour) in colours.iter().enumerate() {
            let h = rect.height() * p.channel_usage[c].clamp(0.0, 1.0) as f32;
            let r = Rect::from_min_max(
                pos2(x0 + bar * c as f32, rect.max.y - h),
                pos2(x0 + bar * (c as f32 + 1.0), rect.max.y),
            );
            painter.rect_filled(r, 0.0, *colour);
        }
        painter.text(
            pos2(x0 + slot / 2.0, rect.max.y + 2.0),
            Align2::CENTER_TOP,
            format!("#{}", p.display.display),
            FontId::proportional(9.0),
            Color32::GRAY,
        );
        let y = rect.max.y - rect.height() * p.headroom as f32;
        painter.line_segment(
            [pos2(x0, y), pos2(x0 + slot - 1.0, y)],
            Stroke::new(1.0, Color32::WHITE),
        );
    }
    painter.text(
        rect.left_top() - vec2(0.0, 2.0),
        Align2::LEFT_BOTTOM,
        "channel usage for the common white (R, G, B per display; line: headroom)",
        FontId::proportional(11.0),
        Color32::GRAY,
    );
}

fn day(c: &Crossing) -> String {
    c.utc.strftime("%Y-%m-%d").to_string()
}

/// The selected display's native white over its stored readings (relative to the
/// first) and every display's forecast.
pub(crate) fn drift_and_forecast(ui: &mut Ui, d: &WallData, selected: Option<&DisplayKey>) {
    if d.readings.is_empty() {
        ui.label(
            "no history: give the station a profile store (--store) that commissioning and \
             recalibrate record into",
        );
        return;
    }
    match selected.and_then(|k| d.readings.get(k)) {
        Some(rs) if !rs.is_empty() => drift_chart(ui, rs),
        _ => {
            ui.label("select a display on the wall map for its chart");
        }
    }
    egui::ScrollArea::vertical().show(ui, |ui| forecast_table(ui, d));
}

/// A display's native white over its readings, relative to the first.
fn drift_chart(ui: &mut Ui, rs: &[LampReading]) {
    ui.label(format!(
        "native white of {} over {} readings (relative to the first)",
        rs[0].display,
        rs.len()
    ));
    let width = ui.available_width().max(200.0);
    let (response, painter) = ui.allocate_painter(vec2(width, 160.0), Sense::hover());
    let rect = response.rect.shrink(12.0);
    let grey = Stroke::new(1.0, Color32::GRAY);
    painter.rect_stroke(rect, 0.0, grey, StrokeKind::Inside);
    let t0 = rs[0].utc.as_second() as f64;
    let span = (rs[rs.len() - 1].utc.as_second() as f64 - t0).max(1.0);
    let y0 = rs[0].native_white_y_cd_m2().max(1e-9);
    let rel: Vec<f64> = rs.iter().map(|r| r.native_white_y_cd_m2() / y0).collect();
    let (lo, hi) = rel
        .iter()
        .fold((1.0f64, 1.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
    let pad = ((hi - lo) * 0.1).max(0.005);
    let (bottom, range) = (lo - pad, hi - lo + 2.0 * pad);
    let pts: Vec<Pos2> = rs
        .iter()
        .zip(&rel)
        .map(|(r, v)| {
            let x = (r.utc.as_second() as f64 - t0) / span;
            let y = (v - bottom) / range;
            pos2(
                rect.min.x + rect.width() * x as f32,
                rect.max.y - rect.height() * y as f32,
            )
        })
        .collect();
    painter.add(egui::Shape::line(
        pts,
        Stroke::new(1.5, Color32::LIGHT_BLUE),
    ));
    let font = FontId::proportional(10.0);
    let top = format!("{:+.1} %", 100.0 * (bottom + range - 1.0));
    painter.text(
        rect.left_top(),
        Align2::LEFT_TOP,
        top,
        font.clone(),
        Color32::GRAY,
    );
    let low = format!("{:+.1} %", 100.0 * (bottom - 1.0));
    painter.text(
        rect.left_bottom(),
        Align2::LEFT_BOTTOM,
        low,
        font,
        Color32::GRAY,
    );
}

/// Every display's forecast: when it leaves its headroom and when it can no longer
/// show the common white.
fn forecast_table(ui: &mut Ui, d: &WallData) {
    let when = |x: Option<(lumiwall_core::Channel, Crossing)>| {
        x.map_or("beyond horizon".to_string(), |(c, x)| {
            format!("{} ({c:?})", day(&x))
        })
    };
    egui::Grid::new("forecast")
        .striped(true)
        .num_columns(4)
        .show(ui, |ui| {
            for h in [
                "display",
                "readings",
                "leaves headroom",
                "beyond full drive",
            ] {
                ui.strong(h);
            }
            ui.end_row();
            for f in &d.forecast {
                ui.label(f.display().to_string());
                match f {
                    DisplayForecast::Fitted { points, .. } => {
                        ui.label(points.to_string());
                        ui.label(when(f.first_to_leave_headroom()));
                        ui.label(when(f.first_beyond_full_drive()));
                    }
                    DisplayForecast::NotEnoughHistory { points, .. } => {
                        ui.label(points.to_string());
                        ui.label("too little history");
                        ui.label("");
                    }
                }
                ui.end_row();
            }
        });
}

/// The aiming prompt of guided aiming: where to aim, the live readings, and the
/// technician's answers (the keys of the terminal prompt).
pub(super) fn aiming(ui: &mut egui::Ui, job: &super::jobs::Job, prompt: &[String]) {
    use super::jobs::AimAnswer;
    ui.strong("Aim the meter");
    for line in prompt {
        ui.monospace(line.trim_end_matches("; Enter = aimed, r = read again, s = skip, q = stop"));
    }
    ui.horizontal(|ui| {
        for (answer, label) in [
            (AimAnswer::Aimed, "Aimed"),
            (AimAnswer::ReadAgain, "Read again"),
            (AimAnswer::Skip, "Skip display"),
            (AimAnswer::Stop, "Stop here"),
        ] {
            if ui.button(label).clicked() {
                job.answer(answer);
            }
        }
    });
}
