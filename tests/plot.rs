//! Charts: each kind writes a PNG of the promised size and an SVG holding its texts; bad values
//! and empty charts are drawn without panicking; output is atomic and deterministic.

mod common;

use std::path::{Path, PathBuf};

use common::TempDir;
use softbench::plot::{
    Bar, BarChart, Chart, HEIGHT, LineChart, ReferenceLine, Series, StackedBarChart, WIDTH, draw,
};

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];

fn line_chart() -> LineChart {
    let dts = [1e-5, 3e-5, 1e-4, 3e-4, 1e-3];
    LineChart {
        title: "Energy drift against time step".into(),
        x_label: "time step dt [s]".into(),
        y_label: "relative energy drift [-]".into(),
        x_log: true,
        y_log: true,
        series: vec![
            Series {
                label: "symplectic-euler".into(),
                points: dts.iter().map(|&dt| (dt, 0.5 * dt)).collect(),
                ended: false,
            },
            Series {
                label: "rk4".into(),
                points: dts.iter().map(|&dt| (dt, 1e3 * dt.powi(4))).collect(),
                ended: false,
            },
        ],
    }
}

fn bar_chart() -> BarChart {
    BarChart {
        title: "Largest stable time step".into(),
        y_label: "dt [s]".into(),
        y_log: true,
        bars: vec![
            Bar {
                label: "explicit-euler".into(),
                value: Some(2e-5),
                marker: Some(3e-5),
                note: None,
            },
            Bar {
                label: "linearly-implicit-euler / cholesky".into(),
                value: None,
                marker: None,
                note: Some("no stable dt in range".into()),
            },
        ],
        marker_label: Some("own 2/omega limit".into()),
        reference: Some(ReferenceLine {
            label: "CFL estimate".into(),
            value: 5e-5,
        }),
    }
}

fn stacked_chart() -> StackedBarChart {
    StackedBarChart {
        title: "Where the time goes".into(),
        y_label: "time per step [ms]".into(),
        categories: vec!["newton / cholesky".into(), "newton / cg".into()],
        parts: vec![
            ("assembly".into(), vec![1.0, 1.1]),
            ("factorization".into(), vec![3.0, 0.0]),
            ("solve".into(), vec![0.5, 4.0]),
        ],
        y_log: false,
    }
}

/// Draws `chart` under `name` in `dir`, checks the PNG and that the SVG contains `texts`.
fn check(dir: &Path, name: &str, chart: &Chart, texts: &[&str]) -> [PathBuf; 2] {
    let paths = draw(chart, &dir.join(name)).expect("chart is drawn");
    let [png, svg] = &paths;
    assert_eq!(png.file_name().unwrap(), format!("{name}.png").as_str());
    assert_eq!(svg.file_name().unwrap(), format!("{name}.svg").as_str());

    let bytes = std::fs::read(png).unwrap();
    assert_eq!(bytes[..8], PNG_SIGNATURE, "{} is a PNG", png.display());
    let image =
        image::load_from_memory_with_format(&bytes, image::ImageFormat::Png).expect("PNG decodes");
    assert_eq!((image.width(), image.height()), (WIDTH, HEIGHT));

    let svg_text = std::fs::read_to_string(svg).unwrap();
    assert!(svg_text.starts_with("<svg"), "{} is an SVG", svg.display());
    for t in texts {
        assert!(svg_text.contains(t), "the SVG shows {t:?}");
    }
    no_partial_files(dir);
    paths
}

fn no_partial_files(dir: &Path) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name();
        assert!(
            !name.to_string_lossy().ends_with(".partial"),
            "{name:?} left behind"
        );
    }
}

#[test]
fn line_chart_writes_png_and_svg_with_title_and_legend() {
    let dir = TempDir::new("plot-line");
    let chart = Chart::Line(line_chart());
    check(
        dir.path(),
        "drift",
        &chart,
        &[
            "Energy drift against time step",
            "symplectic-euler",
            "rk4",
            "time step dt [s]",
            "1e-4",
        ],
    );
}

#[test]
fn bar_chart_writes_png_and_svg_with_notes_and_legend() {
    let dir = TempDir::new("plot-bar");
    let chart = Chart::Bar(bar_chart());
    check(
        dir.path(),
        "dt_limit",
        &chart,
        &[
            "Largest stable time step",
            "own 2/omega limit",
            "CFL estimate",
            "explicit-euler",
            "no stable dt in range",
        ],
    );
}

#[test]
fn stacked_chart_writes_png_and_svg_with_parts_in_legend() {
    let dir = TempDir::new("plot-stacked");
    let chart = Chart::Stacked(stacked_chart());
    check(
        dir.path(),
        "timing",
        &chart,
        &[
            "Where the time goes",
            "assembly",
            "factorization",
            "solve",
            "newton / cg",
        ],
    );
}

#[test]
fn stem_with_a_dot_keeps_it() {
    let dir = TempDir::new("plot-stem");
    let [png, svg] = draw(&Chart::Line(line_chart()), &dir.path().join("drift.v2")).unwrap();
    assert!(png.ends_with("drift.v2.png") && png.is_file());
    assert!(svg.ends_with("drift.v2.svg") && svg.is_file());
}

#[test]
fn nan_and_negative_values_on_log_axes_are_skipped() {
    let dir = TempDir::new("plot-bad-values");
    let mut line = line_chart();
    line.series[0].points.extend([
        (f64::NAN, 1.0),
        (1e-3, -1.0),
        (0.0, 1e-3),
        (f64::INFINITY, 2.0),
    ]);
    line.series.push(Series {
        label: "blew-up".into(),
        points: vec![(1e-4, f64::NAN), (-1.0, 1.0)],
        ended: false,
    });
    check(
        dir.path(),
        "line",
        &Chart::Line(line),
        &["blew-up (no data)"],
    );

    let mut bars = bar_chart();
    bars.bars.push(Bar {
        label: "negative".into(),
        value: Some(-3.0),
        marker: Some(f64::NAN),
        note: None,
    });
    bars.reference = Some(ReferenceLine {
        label: "zero".into(),
        value: 0.0,
    });
    check(dir.path(), "bars", &Chart::Bar(bars), &["no data"]);

    let mut stacked = stacked_chart();
    stacked.parts[0].1 = vec![f64::NAN, -2.0];
    stacked.parts[1].1.truncate(1);
    check(
        dir.path(),
        "stacked",
        &Chart::Stacked(stacked),
        &["assembly"],
    );
}

#[test]
fn empty_charts_still_produce_files_saying_no_data() {
    let dir = TempDir::new("plot-empty");
    let charts = [
        Chart::Line(LineChart {
            title: "Empty lines".into(),
            ..Default::default()
        }),
        Chart::Line(LineChart {
            title: "Only NaN".into(),
            y_log: true,
            series: vec![Series {
                label: "nan".into(),
                points: vec![(1.0, f64::NAN)],
                ended: false,
            }],
            ..Default::default()
        }),
        Chart::Bar(BarChart {
            title: "Empty bars".into(),
            ..Default::default()
        }),
        Chart::Stacked(StackedBarChart {
            title: "Empty stack".into(),
            ..Default::default()
        }),
    ];
    for (i, chart) in charts.iter().enumerate() {
        let name = format!("empty{i}");
        check(dir.path(), &name, chart, &[chart.title(), "no data"]);
    }
}

#[test]
fn every_bar_missing_still_draws_the_notes() {
    let dir = TempDir::new("plot-all-missing");
    let chart = BarChart {
        title: "Nothing stable".into(),
        y_label: "dt [s]".into(),
        y_log: true,
        bars: (0..3)
            .map(|i| Bar {
                label: format!("method {i}"),
                note: Some("no stable dt in range".into()),
                ..Default::default()
            })
            .collect(),
        ..Default::default()
    };
    check(dir.path(), "missing", &Chart::Bar(chart), &["method 2"]);
}

#[test]
fn twenty_long_bar_labels_are_drawn() {
    let dir = TempDir::new("plot-many-bars");
    let chart = BarChart {
        title: "Many methods".into(),
        y_label: "time [s]".into(),
        y_log: false,
        bars: (0..20)
            .map(|i| Bar {
                label: format!("linearly-implicit-euler / cholesky {i}"),
                value: Some(1.0 + i as f64),
                marker: Some(2.0 + i as f64),
                note: None,
            })
            .collect(),
        marker_label: Some("limit".into()),
        reference: None,
    };
    check(dir.path(), "many", &Chart::Bar(chart), &["Many methods"]);
}

#[test]
fn drawing_the_same_chart_twice_gives_identical_files() {
    let dir = TempDir::new("plot-deterministic");
    let charts = [
        Chart::Line(line_chart()),
        Chart::Bar(bar_chart()),
        Chart::Stacked(stacked_chart()),
    ];
    for (i, chart) in charts.iter().enumerate() {
        let [png_a, svg_a] = draw(chart, &dir.path().join(format!("a{i}"))).unwrap();
        let [png_b, svg_b] = draw(chart, &dir.path().join(format!("b{i}"))).unwrap();
        assert_eq!(
            std::fs::read(svg_a).unwrap(),
            std::fs::read(svg_b).unwrap(),
            "SVG of chart {i}"
        );
        assert_eq!(
            std::fs::read(png_a).unwrap(),
            std::fs::read(png_b).unwrap(),
            "PNG of chart {i}"
        );
    }
}

#[test]
fn an_unwritable_target_is_an_io_error_naming_the_path() {
    let dir = TempDir::new("plot-io-error");
    let stem = dir.path().join("no-such-folder").join("chart");
    let err = draw(&Chart::Line(line_chart()), &stem).unwrap_err();
    assert!(
        matches!(&err, softbench::plot::PlotError::Io { path, .. } if path.starts_with(dir.path())),
        "{err}"
    );
}

#[test]
fn ten_series_have_ten_distinguishable_styles() {
    use softbench::plot::series_look;
    let looks: Vec<_> = (0..10).map(series_look).collect();
    for i in 0..10 {
        for j in 0..i {
            let (a, b) = (looks[i], looks[j]);
            assert!(
                a.0 != b.0 || a.1 != b.1,
                "series {i} and {j} share colour and marker"
            );
            // Series that share a colour differ in line style too.
            if a.0 == b.0 {
                assert_ne!(a.2, b.2, "series {i} and {j} share colour and dash");
            }
        }
    }
}

/// Every text `chart` draws lies inside the image.
fn assert_text_inside(chart: &Chart) -> Vec<softbench::plot::TextBox> {
    let boxes = softbench::plot::text_boxes(chart).unwrap();
    assert!(!boxes.is_empty());
    for b in &boxes {
        let [l, t, r, bottom] = b.rect;
        assert!(
            l >= 0 && t >= 0 && r <= WIDTH as i32 && bottom <= HEIGHT as i32,
            "{:?} is drawn at {:?}, outside the {WIDTH}x{HEIGHT} image ({})",
            b.text,
            b.rect,
            chart.title()
        );
    }
    boxes
}

/// The phase chart of a stability study: nine long method labels, one with a word longer
/// than the usual rotated line.
fn phase_chart() -> StackedBarChart {
    let categories: Vec<String> = [
        "rk4 model=neo-hookean dt=4.054e-6",
        "linearly-implicit-euler / cholesky model=neo-hookean dt=0.004511",
        "backward-euler / cholesky model=neo-hookean dt=0.03",
        "bdf2 / cholesky model=neo-hookean dt=0.03",
        "rk4 model=stable-neo-hookean dt=4.893e-6",
        "linearly-implicit-euler / cholesky model=stable-neo-hookean dt=0.03",
        "backward-euler / cholesky model=stable-neo-hookean reached_dt_max_of_the_ladder=0.03",
        "implicit-midpoint / cholesky model=stable-neo-hookean dt=8.442e-6",
        "bdf2 / cholesky model=stable-neo-hookean dt=0.03",
    ]
    .map(str::to_owned)
    .to_vec();
    let n = categories.len();
    StackedBarChart {
        title: "Time per step by phase: armadillo_yank".into(),
        y_label: "wall time per step (s)".into(),
        categories,
        parts: vec![
            ("forces".into(), vec![2e-4; n]),
            (
                "assembly".into(),
                (0..n).map(|i| (i % 2) as f64 * 1e-2).collect(),
            ),
            ("factorization".into(), vec![5e-3; n]),
            ("other".into(), vec![1e-5; n]),
        ],
        y_log: true,
    }
}

#[test]
fn no_tick_or_category_label_is_drawn_outside_the_image() {
    let phases = phase_chart();
    for y_log in [true, false] {
        let chart = Chart::Stacked(StackedBarChart {
            y_log,
            ..phases.clone()
        });
        let boxes = assert_text_inside(&chart);
        // No word is cut between characters: each one is drawn whole on some line.
        for label in &phases.categories {
            for word in label.split([' ', '/', '-']).filter(|w| !w.is_empty()) {
                assert!(
                    boxes.iter().any(|b| b.text.contains(word)),
                    "{word:?} of {label:?} is not drawn whole: {:?}",
                    boxes.iter().map(|b| &b.text).collect::<Vec<_>>()
                );
            }
        }
    }
    let bars = BarChart {
        title: "Largest stable dt".into(),
        y_label: "dt (s)".into(),
        y_log: true,
        bars: phases
            .categories
            .iter()
            .map(|c| Bar {
                label: c.clone(),
                value: Some(1e-3),
                ..Default::default()
            })
            .collect(),
        ..Default::default()
    };
    assert_text_inside(&Chart::Bar(bars));
    assert_text_inside(&Chart::Line(line_chart()));
}

#[test]
fn a_legend_of_twenty_series_stays_inside_the_image() {
    let series = (0..20)
        .map(|i| Series {
            label: format!("method-{i} / cholesky model=stable-neo-hookean"),
            points: (1..50)
                .map(|k| (k as f64 * 1e-3, (k * (i + 1)) as f64))
                .collect(),
            ended: i % 5 == 0,
        })
        .collect();
    let chart = Chart::Line(LineChart {
        title: "Energy over time".into(),
        x_label: "time (s)".into(),
        y_label: "total energy (J)".into(),
        x_log: true,
        y_log: false,
        series,
    });
    let boxes = assert_text_inside(&chart);
    for i in 0..20 {
        let label = format!("method-{i} / cholesky");
        assert!(
            boxes.iter().any(|b| b.text.contains(&label)),
            "series {i} is in the legend"
        );
    }
    let dir = TempDir::new("plot-legend");
    draw(&chart, &dir.path().join("legend20")).unwrap();
    let _ = std::fs::copy(dir.path().join("legend20.png"), "/tmp/wt14/legend20.png");
}
