//! `view(&Model, &mut Frame, PreviewArea)`: the screen layout. Left the polar editor with the
//! control-point table and the light's numbers, right the preview pane, then a status line and
//! a hint bar; the help overlay and the quit prompt on top.

use ratatui::Frame;
use ratatui::layout::{Alignment, Constraint, Layout, Position, Rect};
use ratatui::style::{Color, Modifier, Style, Stylize};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Cell, Clear, Paragraph, Row, Table, TableState, Wrap};

use crate::error::printable;
use crate::session::{ExposureChoice, LightStatus};
use crate::tui::keys::{self, ModeKind};
use crate::tui::luminaires::{self, lid_info};
use crate::tui::model::{LightEdit, Mode, Model};
use crate::tui::panel::{self, draw_panel};
use crate::tui::polar::{self, PolarDiagram};

/// Smallest terminal (columns, rows) the layout needs.
pub const MIN_SIZE: (u16, u16) = (80, 24);

/// Editor widths from which the points table has its wide columns.
const WIDE_EDITOR: u16 = 48;
/// The points table's width (border included), wide and narrow.
const WIDE_TABLE: u16 = 22;
const NARROW_TABLE: u16 = 18;
/// The light panel's label column.
const LABEL_WIDTH: usize = 8;

/// Rows the light panel needs for its eight values and its border.
const LIGHT_PANEL_ROWS: u16 = 10;
/// The polar diagram never gets fewer rows than this (when the terminal has them).
const MIN_POLAR_ROWS: u16 = 8;

/// What to draw in the preview pane's inner rectangle.
pub enum PreviewArea<'a> {
    /// A placeholder naming the preview's pixel size (tests, and before the first frame).
    Placeholder,
    /// The app's drawing (the rendered image), given the frame and the inner rectangle.
    Draw(&'a mut dyn FnMut(&mut Frame<'_>, Rect)),
}

/// The screen's regions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Areas {
    polar: Rect,
    table: Rect,
    numbers: Rect,
    preview: Rect,
    panel: Rect,
    status: Rect,
    hints: Rect,
}

/// True when `area` is at least [`MIN_SIZE`].
pub fn fits(area: Rect) -> bool {
    area.width >= MIN_SIZE.0 && area.height >= MIN_SIZE.1
}

fn areas(area: Rect) -> Areas {
    let [main, status, hints] =
        Layout::vertical([Constraint::Min(0), Constraint::Length(1), Constraint::Length(1)]).areas(area);
    let editor_width = (area.width * 2 / 5).clamp(40, 64);
    let [editor, right] =
        Layout::horizontal([Constraint::Length(editor_width), Constraint::Min(0)]).areas(main);
    let [preview, panel] = Layout::vertical([
        Constraint::Min(0),
        Constraint::Length(panel::panel_rows(area.height)),
    ])
    .areas(right);
    // A square diagram: Braille cells are about twice as tall as wide. On short terminals the
    // diagram gives up rows first (docs/DECISIONS.md "Terminal": the collapse order), so the
    // light panel keeps all its values, position and aim included.
    let polar_height = (editor.width / 2 + 2)
        .min(main.height.saturating_sub(LIGHT_PANEL_ROWS))
        .max(MIN_POLAR_ROWS.min(main.height));
    let [polar, below] =
        Layout::vertical([Constraint::Length(polar_height), Constraint::Min(0)]).areas(editor);
    // Narrow editors (80 columns) take the points table's slimmer layout, so the light panel
    // keeps room for a position.
    let table_width = if below.width < WIDE_EDITOR {
        NARROW_TABLE
    } else {
        WIDE_TABLE
    };
    let [table, numbers] =
        Layout::horizontal([Constraint::Length(table_width), Constraint::Min(0)]).areas(below);
    Areas {
        polar,
        table,
        numbers,
        preview,
        panel,
        status,
        hints,
    }
}

/// The preview image's cells for a terminal of `area`: the inside of the preview pane's border
/// (empty when the terminal is too small). The app renders at this size times the cell's
/// pixel size, and mouse clicks map through it ([`cell_to_pixel`]).
pub fn preview_rect(area: Rect) -> Rect {
    if !fits(area) {
        return Rect::default();
    }
    Block::bordered().inner(areas(area).preview)
}

/// The preview pixel under terminal cell `cell`, for an image of `width × height` pixels
/// covering `image_area` (pixel centres as in docs/METHOD.md §1): the cell's centre scaled to pixels,
/// `(col − x0 + ½) / cols · width`, in exact integer arithmetic.
pub fn cell_to_pixel(cell: Position, image_area: Rect, width: u32, height: u32) -> Option<(u32, u32)> {
    let scale = |offset: u16, cells: u16, pixels: u32| {
        let twice = (2 * u64::from(offset) + 1) * u64::from(pixels) / (2 * u64::from(cells));
        u32::try_from(twice).unwrap_or(u32::MAX)
    };
    image_area.contains(cell).then(|| {
        (
            scale(cell.x - image_area.x, image_area.width, width),
            scale(cell.y - image_area.y, image_area.height, height),
        )
    })
}

/// The cell of `image_area` showing preview pixel `pixel` of an image of `width × height`.
pub fn pixel_to_cell(pixel: (u32, u32), image_area: Rect, width: u32, height: u32) -> Option<Position> {
    if width == 0 || height == 0 || image_area.is_empty() {
        return None;
    }
    let col = u64::from(pixel.0) * u64::from(image_area.width) / u64::from(width);
    let row = u64::from(pixel.1) * u64::from(image_area.height) / u64::from(height);
    let x = image_area.x + u16::try_from(col).ok()?.min(image_area.width - 1);
    let y = image_area.y + u16::try_from(row).ok()?.min(image_area.height - 1);
    Some(Position::new(x, y))
}

/// Draws the whole screen.
pub fn view(model: &Model, frame: &mut Frame<'_>, preview: PreviewArea<'_>) {
    let area = frame.area();
    if !fits(area) {
        let text = format!(
            "Terminal too small: {}×{}. Haiko needs at least {}×{}.",
            area.width, area.height, MIN_SIZE.0, MIN_SIZE.1
        );
        let [middle] = Layout::vertical([Constraint::Length(1)])
            .flex(ratatui::layout::Flex::Center)
            .areas(area);
        frame.render_widget(Paragraph::new(text).alignment(Alignment::Center), middle);
        return;
    }
    let areas = areas(area);
    if let Some(light) = model.light() {
        draw_editor(model, light, frame, &areas);
    } else {
        frame.render_widget(
            Paragraph::new("This room has no lights.").block(Block::bordered()),
            areas.polar,
        );
    }
    draw_preview(model, frame, areas.preview, preview);
    draw_panel(model.numbers.as_ref(), frame, areas.panel);
    frame.render_widget(
        Paragraph::new(status_line(model, area.width)).reversed(),
        areas.status,
    );
    frame.render_widget(Paragraph::new(hint_line(model)), areas.hints);
    match &model.mode {
        Mode::Help => draw_help(model, frame, area),
        Mode::ConfirmQuit => draw_quit_prompt(frame, area),
        Mode::SaveConflict { reason, .. } => draw_prompt(
            frame,
            area,
            " the room file changed on disk ",
            vec![
                Line::from(printable(reason).into_owned()),
                Line::from(
                    "Overwrite it with this version, reload it (dropping the edits), or save as another file?",
                ),
                Line::from(keys::hint_line(ModeKind::SaveConflict)).bold(),
            ],
        ),
        Mode::SaveAs { buffer, reason } => {
            let mut lines: Vec<Line<'static>> = reason
                .iter()
                .map(|r| Line::from(printable(r).into_owned()).fg(Color::Yellow))
                .collect();
            lines.push(Line::from(vec![
                Span::from("save as (file name): "),
                Span::from(format!("{}▏", printable(buffer))).bold(),
            ]));
            lines.push(Line::from(keys::hint_line(ModeKind::SaveAs)).bold());
            draw_prompt(frame, area, " save as ", lines);
        }
        Mode::ConfirmSave => draw_save_prompt(model, frame, area),
        _ => {}
    }
}

/// True when `model` shows a dialog over the panes (the help or a prompt, drawn by [`view`]).
/// When one closes, an image protocol that paints pixels over skipped cells (sixel, iTerm2)
/// must send the preview again: the cells under the dialog are skipped, so the terminal would
/// keep the dialog's text over the image (docs/DECISIONS.md "Terminal graphics").
pub fn dialog_shown(model: &Model) -> bool {
    matches!(
        model.mode,
        Mode::Help | Mode::ConfirmQuit | Mode::SaveConflict { .. } | Mode::SaveAs { .. } | Mode::ConfirmSave
    )
}

/// The C-planes' spread of `light`'s file while its curve is still the file's.
fn spread_samples(model: &Model, light: &LightEdit) -> Option<Vec<(f64, f64, f64)>> {
    lid_info(model, light)
        .filter(|i| i.n_planes > 1 && i.curve == light.curve)
        .map(|i| i.spread_samples())
}

/// The polar diagram of the selected light without its block, and the spread it draws.
fn diagram<'a>(
    model: &'a Model,
    light: &'a LightEdit,
    spread: Option<&'a [(f64, f64, f64)]>,
) -> PolarDiagram<'a> {
    let series = model.series.get(model.selected_light).and_then(Option::as_ref);
    PolarDiagram {
        curve: &light.curve,
        series: series.map(|s| s.samples.as_slice()),
        spread,
        selected: model.selected_point,
        block: Block::default(),
    }
}

/// The peak (cd) the selected light's polar diagram shows, if there is a light: the app keeps
/// the diagram's scale following it ([`crate::tui::polar::PolarScale::follow`]).
pub fn polar_peak(model: &Model) -> Option<f64> {
    let light = model.light()?;
    let spread = spread_samples(model, light);
    Some(diagram(model, light, spread.as_deref()).peak_cd())
}

fn draw_editor(model: &Model, light: &LightEdit, frame: &mut Frame<'_>, areas: &Areas) {
    let series = model.series.get(model.selected_light).and_then(Option::as_ref);
    let info = lid_info(model, light);
    let title = match info {
        Some(info) if info.n_planes > 1 => format!(
            " {} · I(γ) cd · C-plane average, asym {:.2} ",
            printable(&light.name),
            info.asymmetry
        ),
        _ => format!(" {} · I(γ) cd · C0–C180 ", printable(&light.name)),
    };
    // The C-planes' spread is drawn while the curve is still the file's.
    let spread = spread_samples(model, light);
    let mut legend = polar::legend_for(light.order, model.polar.style);
    if spread.is_some() {
        legend
            .spans
            .push(Span::styled(" ━ C-planes", Style::new().fg(polar::SPREAD_COLOR)));
    }
    let diagram = PolarDiagram {
        block: Block::bordered().title(title).title_bottom(legend),
        ..diagram(model, light, spread.as_deref())
    };
    diagram.render_with(model.polar, areas.polar, frame.buffer_mut());

    let wide = areas.table.width >= WIDE_TABLE;
    let rows = light.curve.points().map(|(gamma_deg, cd)| {
        let cd = if wide {
            format!("{cd:>9.1}")
        } else {
            format!("{cd:>8.1}")
        };
        Row::new([Cell::from(format!("{gamma_deg:>6.1}")), Cell::from(cd)])
    });
    let (widths, header) = if wide {
        (
            [Constraint::Length(7), Constraint::Length(10)],
            ["   γ °", "     I cd"],
        )
    } else {
        (
            [Constraint::Length(6), Constraint::Length(8)],
            ["   γ °", "    I cd"],
        )
    };
    let table = Table::new(rows, widths)
        .header(Row::new(header).style(Style::new().bold()))
        .row_highlight_style(Style::new().add_modifier(Modifier::REVERSED))
        .highlight_symbol("▶")
        .block(Block::bordered().title(" points "));
    let mut state = TableState::default().with_selected(Some(model.selected_point));
    frame.render_stateful_widget(table, areas.table, &mut state);

    let error = series.map_or("—".to_string(), |s| {
        format!("{:.2} %", 100.0 * s.relative_error)
    });
    let mut lines: Vec<Line> = Vec::new();
    if let Some(info) = info.filter(|i| i.warns()) {
        lines.push(
            Line::from(format!(
                "⚠ asymmetry {:.2} > {}",
                info.asymmetry,
                crate::photometry::ASYMMETRY_WARNING
            ))
            .style(Style::new().fg(Color::Yellow).bold()),
        );
    }
    let group = luminaires::group(model);
    if group.len() > 1 {
        lines
            .push(Line::from(format!("group of {} lights", group.len())).style(Style::new().fg(Color::Cyan)));
    }
    let numbers = [
        ("order", light.order.to_string()),
        ("window", light.window.label().to_string()),
        ("error", error),
        ("flux", format!("{:.0} lm", light.curve.flux_lm())),
        ("peak", format!("{:.0} cd", light.curve.peak_cd())),
        ("dimmer", dimmer_label(light.dimmer)),
        ("pos m", format_vec(light.position.to_array())),
        ("aim", format_vec(light.aim.to_array())),
    ];
    // Vectors to one decimal where two do not fit (80 columns).
    let inner_width = usize::from(areas.numbers.width.saturating_sub(2));
    let numbers = numbers.map(|(name, value)| {
        let vector = name == "pos m" || name == "aim";
        let short = match name {
            "pos m" => format_vec_to(light.position.to_array(), 1),
            _ => format_vec_to(light.aim.to_array(), 1),
        };
        let value = if vector && LABEL_WIDTH + value.chars().count() > inner_width {
            short
        } else {
            value
        };
        (name, value)
    });
    lines.extend(numbers.into_iter().map(|(name, value)| {
        Line::from(vec![
            Span::from(format!("{name:<LABEL_WIDTH$}")).dim(),
            Span::from(value),
        ])
    }));
    frame.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(" light ")),
        areas.numbers,
    );
}

/// The dimmer in percent, with a decimal only when it is not a whole percent (24 %, 24.5 %).
pub fn dimmer_label(dimmer: f64) -> String {
    let percent = 100.0 * dimmer;
    if (percent - percent.round()).abs() < 1e-9 {
        format!("{percent:.0} %")
    } else {
        format!("{percent:.1} %")
    }
}

fn format_vec(v: [f64; 3]) -> String {
    format_vec_to(v, 2)
}

/// `v` with `decimals` decimals, space-separated.
fn format_vec_to(v: [f64; 3], decimals: usize) -> String {
    format!("{:.decimals$} {:.decimals$} {:.decimals$}", v[0], v[1], v[2])
}

/// The preview's title: the view, the display mode and the exposure.
fn preview_title(model: &Model) -> String {
    let view = match (model.plan_view, model.plan_work_plane) {
        (false, _) => "",
        (true, false) => " · plan",
        (true, true) => " · work-plane plan",
    };
    let isolux = if model.isolux { " · isolux" } else { "" };
    let shown = if model.false_colour {
        " · false colour (lx)".to_string()
    } else {
        match model.exposure {
            ExposureChoice::Room { brighter_ev } if brighter_ev != 0.0 => {
                format!(" · exposure {brighter_ev:+.1} EV")
            }
            ExposureChoice::Room { .. } => String::new(),
            ExposureChoice::Ev100(ev100) => format!(" · EV100 {ev100:.1}"),
            ExposureChoice::Auto => " · auto exposure".to_string(),
        }
    };
    format!(" preview{view}{shown}{isolux} ")
}

fn draw_preview(model: &Model, frame: &mut Frame<'_>, pane: Rect, preview: PreviewArea<'_>) {
    let (w, h) = model.preview_px;
    let title = match &model.mode {
        Mode::Aim { cursor } => format!(" aim: cursor at pixel ({}, {}) ", cursor.0, cursor.1),
        Mode::Move { .. } => match model.light() {
            Some(light) => format!(" move: position {} m ", format_vec(light.position.to_array())),
            None => " move ".into(),
        },
        _ => preview_title(model),
    };
    let block = Block::bordered().title(title);
    let inner = block.inner(pane);
    frame.render_widget(block, pane);
    match preview {
        PreviewArea::Placeholder => {
            let [middle] = Layout::vertical([Constraint::Length(1)])
                .flex(ratatui::layout::Flex::Center)
                .areas(inner);
            let text = format!("preview {w}×{h} px");
            frame.render_widget(Paragraph::new(text).alignment(Alignment::Center).dim(), middle);
        }
        PreviewArea::Draw(draw) => draw(frame, inner),
    }
    if let Mode::Aim { cursor } = model.mode
        && let Some(cell) = pixel_to_cell(cursor, inner, w, h)
    {
        frame.render_widget(
            Paragraph::new("╋").style(Style::new().fg(Color::LightRed).bold()),
            Rect::new(cell.x, cell.y, 1, 1),
        );
    }
}

/// The status line's parts, each with its rank: when the line is wider than the terminal the
/// lowest ranks go first — timings (0), the protocol (1), the marked count (2), the light's name
/// (3), bake and update progress (4); the mode, the lux at the cursor and the unsaved mark (5)
/// always stay.
fn status_parts(model: &Model) -> Vec<(u8, String)> {
    let mut parts = Vec::new();
    if let Some(light) = model.light() {
        parts.push((
            3,
            format!(
                "{} ({}/{})",
                printable(&light.name),
                model.selected_light + 1,
                model.lights.len()
            ),
        ));
    }
    if !model.marked.is_empty() {
        parts.push((2, format!("{} marked", model.marked.len())));
    }
    parts.push((5, model.mode.label().to_string()));
    if let Some(t) = model.timings {
        parts.push((
            0,
            format!(
                "relight {:.1} · render {:.1} · encode {:.1} ms",
                t.relight_ms, t.render_ms, t.encode_ms
            ),
        ));
    }
    if !model.protocol.is_empty() {
        parts.push((1, model.protocol.clone()));
    }
    if let Some((done, total)) = model.bake {
        parts.push((4, format!("baking {done}/{total}")));
    }
    let updating: Vec<_> = model
        .lights
        .iter()
        .zip(&model.light_status)
        .filter(|(_, status)| **status == LightStatus::Updating)
        .map(|(light, _)| printable(&light.name).into_owned())
        .collect();
    if let Some(text) = updating_part(&updating, model.lights.len()) {
        parts.push((4, text));
    }
    if let Some(picked) = model.picked {
        parts.push((5, format!("E {:.0} lx", picked.lux)));
    }
    if model.dirty {
        parts.push((5, "● unsaved".into()));
    }
    parts
}

/// Names listed before the rest of the updating lights are counted instead.
const UPDATING_NAMES: usize = 3;

/// The status line's part for the lights still `updating` out of `total` (`None` when none):
/// their names, at most [`UPDATING_NAMES`] of them and then a count, so that a rebuilt engine
/// of a large floor (every light updating) still fits the line instead of being dropped from it.
fn updating_part(updating: &[String], total: usize) -> Option<String> {
    match updating.len() {
        0 => None,
        n if n <= UPDATING_NAMES => Some(format!("updating {}", updating.join(", "))),
        n if n == total => Some(format!("updating all {n} lights")),
        n => Some(format!(
            "updating {} +{} more",
            updating[..UPDATING_NAMES].join(", "),
            n - UPDATING_NAMES
        )),
    }
}

/// The status line for a terminal `width` columns wide ([`status_parts`]).
fn status_line(model: &Model, width: u16) -> Line<'static> {
    let mut parts = status_parts(model);
    let text = |parts: &[(u8, String)]| {
        let joined: Vec<&str> = parts.iter().map(|(_, t)| t.as_str()).collect();
        format!(" {}", joined.join(" │ "))
    };
    for rank in 0..5 {
        if Line::from(text(&parts)).width() <= usize::from(width) {
            break;
        }
        parts.retain(|(r, _)| *r != rank);
    }
    Line::from(text(&parts))
}

fn hint_line(model: &Model) -> Line<'static> {
    if let Some(message) = &model.message {
        return Line::from(format!(" {}", printable(message))).style(Style::new().fg(Color::Yellow));
    }
    let hints = keys::hint_line(model.mode.kind());
    match &model.mode {
        Mode::ValueEntry { buffer } => Line::from(vec![
            Span::from(" intensity (cd): "),
            Span::from(format!("{buffer}▏")).bold(),
            Span::from(format!("   {hints}")).dim(),
        ]),
        Mode::DimmerEntry { buffer } => Line::from(vec![
            Span::from(" dimmer (%): "),
            Span::from(format!("{buffer}▏")).bold(),
            Span::from(format!("   {hints}")).dim(),
        ]),
        Mode::PathEntry { buffer } => Line::from(vec![
            Span::from(" IES/LDT file: "),
            Span::from(format!("{buffer}▏")).bold(),
            Span::from(format!("   {hints}")).dim(),
        ]),
        _ => Line::from(format!(" {hints}")).dim(),
    }
}

/// A centred rectangle of at most `width × height` inside `area`.
fn centred(area: Rect, width: u16, height: u16) -> Rect {
    let [row] = Layout::vertical([Constraint::Length(height.min(area.height))])
        .flex(ratatui::layout::Flex::Center)
        .areas(area);
    let [cell] = Layout::horizontal([Constraint::Length(width.min(area.width))])
        .flex(ratatui::layout::Flex::Center)
        .areas(row);
    cell
}

/// The help text, one line per binding, grouped by mode, from the key table.
fn help_lines() -> Vec<Line<'static>> {
    let mut lines = Vec::new();
    for mode in ModeKind::ALL {
        if !lines.is_empty() {
            lines.push(Line::default());
        }
        lines.push(Line::from(mode.title()).bold());
        for binding in keys::bindings_of(mode) {
            lines.push(Line::from(vec![
                Span::from(format!(" {:<10}", binding.keys_label())).fg(Color::Cyan),
                Span::from(binding.help),
            ]));
        }
    }
    lines
}

/// The help's pages for an inner area of `width × height` cells: as many columns as fit lines
/// of the widest entry, and as many pages as the lines need (one when they all fit).
fn help_pages(width: u16, height: u16) -> Vec<Vec<Vec<Line<'static>>>> {
    let lines = help_lines();
    let widest = lines.iter().map(Line::width).max().unwrap_or(1) as u16;
    let columns = usize::from(((width + HELP_SPACING) / (widest + HELP_SPACING)).max(1));
    let per_column = usize::from(height.max(1));
    lines
        .chunks(columns * per_column)
        .map(|page| page.chunks(per_column).map(<[Line]>::to_vec).collect())
        .collect()
}

/// The help overlay's rectangle and its inside for a terminal of `area`: over the panes only,
/// so the status line and the hint bar stay visible.
fn help_area(area: Rect) -> (Rect, Rect) {
    let panes = Rect {
        height: area.height.saturating_sub(2),
        ..area
    };
    let popup = centred(
        panes,
        panes.width.saturating_sub(4),
        panes.height.saturating_sub(2),
    );
    (popup, Block::bordered().inner(popup))
}

/// How many pages the help has in a terminal of `size` (columns, rows).
pub fn help_page_count((width, height): (u16, u16)) -> usize {
    let (_, inner) = help_area(Rect::new(0, 0, width, height));
    help_pages(inner.width, inner.height).len()
}

/// Columns between two help columns.
const HELP_SPACING: u16 = 2;

/// The help overlay; long help is split into pages (`model.help_page`, PgDn/PgUp).
fn draw_help(model: &Model, frame: &mut Frame<'_>, area: Rect) {
    let (popup, inner) = help_area(area);
    frame.render_widget(Clear, popup);
    let pages = help_pages(inner.width, inner.height);
    let page = model.help_page.min(pages.len().saturating_sub(1));
    let title = if pages.len() > 1 {
        format!(
            " keys · page {}/{} · PgDn/PgUp turn · ? or Esc closes ",
            page + 1,
            pages.len()
        )
    } else {
        " keys · ? or Esc closes ".to_string()
    };
    frame.render_widget(Block::bordered().title(title), popup);
    let Some(columns) = pages.get(page) else {
        return;
    };
    let widest = help_lines().iter().map(Line::width).max().unwrap_or(1) as u16;
    let column_areas = Layout::horizontal(vec![Constraint::Length(widest); columns.len()])
        .spacing(HELP_SPACING)
        .split(inner);
    for (lines, column) in columns.iter().zip(column_areas.iter()) {
        frame.render_widget(Paragraph::new(lines.clone()), *column);
    }
}

/// A bordered prompt titled `title` over the middle of the screen, its lines wrapped.
fn draw_prompt(frame: &mut Frame<'_>, area: Rect, title: &'static str, lines: Vec<Line<'static>>) {
    let width = area.width.saturating_sub(4).min(100);
    let inner_width = usize::from(width.saturating_sub(2).max(1));
    let rows: usize = lines.iter().map(|l| l.width().div_ceil(inner_width).max(1)).sum();
    let height = u16::try_from(rows + 2).unwrap_or(u16::MAX);
    let popup = centred(area, width, height);
    frame.render_widget(Clear, popup);
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(Block::bordered().title(title)),
        popup,
    );
}

fn draw_save_prompt(model: &Model, frame: &mut Frame<'_>, area: Rect) {
    let names = luminaires::edited_names(model).join(", ");
    let text = vec![
        Line::from(format!("Edited curves from photometric files: {names}")),
        Line::from("Enter/w: write each as a new IES file next to the room (lid_file)"),
        Line::from("i: write them inline (lid = …) · Esc: do not save"),
    ];
    let width = text.iter().map(Line::width).max().unwrap_or(40) as u16 + 4;
    let popup = centred(area, width, 5);
    frame.render_widget(Clear, popup);
    frame.render_widget(
        Paragraph::new(text).block(Block::bordered().title(" save ")),
        popup,
    );
}

fn draw_quit_prompt(frame: &mut Frame<'_>, area: Rect) {
    let popup = centred(area, 51, 4);
    frame.render_widget(Clear, popup);
    let text = vec![
        Line::from("There are unsaved changes. Quit without saving?"),
        Line::from(keys::hint_line(ModeKind::ConfirmQuit)).bold(),
    ];
    frame.render_widget(
        Paragraph::new(text)
            .alignment(Alignment::Center)
            .block(Block::bordered().title(" quit ")),
        popup,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_updating_lights_fit_the_status_line() {
        let names = |n: usize| (1..=n).map(|i| format!("d{i}")).collect::<Vec<_>>();
        assert_eq!(updating_part(&[], 6), None);
        assert_eq!(updating_part(&names(1), 6).as_deref(), Some("updating d1"));
        assert_eq!(
            updating_part(&names(3), 6).as_deref(),
            Some("updating d1, d2, d3")
        );
        assert_eq!(
            updating_part(&names(5), 6).as_deref(),
            Some("updating d1, d2, d3 +2 more")
        );
        assert_eq!(
            updating_part(&names(48), 48).as_deref(),
            Some("updating all 48 lights")
        );
    }
}
