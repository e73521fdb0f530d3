//! The drawing of an image figure: the grid's layout in figure pixels and the page drawn on any
//! plotters backend (the PNG and the SVG are the same drawing).

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::figure::{Column, Content};
use super::pixels::{self, LogScale, Rgb};

/// Sizes and positions of the grid, in figure pixels.
pub(super) struct Layout {
    pub(super) width: u32,
    pub(super) height: u32,
    /// A cell's picture.
    pub(super) cw: u32,
    pub(super) ch: u32,
    pub(super) gap: u32,
    pub(super) pad: u32,
    pub(super) font: u32,
    pub(super) small: u32,
    pub(super) left: u32,
    pub(super) head: u32,
    pub(super) top: u32,
    pub(super) ref_row: u32,
    pub(super) var_row: u32,
    pub(super) bar_top: u32,
    /// Many variants are laid out in panels side by side, each with its own column heads and
    /// first row, `rows` variants high and `panel_w` wide.
    pub(super) panels: u32,
    pub(super) rows: u32,
    pub(super) panel_w: u32,
}

impl Layout {
    pub(super) fn new(
        cw: u32,
        ch: u32,
        columns: &[Column],
        variants: &[&str],
        (title, caption): (&str, &str),
    ) -> Layout {
        let font = (cw.min(ch) / 11).clamp(15, 24);
        let small = (font * 5 / 6).max(13);
        let pad = font * 2 / 3;
        let gap = 4;
        // Variant labels break at '/' (renderer, sort, integrator) and ',' (parameters), one
        // part a line.
        let longest = variants
            .iter()
            .flat_map(|v| label_lines(v))
            .chain(["reference"])
            .map(|s| s.chars().count())
            .max()
            .unwrap_or(8) as u32;
        let left = pad + longest * font * 11 / 20 + pad;
        let panel_w = left + columns.len() as u32 * (cw + pad);
        let ref_row = ch + (small + 8) + pad;
        let var_row = 2 * ch + gap + (small + 8) + pad;
        let head = 2 * (font + 6) + pad / 2;
        // As few panels as keep the figure no more than 1.5 times as high as it is wide.
        let n = variants.len().max(1) as u32;
        let panels = (1..=n)
            .find(|&p| 2 * (head + ref_row + n.div_ceil(p) * var_row) <= 3 * p * panel_w)
            .unwrap_or(n);
        let rows = n.div_ceil(panels);
        let panels = n.div_ceil(rows);
        let width = (panels * panel_w + pad).max(6 * font * 11 / 10 + 500);
        let title_lines = wrap(title, chars_in(width - 2 * pad, font + 2))
            .len()
            .min(2) as u32;
        let caption_lines = wrap(caption, chars_in(width - 2 * pad, small)).len().min(3) as u32;
        let top = pad + title_lines * (font + 8) + caption_lines * (small + 4) + pad;
        let bar_top = top + head + ref_row + rows * var_row + pad;
        Layout {
            width,
            height: bar_top + 4 * (font + 6) + 2 * pad,
            cw,
            ch,
            gap,
            pad,
            font,
            small,
            left,
            head,
            top,
            ref_row,
            var_row,
            bar_top,
            panels,
            rows,
            panel_w,
        }
    }

    /// Left edge of panel `p`.
    fn panel_x(&self, p: u32) -> u32 {
        p * self.panel_w
    }

    /// Left edge of dataset `d`'s column in panel `p`.
    fn column_x(&self, p: u32, d: usize) -> u32 {
        self.panel_x(p) + self.left + d as u32 * (self.cw + self.pad)
    }

    /// Top-left corner of the picture of variant `v` (row), dataset `d` (column).
    pub(super) fn cell(&self, v: usize, d: usize) -> (u32, u32) {
        let (p, r) = (v as u32 / self.rows, v as u32 % self.rows);
        (
            self.column_x(p, d),
            self.top + self.head + self.ref_row + r * self.var_row,
        )
    }
}

/// A variant label's lines: its parts between '/' (renderer, sort, integrator), the first also
/// broken after its ',' (a wrapper's parameters).
fn label_lines(v: &str) -> Vec<&str> {
    let mut parts = v.split('/');
    let mut lines: Vec<&str> = parts.next().unwrap_or("").split_inclusive(',').collect();
    lines.extend(parts);
    lines
}

pub(super) struct Page<'a> {
    pub(super) title: &'a str,
    /// The first row's name and its second line.
    pub(super) first_label: &'a (String, String),
    pub(super) caption: &'a str,
    pub(super) columns: &'a [Column],
    pub(super) variants: &'a [&'a str],
    pub(super) grid: &'a [Vec<Content>],
    pub(super) scale: &'a LogScale,
    pub(super) layout: &'a Layout,
}

type DrawResult = std::result::Result<(), Box<dyn std::error::Error>>;

impl Page<'_> {
    pub(super) fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let l = self.layout;
        root.fill(&WHITE)?;
        let text = |s: &str, x: u32, y: u32, size: u32, pos: Pos| -> DrawResult {
            let style = ("sans-serif", size as f64)
                .into_font()
                .color(&BLACK)
                .pos(pos);
            root.draw_text(s, &style, (x as i32, y as i32))?;
            Ok(())
        };
        let top_left = Pos::new(HPos::Left, VPos::Top);
        let centre = Pos::new(HPos::Center, VPos::Top);
        let mut y = l.pad;
        for line in wrap(self.title, chars_in(l.width - 2 * l.pad, l.font + 2))
            .iter()
            .take(2)
        {
            text(line, l.pad, y, l.font + 2, top_left)?;
            y += l.font + 8;
        }
        for line in wrap(self.caption, chars_in(l.width - 2 * l.pad, l.small))
            .iter()
            .take(3)
        {
            text(line, l.pad, y, l.small, top_left)?;
            y += l.small + 4;
        }
        for p in 0..l.panels {
            self.panel_head(root, p)?;
        }
        // One row per variant: render, error map, RMSE.
        for (v, name) in self.variants.iter().enumerate() {
            let (_, y) = l.cell(v, 0);
            let x_label = l.panel_x(v as u32 / l.rows) + l.pad;
            let parts = label_lines(name);
            let y_label = y + l.ch + l.gap / 2 - (parts.len() as u32 * (l.font + 4)) / 2;
            for (i, p) in parts.iter().enumerate() {
                let size = if i == 0 { l.font } else { l.small };
                text(
                    p,
                    x_label,
                    y_label + i as u32 * (l.font + 4),
                    size,
                    top_left,
                )?;
            }
            for (d, content) in self.grid[v].iter().enumerate() {
                let (x, y) = l.cell(v, d);
                match content {
                    Content::Ok {
                        render,
                        error,
                        rmse,
                        versus,
                    } => {
                        blit(root, render, x, y)?;
                        match error {
                            Some(e) => blit(root, e, x, y + l.ch + l.gap)?,
                            None => empty(
                                root,
                                l,
                                x,
                                y + l.ch + l.gap,
                                l.ch,
                                "no error map",
                                "no yardstick image was compared with it",
                            )?,
                        }
                        let mut r = match rmse {
                            Some(r) => format!("RMSE {r:.2e}"),
                            None => "RMSE —".into(),
                        };
                        if let Some(y) = versus {
                            r.push_str(&format!(" vs {y}"));
                        }
                        text(&r, x + l.cw / 2, y + 2 * l.ch + l.gap + 4, l.small, centre)?;
                    }
                    Content::Empty { what, why } => {
                        empty(root, l, x, y, 2 * l.ch + l.gap, what, why)?;
                    }
                }
            }
        }
        self.colour_bar(root)
    }

    /// A panel's column heads (the dataset and its size) and first row.
    fn panel_head<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, p: u32) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let l = self.layout;
        let text = |s: &str, x: u32, y: u32, size: u32, pos: Pos| -> DrawResult {
            let style = ("sans-serif", size as f64)
                .into_font()
                .color(&BLACK)
                .pos(pos);
            root.draw_text(s, &style, (x as i32, y as i32))?;
            Ok(())
        };
        let top_left = Pos::new(HPos::Left, VPos::Top);
        let centre = Pos::new(HPos::Center, VPos::Top);
        for (d, c) in self.columns.iter().enumerate() {
            let x = l.column_x(p, d) + l.cw / 2;
            text(&c.label, x, l.top, l.font, centre)?;
            text(
                &format!("{} tets", crate::table::count(c.tets)),
                x,
                l.top + l.font + 6,
                l.small,
                centre,
            )?;
        }
        let y0 = l.top + l.head;
        let x_label = l.panel_x(p) + l.pad;
        let (name, second) = self.first_label;
        text(name, x_label, y0 + l.ch / 2 - l.font, l.font, top_left)?;
        text(second, x_label, y0 + l.ch / 2 + 6, l.small, top_left)?;
        for (d, c) in self.columns.iter().enumerate() {
            let x = l.column_x(p, d);
            match &c.reference {
                Some(r) => blit(root, r, x, y0)?,
                None => empty(
                    root,
                    l,
                    x,
                    y0,
                    l.ch,
                    "no reference",
                    "this sweep compared no image",
                )?,
            }
        }
        Ok(())
    }

    /// The shared colour bar: the ramp, a tick and label per decade, what it measures.
    fn colour_bar<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let l = self.layout;
        let x0 = l.left.min(l.pad + 200);
        // Room on the right for the last label, centred on the bar's end.
        let w = (l.width - x0 - l.pad - 2 * l.font).min(8 * l.cw.max(64));
        let h = l.font;
        let y0 = l.bar_top;
        let style = |size: u32, pos: Pos| {
            ("sans-serif", size as f64)
                .into_font()
                .color(&BLACK)
                .pos(pos)
        };
        let what = "per-pixel error against the yardstick (RMS over RGB), log scale; black: exact";
        let lines = wrap(what, chars_in(l.width - x0 - l.pad, l.small));
        for (i, line) in lines.iter().enumerate() {
            root.draw_text(
                line,
                &style(l.small, Pos::new(HPos::Left, VPos::Top)),
                (x0 as i32, (y0 + i as u32 * (l.small + 4)) as i32),
            )?;
        }
        let yb = y0 + lines.len() as u32 * (l.small + 4) + 4;
        let mut ramp = Vec::with_capacity((w * h * 3) as usize);
        for _ in 0..h {
            for i in 0..w {
                ramp.extend(pixels::ramp(i as f64 / (w - 1).max(1) as f64));
            }
        }
        blit(
            root,
            &Rgb {
                width: w,
                height: h,
                data: ramp,
            },
            x0,
            yb,
        )?;
        root.draw(&Rectangle::new(
            [(x0 as i32, yb as i32), ((x0 + w) as i32, (yb + h) as i32)],
            BLACK.stroke_width(1),
        ))?;
        let decades: Vec<i32> = self.scale.decades().collect();
        let n = decades.len().max(2) as u32 - 1;
        for (i, e) in decades.iter().enumerate() {
            let x = x0 + i as u32 * (w - 1) / n;
            root.draw(&PathElement::new(
                vec![(x as i32, (yb + h) as i32), (x as i32, (yb + h + 6) as i32)],
                BLACK.stroke_width(1),
            ))?;
            let label = if i == 0 {
                format!("≤ 1e{e}")
            } else {
                format!("1e{e}")
            };
            root.draw_text(
                &label,
                &style(l.small, Pos::new(HPos::Center, VPos::Top)),
                (x as i32, (yb + h + 8) as i32),
            )?;
        }
        Ok(())
    }
}

fn blit<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, rgb: &Rgb, x: u32, y: u32) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let el = BitMapElement::<_, plotters::backend::RGBPixel>::with_ref(
        (x as i32, y as i32),
        (rgb.width, rgb.height),
        &rgb.data,
    )
    .ok_or("a figure cell's pixels do not match its size")?;
    root.draw(&el)?;
    Ok(())
}

/// A cell without a picture: a grey box saying what and why.
fn empty<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    l: &Layout,
    x: u32,
    y: u32,
    h: u32,
    what: &str,
    why: &str,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (x, y) = (x as i32, y as i32);
    root.draw(&Rectangle::new(
        [(x, y), (x + l.cw as i32, y + h as i32)],
        RGBColor(236, 236, 236).filled(),
    ))?;
    root.draw(&Rectangle::new(
        [(x, y), (x + l.cw as i32, y + h as i32)],
        RGBColor(160, 160, 160).stroke_width(1),
    ))?;
    let colour = if what == "failed" {
        RGBColor(180, 30, 30)
    } else {
        RGBColor(90, 90, 90)
    };
    let font = |size: u32, c: &RGBColor| ("sans-serif", size as f64).into_font().color(c);
    root.draw_text(what, &font(l.font, &colour), (x + 8, y + 8))?;
    let per_line = chars_in(l.cw - 16, l.small);
    let max_lines = ((h - l.font - 24) / (l.small + 4)).max(1) as usize;
    for (i, line) in wrap(why, per_line).iter().take(max_lines).enumerate() {
        root.draw_text(
            line,
            &font(l.small, &BLACK),
            (
                x + 8,
                y + l.font as i32 + 16 + i as i32 * (l.small as i32 + 4),
            ),
        )?;
    }
    Ok(())
}

/// About how many characters of a sans-serif font of `size` pixels fit in `width` pixels.
fn chars_in(width: u32, size: u32) -> u32 {
    (width / (size * 11 / 20).max(1)).max(8)
}

/// Splits `s` into lines of at most `width` characters, at spaces where it can.
fn wrap(s: &str, width: u32) -> Vec<String> {
    let width = width.max(4) as usize;
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in s.split_whitespace() {
        let mut word = word.to_string();
        while word.chars().count() > width {
            if !line.is_empty() {
                lines.push(std::mem::take(&mut line));
            }
            let head: String = word.chars().take(width).collect();
            word = word.chars().skip(width).collect();
            lines.push(head);
        }
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(&word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_keeps_words_and_cuts_long_ones() {
        assert_eq!(wrap("a bb ccc dddd", 6), ["a bb", "ccc", "dddd"]);
        assert_eq!(wrap("abcdefghij", 4), ["abcd", "efgh", "ij"]);
        assert!(wrap("", 5).is_empty());
    }
}
