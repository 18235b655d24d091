//! Pictures of the body: the rasterizer draws where the camera projects, a run's snapshots
//! hold the sampled times and a failed run's last valid state, the GIF decodes with an
//! independent decoder (Python's Pillow) with one frame per sample, and a study panel has one
//! row per run.

mod common;

use std::process::Command;

use common::{TempDir, scene, simulate};
use softbench::render::film::{CELL, FILM_TIMES};
use softbench::render::raster::{BACKGROUND, Bounds, Camera, Canvas};
use softbench::render::{
    Coloring, RunPictures, SAMPLES, SnapshotFrame, Snapshots, animation, panel,
};

/// A box [0,2] x [0,1] x [0,0.5] as 12 outward triangles.
fn box_snapshots(frames: usize) -> Snapshots {
    let (a, b, c) = (2.0f32, 1.0f32, 0.5f32);
    let positions: Vec<[f32; 3]> = (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { 0.0 } else { a },
                if i & 2 == 0 { 0.0 } else { b },
                if i & 4 == 0 { 0.0 } else { c },
            ]
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Snapshots {
        up: [0.0, 1.0, 0.0],
        end_time: 1.0,
        triangles,
        frames: (0..frames)
            .map(|k| SnapshotFrame {
                t: k as f64 / (frames.max(2) - 1) as f64,
                step: k as u64,
                positions: positions
                    .iter()
                    .map(|p| [p[0] + 0.1 * k as f32, p[1], p[2]])
                    .collect(),
                j: vec![1.0; 12],
                energy_density: vec![0.0; 12],
                obstacles: Vec::new(),
                last_valid: false,
            })
            .collect(),
        failure: String::new(),
    }
}

#[test]
fn a_box_renders_to_its_projected_bounding_box() {
    let s = box_snapshots(1);
    let frame = &s.frames[0];
    let bounds = Bounds::of(&frame.positions).unwrap();
    let camera = Camera::framing(&bounds, s.up, 320, 240);
    let mut canvas = Canvas::new(320, 240);
    softbench::render::film::draw_frame(&mut canvas, &camera, &s, frame, Coloring::Plain);
    // The projected corners' box, in pixels.
    let projected: Vec<[f64; 3]> = bounds
        .corners()
        .iter()
        .map(|c| camera.project(*c))
        .collect();
    let min = |k: usize| projected.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min);
    let max = |k: usize| {
        projected
            .iter()
            .map(|p| p[k])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    // The drawn pixels' box.
    let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
    for y in 0..240 {
        for x in 0..320 {
            if canvas.pixel(x, y) != BACKGROUND {
                x0 = x0.min(x);
                y0 = y0.min(y);
                x1 = x1.max(x);
                y1 = y1.max(y);
            }
        }
    }
    // A pixel is drawn when its centre is covered: every drawn centre lies inside the
    // projected box, and the drawn box reaches to within two pixels of each side (a sharp
    // corner of the silhouette may fall between pixel centres).
    let near = |drawn: u32, edge: f64| (f64::from(drawn) + 0.5 - edge).abs() <= 2.0;
    let inside =
        |lo: u32, hi: u32, k: usize| f64::from(lo) + 0.5 >= min(k) && f64::from(hi) + 0.5 <= max(k);
    assert!(inside(x0, x1, 0) && inside(y0, y1, 1));
    assert!(
        near(x0, min(0)) && near(x1, max(0)),
        "x: drawn {x0}..{x1}, projected {}..{}",
        min(0),
        max(0)
    );
    assert!(
        near(y0, min(1)) && near(y1, max(1)),
        "y: drawn {y0}..{y1}, projected {}..{}",
        min(1),
        max(1)
    );
    // The framing leaves a margin of 6 % on the tighter side and centres the box.
    assert!(min(0) >= 0.05 * 320.0 && max(0) <= 0.95 * 320.0);
    assert!(min(1) >= 0.05 * 240.0 && max(1) <= 0.95 * 240.0);
    // A closed box covers its silhouette: no background pixel inside the drawn box's centre.
    let (cx, cy) = ((x0 + x1) / 2, (y0 + y1) / 2);
    assert_ne!(canvas.pixel(cx, cy), BACKGROUND);
}

#[test]
fn the_nearer_face_hides_the_farther_one() {
    // Two parallel squares, the near one red, the far one blue, both covering the centre.
    let square = |z: f32| -> Vec<[f32; 3]> {
        vec![
            [-1.0, -1.0, z],
            [1.0, -1.0, z],
            [1.0, 1.0, z],
            [-1.0, 1.0, z],
        ]
    };
    let pts: Vec<[f32; 3]> = square(0.0).into_iter().chain(square(0.0)).collect();
    let bounds = Bounds::of(&pts).unwrap();
    let camera = Camera::framing(&bounds, [0.0, 1.0, 0.0], 100, 100);
    let toward_eye = {
        // The eye looks from +z-ish (azimuth 35 deg from +z around y, 25 deg up): the square
        // at larger z is nearer.
        let p_near = camera.project([0.0, 0.0, 0.5]);
        let p_far = camera.project([0.0, 0.0, -0.5]);
        p_near[2] < p_far[2]
    };
    assert!(toward_eye, "the camera looks from +z");
    let mut canvas = Canvas::new(100, 100);
    let quad = |z: f64| {
        [
            [[-1.0, -1.0, z], [1.0, -1.0, z], [1.0, 1.0, z]],
            [[-1.0, -1.0, z], [1.0, 1.0, z], [-1.0, 1.0, z]],
        ]
    };
    // Drawn far-last, so only the depth test can keep the near one.
    for t in quad(0.5) {
        canvas.triangle(&camera, t, [255, 0, 0]);
    }
    for t in quad(-0.5) {
        canvas.triangle(&camera, t, [0, 0, 255]);
    }
    let c = camera.project([0.0, 0.0, 0.5]);
    let px = canvas.pixel(c[0] as u32, c[1] as u32);
    assert!(
        px[0] > 0 && px[2] == 0,
        "the near red square shows, got {px:?}"
    );
}

#[test]
fn snapshots_survive_a_round_trip_and_a_foreign_file_is_refused() {
    let dir = TempDir::new("render-roundtrip");
    let mut s = box_snapshots(3);
    s.frames[2].last_valid = true;
    s.frames[1].obstacles = vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]];
    s.failure = "unstable (energy growth) at t = 0.5 s".into();
    let path = dir.path().join("a.snapshots");
    s.write(&path).unwrap();
    assert_eq!(Snapshots::read(&path).unwrap(), s);
    let bad = dir.write("b.snapshots", "not gzip at all");
    let e = Snapshots::read(&bad).unwrap_err().to_string();
    assert!(
        e.contains("b.snapshots") && e.contains("not a readable snapshot file"),
        "{e}"
    );
}

/// Reads `path` with Python's Pillow and prints `frames width height`. Under CI (`CI` set) a
/// missing Pillow fails the test; otherwise it is skipped with a visible line.
fn pillow_gif_info(path: &std::path::Path) -> Option<(usize, u32, u32)> {
    let probe = Command::new("python3").args(["-c", "import PIL"]).output();
    if !probe.as_ref().is_ok_and(|o| o.status.success()) {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but Python's Pillow is not importable; .ci/run installs it"
        );
        eprintln!("skipped: Pillow is not importable (`python3 -m pip install pillow`)");
        return None;
    }
    let script = format!(
        "from PIL import Image\nim = Image.open({:?})\nassert im.format == 'GIF'\nn = 0\n\
         try:\n    while True:\n        im.seek(n); im.convert('RGB'); n += 1\nexcept EOFError:\n    pass\n\
         print(n, im.size[0], im.size[1])",
        path.to_str().unwrap()
    );
    let out = Command::new("python3")
        .args(["-c", &script])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let v: Vec<&str> = text.split_whitespace().collect();
    Some((
        v[0].parse().unwrap(),
        v[1].parse().unwrap(),
        v[2].parse().unwrap(),
    ))
}

#[test]
fn a_run_gif_has_one_frame_per_sample_and_decodes_with_pillow() {
    let dir = TempDir::new("render-gif");
    let s = box_snapshots(SAMPLES);
    let path = dir.path().join("a.gif");
    let one = [RunPictures {
        label: "box".into(),
        snapshots: &s,
    }];
    animation(&path, &one, Coloring::VolumeRatio).unwrap();
    // The gif crate's own decoder agrees on the frame count.
    let file = std::fs::File::open(&path).unwrap();
    let mut decoder = gif::DecodeOptions::new().read_info(file).unwrap();
    let mut n = 0;
    while decoder.read_next_frame().unwrap().is_some() {
        n += 1;
    }
    assert_eq!(n, SAMPLES);
    if let Some((frames, w, h)) = pillow_gif_info(&path) {
        assert_eq!(frames, SAMPLES);
        assert_eq!((w, h), (CELL.0, CELL.1 + 20));
    }
}

#[test]
fn a_study_panel_has_one_row_per_run_with_a_body_in_every_cell() {
    let dir = TempDir::new("render-panel");
    let runs: Vec<Snapshots> = (0..3).map(|_| box_snapshots(SAMPLES)).collect();
    let pictures: Vec<RunPictures> = runs
        .iter()
        .enumerate()
        .map(|(i, s)| RunPictures {
            label: format!("run {i}"),
            snapshots: s,
        })
        .collect();
    let path = dir.path().join("panel.png");
    panel(&path, &pictures, Coloring::Plain).unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    let (cw, ch) = CELL;
    let row_h = ch + 34;
    assert_eq!(img.height(), 3 * row_h);
    let label_w = img.width() - FILM_TIMES as u32 * cw;
    for row in 0..3 {
        for col in 0..FILM_TIMES as u32 {
            let (x0, y0) = (label_w + col * cw, row * row_h);
            let body = (y0..y0 + ch)
                .flat_map(|y| (x0..x0 + cw).map(move |x| (x, y)))
                .filter(|&(x, y)| {
                    let p = img.get_pixel(x, y).0;
                    p[2] > p[0] + 40 // the body's blue
                })
                .count();
            assert!(body > 100, "row {row}, column {col}: {body} body pixels");
        }
    }
}

#[test]
fn simulate_render_keeps_the_sampled_times_and_marks_a_failed_run() {
    let dir = TempDir::new("render-simulate");
    let out = dir.path().join("ok");
    let o = simulate(
        &scene("soft_beam.toml"),
        &out,
        &["--render", "--set", "run.steps=60"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = Snapshots::read(&out.join("run.snapshots")).unwrap();
    // 60 steps in 30 parts: every second step, 31 frames, the last at the horizon.
    assert_eq!(s.frames.len(), SAMPLES);
    for (k, f) in s.frames.iter().enumerate() {
        assert_eq!(f.step, 2 * k as u64);
        assert!((f.t - 0.002 * f.step as f64).abs() < 1e-12);
        assert_eq!(f.j.len(), s.triangles.len());
    }
    assert!((s.end_time - 0.12).abs() < 1e-12);
    assert!(s.failure.is_empty());
    // At rest every tet has J = 1 and the body hangs from x = 0 along +x up to 1 m.
    assert!(s.frames[0].j.iter().all(|j| (j - 1.0).abs() < 1e-6));
    let xs = s.frames[0].positions.iter().map(|p| p[0]);
    assert!((xs.clone().fold(f32::MAX, f32::min)).abs() < 1e-6);
    assert!((xs.fold(f32::MIN, f32::max) - 1.0).abs() < 1e-6);
    for f in ["filmstrip.png", "animation.gif"] {
        assert!(out.join(f).is_file(), "{f}");
    }

    // Far beyond its stability limit, symplectic Euler blows up within a few steps.
    let bad = dir.path().join("bad");
    let o = simulate(
        &scene("soft_beam.toml"),
        &bad,
        &[
            "--render",
            "--set",
            "integrator.method=symplectic-euler",
            "--set",
            "run.dt=0.01",
            "--set",
            "run.steps=100",
        ],
    );
    assert!(!o.status.success());
    let s = Snapshots::read(&bad.join("run.snapshots")).unwrap();
    let last = s.frames.last().unwrap();
    assert!(last.last_valid, "the last frame is the last valid state");
    assert!(s.frames[..s.frames.len() - 1].iter().all(|f| !f.last_valid));
    assert!(last.t < s.end_time);
    assert!(s.failure.starts_with("unstable"), "{}", s.failure);
    assert!(last.positions.iter().flatten().all(|x| x.is_finite()));
    // `softbench render` redraws the pictures from the file alone.
    std::fs::remove_file(bad.join("filmstrip.png")).unwrap();
    let o = common::softbench(&["render", bad.to_str().unwrap(), "--color", "plain"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(bad.join("filmstrip.png").is_file());
}

#[test]
fn a_study_draws_one_panel_per_scene_with_a_row_per_run_and_embeds_it() {
    let dir = TempDir::new("render-study");
    let study =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/quickstart.toml");
    common::run_study_ok(&study, dir.path(), &["--quick", "--only", "soft_beam-*"]);
    let results = dir.path().join("quickstart");
    let runs = std::fs::read_to_string(results.join("runs.csv")).unwrap();
    let n = runs.lines().count() - 1;
    assert!(n >= 2, "{n} runs");
    for id in runs.lines().skip(1).map(|l| l.split(',').next().unwrap()) {
        assert!(
            results.join(format!("series/{id}.snapshots")).is_file(),
            "{id}"
        );
    }
    let img = image::open(results.join("pictures-soft_beam.png")).unwrap();
    assert_eq!(img.height(), n as u32 * (CELL.1 + 34));
    let report = std::fs::read_to_string(results.join("report.md")).unwrap();
    assert!(report.contains("![The body over time: soft_beam](pictures-soft_beam.png)"));
    assert!(report.contains("(pictures-soft_beam.gif)"));
    if let Some((frames, _, _)) = pillow_gif_info(&results.join("pictures-soft_beam.gif")) {
        assert_eq!(frames, SAMPLES);
    }
    // `softbench render` redraws them from the snapshot files.
    std::fs::remove_file(results.join("pictures-soft_beam.png")).unwrap();
    let o = common::softbench(&["render", results.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(results.join("pictures-soft_beam.png").is_file());
}

#[test]
fn a_stability_study_pictures_each_methods_chosen_trial_and_marks_one_unstable_everywhere() {
    let dir = TempDir::new("render-stability");
    let study = dir.path().join("stability.toml");
    // Explicit Euler on the stiff beam blows up at every judged step (>= 1 s / 200, far above
    // its explicit limit, so the verdict is about the range, not every dt); backward Euler is
    // stable to the ceiling.
    std::fs::write(
        &study,
        format!(
            "name = \"pictured\"\nstudy = \"stability\"\nscenes = [{:?}]\n\
             [grid]\n\"integrator.method\" = [\"explicit-euler\", \"backward-euler\"]\n\
             [set]\n\"material.youngs_modulus\" = 1e7\n\
             [stability]\ndt_min = 5e-3\ndt_max = 0.02\nhorizon = 1.0\nmax_steps = 200\n\
             relative_precision = 0.1\n",
            scene("soft_beam.toml")
        ),
    )
    .unwrap();
    common::run_study_ok(&study, dir.path(), &[]);
    let results = dir.path().join("pictured");
    let runs = std::fs::read_to_string(results.join("runs.csv")).unwrap();
    let id = |method: &str| {
        runs.lines()
            .map(|l| l.split(',').next().unwrap())
            .find(|id| id.contains(method))
            .unwrap()
            .to_owned()
    };
    let snapshots = |method: &str| {
        Snapshots::read(&results.join(format!("series/{}.snapshots", id(method)))).unwrap()
    };
    assert!(runs.contains("no-stable-dt-in-range"), "{runs}");
    assert!(runs.contains("stable-to-ceiling"), "{runs}");
    // The stable run's pictures cover the horizon; the unstable one's end at its last valid
    // state, marked with the cause.
    let stable = snapshots("backward-euler");
    assert!(stable.failure.is_empty());
    assert!((stable.frames.last().unwrap().t - 1.0).abs() < 1e-9);
    let unstable = snapshots("explicit-euler");
    assert!(
        unstable.failure.starts_with("unstable"),
        "{}",
        unstable.failure
    );
    let last = unstable.frames.last().unwrap();
    assert!(last.last_valid && last.t < 1.0);
    let img = image::open(results.join("pictures-soft_beam.png")).unwrap();
    assert_eq!(img.height(), 2 * (CELL.1 + 34));
    let report = std::fs::read_to_string(results.join("report.md")).unwrap();
    assert!(report.contains("![The body over time: soft_beam](pictures-soft_beam.png)"));
}

/// Snapshots of a course Neo-Hookean box at rest (step 0) and with one corner pulled out by
/// 10% of the box (step 1), recorded by the study's recorder.
fn energy_snapshots() -> Snapshots {
    energy_snapshots_of(|q| q[0] -= 0.02)
}

/// Snapshots of the box of [`energy_snapshots`] at rest (step 0) and deformed by `deform`
/// (step 1).
fn energy_snapshots_of(deform: impl Fn(&mut Vec<f64>)) -> Snapshots {
    use softbench::integrate::State;
    use softbench::material::{MaterialModel, NeoHookean};
    use softbench::model::{Model, ModelSpec};
    use softbench::run::Observer;
    let mesh = softbench::mesh::generate::box_mesh([2, 1, 1], [0.2, 0.1, 0.1]);
    let material = MaterialModel::NeoHookean(NeoHookean::from_c_d(1e4, 2e4));
    let model = Model::new(ModelSpec::elastic(mesh, material, 1000.0)).unwrap();
    let rest = State::at_rest(&model);
    let mut pulled = rest.clone();
    deform(&mut pulled.q);
    pulled.t = 1.0;
    let surface = softbench::render::Surface::boundary(&model, model.tets());
    let mut rows = |_: &softbench::run::Sample| Ok(());
    let mut recorder =
        softbench::render::SnapshotRecorder::new(&model, &rest, surface, None, (1, 1.0), &mut rows);
    recorder.after_step(0, &model, &rest).unwrap();
    recorder.after_step(1, &model, &pulled).unwrap();
    recorder.finish(&model, &softbench::run::Outcome::completed())
}

#[test]
fn energy_colouring_is_one_colour_at_rest_and_higher_where_stretched() {
    use softbench::render::film::max_energy_density;
    use softbench::render::raster::energy_color;
    let s = energy_snapshots();
    assert_eq!(s.frames.len(), 2);
    let (rest, pulled) = (&s.frames[0], &s.frames[1]);
    assert_eq!(rest.energy_density.len(), s.triangles.len());
    // At rest every tet stores no energy: every face gets the one colour of zero.
    assert!(
        rest.energy_density.iter().all(|&e| e == 0.0),
        "{:?}",
        rest.energy_density
    );
    let max = max_energy_density(&s);
    assert!(max > 0.0);
    let zero = energy_color(0.0, max);
    assert!(
        rest.energy_density
            .iter()
            .all(|&e| energy_color(e, max) == zero)
    );
    // Pulling one corner stores energy in the tets around it only; they are redder.
    let stretched: Vec<f32> = pulled
        .energy_density
        .iter()
        .copied()
        .filter(|&e| e > 0.0)
        .collect();
    assert!(!stretched.is_empty() && stretched.len() < s.triangles.len());
    let hot = energy_color(max, max);
    assert_ne!(hot, zero);
    assert!(i32::from(hot[0]) - i32::from(hot[2]) > i32::from(zero[0]) - i32::from(zero[2]));
    // And the densities survive the file.
    let dir = TempDir::new("render-energy");
    let path = dir.path().join("e.snapshots");
    s.write(&path).unwrap();
    assert_eq!(Snapshots::read(&path).unwrap(), s);
    // Drawn, the energy colouring is not the det F one.
    let camera = Camera::framing(&Bounds::of(&pulled.positions).unwrap(), s.up, 160, 120);
    let draw = |frame: &SnapshotFrame, c: Coloring| {
        let mut canvas = Canvas::new(160, 120);
        softbench::render::film::draw_frame(&mut canvas, &camera, &s, frame, c);
        canvas
    };
    let pixels = |c: &Canvas| -> Vec<[u8; 3]> {
        (0..120)
            .flat_map(|y| (0..160).map(move |x| (x, y)))
            .map(|(x, y)| c.pixel(x, y))
            .collect()
    };
    let energy = pixels(&draw(pulled, Coloring::EnergyDensity));
    let j = pixels(&draw(pulled, Coloring::VolumeRatio));
    assert_ne!(energy, j);
}

#[test]
fn a_panel_shares_one_energy_scale_that_a_blown_up_run_does_not_set() {
    use softbench::render::film::{max_energy_density, shared_energy_max};
    // Stretched by 10% along x everywhere: every face stores energy.
    let a = energy_snapshots_of(|q| q.iter_mut().step_by(3).for_each(|x| *x *= 1.1));
    let scaled = |s: &Snapshots, k: f32, failure: &str| {
        let mut s = s.clone();
        for f in &mut s.frames {
            for e in &mut f.energy_density {
                *e *= k;
            }
        }
        s.failure = failure.to_owned();
        s
    };
    let b = scaled(&a, 4.0, "");
    let blown = scaled(&a, 1000.0, "unstable: energy growth at t = 0.5 s");
    let max_a = max_energy_density(&a);
    fn pictures<'a>(runs: &[&'a Snapshots]) -> Vec<RunPictures<'a>> {
        runs.iter()
            .enumerate()
            .map(|(i, s)| RunPictures {
                label: format!("run {i}"),
                snapshots: s,
            })
            .collect()
    }
    assert_eq!(shared_energy_max(&pictures(&[&a, &b])), 4.0 * max_a);
    // The blown-up run does not wash out the others; alone, it has its own scale.
    assert_eq!(shared_energy_max(&pictures(&[&a, &b, &blown])), 4.0 * max_a);
    assert_eq!(shared_energy_max(&pictures(&[&blown])), 1000.0 * max_a);
    // Drawn together, the less stretched run's hottest face is paler than the other's.
    let dir = TempDir::new("render-shared-energy");
    let path = dir.path().join("panel.png");
    panel(&path, &pictures(&[&a, &b]), Coloring::EnergyDensity).unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    let (cw, ch) = CELL;
    let row_h = ch + 34;
    let label_w = img.width() - FILM_TIMES as u32 * cw;
    // The last column shows the pulled frame; redness = red minus blue.
    let hottest = |row: u32| {
        let (x0, y0) = (label_w + (FILM_TIMES as u32 - 1) * cw, row * row_h);
        (y0..y0 + ch)
            .flat_map(|y| (x0..x0 + cw).map(move |x| (x, y)))
            .map(|(x, y)| {
                let p = img.get_pixel(x, y).0;
                i32::from(p[0]) - i32::from(p[2])
            })
            .max()
            .unwrap()
    };
    assert!(hottest(0) < hottest(1), "{} vs {}", hottest(0), hottest(1));
}

#[test]
fn a_work_precision_study_pictures_each_method_at_its_least_accurate_completed_step() {
    let dir = TempDir::new("render-wp");
    std::fs::write(
        dir.path().join("beam.toml"),
        "[mesh]\ngenerate = { box = [4, 1, 1], size = [1.0, 0.25, 0.25] }\n\
         [material]\nmodel = \"stable-neo-hookean\"\nyoungs_modulus = 2e6\npoisson_ratio = 0.3\n\
         density = 1000.0\nmass = \"lumped\"\n\
         [fixed]\nrule = { axis = \"x\", side = \"min\", tolerance = 1e-6 }\n\
         [forces]\ngravity = [0.0, -9.81, 0.0]\n[run]\ndt = 0.01\nsteps = 1\n",
    )
    .unwrap();
    // Symplectic Euler blows up at 0.02 s on this stiff beam and completes at 0.5 ms;
    // backward Euler completes at both.
    let study = dir.path().join("study.toml");
    std::fs::write(
        &study,
        "name = \"wp\"\nstudy = \"work-precision\"\nscenes = [\"beam.toml\"]\n\
         [grid]\n\"integrator.method\" = [\"symplectic-euler\", \"backward-euler\"]\n\
         \"run.dt\" = [0.02, 0.0005]\n\
         [work-precision]\nhorizon = 0.4\nsamples = 2\n\
         reference = { method = \"rk4\", dt_factor = 4 }\n",
    )
    .unwrap();
    common::run_study_ok(&study, dir.path(), &[]);
    let results = dir.path().join("wp");
    let runs = std::fs::read_to_string(results.join("runs.csv")).unwrap();
    assert_eq!(runs.lines().count() - 1, 4);
    assert!(
        runs.lines()
            .any(|l| l.contains("symplectic-euler") && l.contains("unstable")),
        "{runs}"
    );
    // Every run keeps its snapshots; the panel shows one row per method.
    for id in runs.lines().skip(1).map(|l| l.split(',').next().unwrap()) {
        assert!(
            results.join(format!("series/{id}.snapshots")).is_file(),
            "{id}"
        );
    }
    let img = image::open(results.join("pictures-beam.png")).unwrap();
    assert_eq!(img.height(), 2 * (CELL.1 + 34));
    let report = std::fs::read_to_string(results.join("report.md")).unwrap();
    assert!(
        report.contains("rows: symplectic-euler dt=5e-4; backward-euler / cholesky dt=2e-2"),
        "{report}"
    );
}

/// Issue 24: runs of one method that differ only in dt are told apart in the picture rows and
/// in the findings (the step has a `dt` column, not a parameter column, and was left out).
#[test]
fn rows_of_one_method_at_two_steps_are_labelled_with_their_dt() {
    let dir = TempDir::new("render-dt-labels");
    let study = dir.path().join("steps.toml");
    std::fs::write(
        &study,
        format!(
            "name = \"steps\"\nstudy = \"trajectory\"\nscenes = [{:?}]\n\
             [grid]\n\"integrator.method\" = [\"backward-euler\"]\n\
             \"run.dt\" = [0.002, 0.001]\n\
             [set]\n\"run.steps\" = 10\n\"run.sample_every\" = 5\n",
            scene("soft_beam.toml")
        ),
    )
    .unwrap();
    common::run_study_ok(&study, dir.path(), &[]);
    let report = std::fs::read_to_string(dir.path().join("steps/report.md")).unwrap();
    let pictures = report
        .lines()
        .find(|l| l.starts_with("One row per run"))
        .expect("the pictures' caption");
    assert!(
        pictures.contains("backward-euler / cholesky dt=2e-3")
            && pictures.contains("backward-euler / cholesky dt=1e-3"),
        "{pictures}"
    );
    let findings = &report[report.find("## Findings").unwrap()..report.find("Study file").unwrap()];
    assert!(
        findings.contains("backward-euler / cholesky dt=2e-3")
            && findings.contains("backward-euler / cholesky dt=1e-3"),
        "{findings}"
    );
}

/// Issue 24: a failed run's last valid state, which has no det F recorded, was painted in the
/// plain body colour, a blue that the det F scale uses for "compressed". It is magenta now.
#[test]
fn a_failed_runs_last_state_is_not_painted_in_a_det_f_colour() {
    use softbench::render::film::FAILED_BODY;
    let mut s = box_snapshots(2);
    let last = s.frames.last_mut().unwrap();
    last.last_valid = true;
    last.j.clear();
    last.energy_density.clear();
    let frame = s.frames.last().unwrap();
    let camera = Camera::framing(&Bounds::of(&frame.positions).unwrap(), s.up, 160, 120);
    let mut canvas = Canvas::new(160, 120);
    for coloring in [Coloring::VolumeRatio, Coloring::EnergyDensity] {
        softbench::render::film::draw_frame(&mut canvas, &camera, &s, frame, coloring);
        let centre = canvas.pixel(80, 60);
        // Shading scales the colour: it keeps magenta's balance (red = blue, green low),
        // which no det F colour (blue compressed, white, red stretched, black) has.
        let [r, g, b] = centre.map(i32::from);
        assert!(
            (r - b).abs() <= 2 && g < r / 2 && r > 40,
            "{coloring:?}: {centre:?}, expected a shade of {FAILED_BODY:?}"
        );
    }
}

/// Issue 24: the energy chart plots |excess| on a log axis, which hid whether energy was gained
/// or lost; its legend now says. Backward Euler on an undamped beam only loses energy.
#[test]
fn the_energy_chart_says_whether_energy_was_gained_or_lost() {
    let dir = TempDir::new("plot-energy-sign");
    let study = dir.path().join("sign.toml");
    std::fs::write(
        &study,
        format!(
            "name = \"sign\"\nstudy = \"trajectory\"\nscenes = [{:?}]\n\
             [grid]\n\"integrator.method\" = [\"backward-euler\"]\n\
             [set]\n\"run.dt\" = 0.002\n\"run.steps\" = 20\n\"run.sample_every\" = 5\n",
            scene("soft_beam.toml")
        ),
    )
    .unwrap();
    common::run_study_ok(&study, dir.path(), &[]);
    let svg = std::fs::read_to_string(dir.path().join("sign/energy-soft_beam.svg")).unwrap();
    assert!(svg.contains("backward-euler (lost)"), "no '(lost)' legend");
    assert!(!svg.contains("(gained)") && !svg.contains(", gained"));
}
