//! One chart of each kind, for looking at the plot style:
//! `cargo run --release --example plot_gallery -- /tmp/plot-examples`.

use std::path::PathBuf;

use softbench::plot::{
    Bar, BarChart, Chart, LineChart, ReferenceLine, Series, StackedBarChart, draw,
};

fn main() -> anyhow::Result<()> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "plot-examples".into()),
    );
    std::fs::create_dir_all(&dir)?;

    let dts: Vec<f64> = (0..9).map(|k| 1e-5 * 10f64.powf(k as f64 / 4.0)).collect();
    let methods = [
        ("symplectic-euler", 1.0, 1.0),
        ("velocity-verlet", 0.3, 2.0),
        ("rk4", 50.0, 4.0),
        ("backward-euler / cholesky", 2.0, 1.0),
        ("implicit-midpoint / cg", 0.1, 2.0),
    ];
    let mut series: Vec<Series> = methods
        .iter()
        .map(|&(label, c, order)| Series {
            label: label.into(),
            ended: false,
            points: dts
                .iter()
                .map(|&dt| {
                    let err = c * (dt / 1e-3f64).powf(order);
                    // Explicit methods blow up at large steps: not finite there.
                    if label == "rk4" && dt > 5e-4 {
                        (dt, f64::NAN)
                    } else {
                        (dt, err)
                    }
                })
                .collect(),
        })
        .collect();
    series.push(Series {
        label: "explicit-euler".into(),
        points: vec![(1e-5, f64::INFINITY)],
        ended: false,
    });
    let line = LineChart {
        title: "Energy error after 1 s against time step".into(),
        x_label: "time step dt [s]".into(),
        y_label: "relative energy error |E - E0| / E0 [-]".into(),
        x_log: true,
        y_log: true,
        series,
    };

    let names = [
        "explicit-euler",
        "symplectic-euler",
        "velocity-verlet",
        "rk4",
        "rk45-adaptive",
        "backward-euler / cholesky",
        "backward-euler / ldlt",
        "backward-euler / cg",
        "linearly-implicit-euler / cholesky",
        "linearly-implicit-euler / cg",
        "implicit-midpoint / cholesky",
        "implicit-midpoint / cg",
        "bdf2 / cholesky",
        "bdf2 / cg",
        "newmark-average-acceleration",
        "generalized-alpha",
        "trapezoidal / cholesky",
        "incremental-potential / cholesky",
        "projective-dynamics",
        "xpbd",
    ];
    let bars: Vec<Bar> = names
        .iter()
        .enumerate()
        .map(|(i, &label)| {
            let explicit = i < 5;
            Bar {
                label: label.into(),
                value: match i {
                    3 => Some(4.1e-5),
                    _ if explicit => Some(1.5e-5 * (1.0 + i as f64 * 0.3)),
                    9 | 13 => None,
                    _ => Some(1e-3 * (1.0 + (i % 4) as f64)),
                },
                marker: explicit.then_some(2.2e-5 * (1.0 + i as f64 * 0.25)),
                note: Some("no stable dt in range".into()),
            }
        })
        .collect();
    let bar = BarChart {
        title: "Largest stable time step, jello cube (E = 1e5 Pa)".into(),
        y_label: "largest stable dt [s]".into(),
        y_log: true,
        bars,
        marker_label: Some("own 2/ω limit (explicit methods)".into()),
        reference: Some(ReferenceLine {
            label: "frame time 1/60 s".into(),
            value: 1.0 / 60.0,
        }),
    };

    let categories: Vec<String> = [
        "backward-euler / cholesky",
        "backward-euler / cg",
        "implicit-midpoint / cholesky",
        "linearly-implicit-euler / cholesky",
        "incremental-potential / cholesky",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let stacked = StackedBarChart {
        title: "Time per step by phase, 28k DOFs".into(),
        y_label: "wall time per step [ms]".into(),
        categories,
        parts: vec![
            ("assembly".into(), vec![40.0, 42.0, 41.0, 38.0, 45.0]),
            (
                "factorization".into(),
                vec![520.0, 0.0, 530.0, 180.0, 610.0],
            ),
            ("solve".into(), vec![25.0, 310.0, 27.0, 9.0, 30.0]),
            ("line search".into(), vec![0.0, 0.0, 0.0, 0.0, 60.0]),
            ("other".into(), vec![12.0, 11.0, 13.0, 10.0, 15.0]),
        ],
        y_log: true,
    };

    for (name, chart) in [
        ("line", Chart::Line(line)),
        ("bar", Chart::Bar(bar)),
        ("stacked", Chart::Stacked(stacked)),
    ] {
        let [png, svg] = draw(&chart, &dir.join(name))?;
        println!("{}\n{}", png.display(), svg.display());
    }
    Ok(())
}
