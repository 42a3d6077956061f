//! SVG figures in the paper's style (plotters): labelled axes with units,
//! legends, one concept per panel.

use crate::err;
use crate::error::Result;
use crate::identify::HistoryEntry;
use crate::io::BatteryRecord;
use plotters::prelude::*;
use std::path::Path;

/// One curve of a panel.
pub struct Series<'a> {
    /// Legend label.
    pub label: &'a str,
    /// Points (x, y).
    pub points: Vec<(f64, f64)>,
    /// Colour index (0 blue, 1 red, 2 green, 3 black).
    pub color: usize,
}

/// One panel: title, axis labels and curves.
pub struct Panel<'a> {
    /// Caption.
    pub title: &'a str,
    /// x-axis label with unit.
    pub x: &'a str,
    /// y-axis label with unit.
    pub y: &'a str,
    /// Curves.
    pub series: Vec<Series<'a>>,
    /// Logarithmic y axis.
    pub log_y: bool,
}

fn color(i: usize) -> RGBColor {
    [BLUE, RED, RGBColor(0, 140, 0), BLACK][i % 4]
}

fn range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-12);
    (lo - pad, hi + pad)
}

/// Draws panels stacked vertically into one SVG file.
pub fn panels(path: &Path, panels: &[Panel<'_>]) -> Result<()> {
    let e = |e: &dyn std::fmt::Display| err!(Data, "{}: cannot draw ({e})", path.display());
    let height = 320 * panels.len() as u32;
    let root = SVGBackend::new(path, (800, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let areas = root.split_evenly((panels.len(), 1));
    for (area, p) in areas.iter().zip(panels) {
        let (x0, x1) = range(p.series.iter().flat_map(|s| s.points.iter().map(|q| q.0)));
        let ys = p.series.iter().flat_map(|s| s.points.iter().map(|q| q.1));
        let mut b = ChartBuilder::on(area);
        b.caption(p.title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70);
        if p.log_y {
            let (lo, hi) = range(ys.filter(|y| *y > 0.0));
            let lo = lo.max(hi * 1e-12).max(1e-300);
            let mut c = b
                .build_cartesian_2d(x0..x1, (lo..hi).log_scale())
                .map_err(|x| e(&x))?;
            c.configure_mesh()
                .x_desc(p.x)
                .y_desc(p.y)
                .draw()
                .map_err(|x| e(&x))?;
            for s in &p.series {
                let col = color(s.color);
                c.draw_series(LineSeries::new(
                    s.points.iter().copied().filter(|q| q.1 > 0.0),
                    col.stroke_width(2),
                ))
                .map_err(|x| e(&x))?
                .label(s.label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col));
            }
            c.configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|x| e(&x))?;
        } else {
            let (y0, y1) = range(ys);
            let mut c = b.build_cartesian_2d(x0..x1, y0..y1).map_err(|x| e(&x))?;
            c.configure_mesh()
                .x_desc(p.x)
                .y_desc(p.y)
                .draw()
                .map_err(|x| e(&x))?;
            for s in &p.series {
                let col = color(s.color);
                c.draw_series(LineSeries::new(
                    s.points.iter().copied(),
                    col.stroke_width(1),
                ))
                .map_err(|x| e(&x))?
                .label(s.label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col));
            }
            c.configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|x| e(&x))?;
        }
    }
    root.present().map_err(|x| e(&x))?;
    Ok(())
}

fn xy(t: &[f64], v: impl IntoIterator<Item = f64>) -> Vec<(f64, f64)> {
    t.iter().copied().zip(v).collect()
}

/// Figure 7: current and voltage.
pub fn figure7(path: &Path, rec: &BatteryRecord) -> Result<()> {
    panels(
        path,
        &[
            Panel {
                title: "Figure 7a: current (positive when charging)",
                x: "time (s)",
                y: "current (A)",
                series: vec![Series {
                    label: "I",
                    points: xy(&rec.time, rec.current.iter().copied()),
                    color: 0,
                }],
                log_y: false,
            },
            Panel {
                title: "Figure 7b: terminal voltage",
                x: "time (s)",
                y: "voltage (V)",
                series: vec![Series {
                    label: "U_t measured",
                    points: xy(&rec.time, rec.voltage.iter().copied()),
                    color: 1,
                }],
                log_y: false,
            },
        ],
    )
}

/// Figures 8–11 for one identified record.
pub fn battery_figures(
    dir: &Path,
    rec: &BatteryRecord,
    model: &[f64],
    history: &[HistoryEntry],
) -> Result<()> {
    let t = &rec.time;
    panels(
        &dir.join("figure8_voltage_fit.svg"),
        &[Panel {
            title: "Figure 8: measured and estimated voltage",
            x: "time (s)",
            y: "voltage (V)",
            series: vec![
                Series {
                    label: "measured",
                    points: xy(t, rec.voltage.iter().copied()),
                    color: 0,
                },
                Series {
                    label: "identified model",
                    points: xy(t, model.iter().copied()),
                    color: 1,
                },
            ],
            log_y: false,
        }],
    )?;
    panels(
        &dir.join("figure9_voltage_error.svg"),
        &[Panel {
            title: "Figure 9: voltage error (measured − model)",
            x: "time (s)",
            y: "error (V)",
            series: vec![Series {
                label: "error",
                points: xy(t, rec.voltage.iter().zip(model).map(|(a, b)| a - b)),
                color: 0,
            }],
            log_y: false,
        }],
    )?;
    let p_meas: Vec<f64> = rec
        .voltage
        .iter()
        .zip(&rec.current)
        .map(|(v, i)| v * i)
        .collect();
    let p_model: Vec<f64> = model.iter().zip(&rec.current).map(|(v, i)| v * i).collect();
    panels(
        &dir.join("figure10_power.svg"),
        &[
            Panel {
                title: "Figure 10a: measured and estimated power (U_t·I)",
                x: "time (s)",
                y: "power (W)",
                series: vec![
                    Series {
                        label: "measured",
                        points: xy(t, p_meas.iter().copied()),
                        color: 0,
                    },
                    Series {
                        label: "identified model",
                        points: xy(t, p_model.iter().copied()),
                        color: 1,
                    },
                ],
                log_y: false,
            },
            Panel {
                title: "Figure 10b: power error",
                x: "time (s)",
                y: "error (W)",
                series: vec![Series {
                    label: "error",
                    points: xy(t, p_meas.iter().zip(&p_model).map(|(a, b)| a - b)),
                    color: 0,
                }],
                log_y: false,
            },
        ],
    )?;
    panels(
        &dir.join("figure11_cost.svg"),
        &[Panel {
            title: "Figure 11: 2S-OP-GI cost versus k (no truth known for a file)",
            x: "iteration k",
            y: "cost ½Σr² (V²)",
            series: vec![Series {
                label: "cost",
                points: history.iter().map(|h| (f64::from(h.k), h.cost)).collect(),
                color: 0,
            }],
            log_y: true,
        }],
    )
}
