//! Per-stage timing of one evaluation, on one thread (issue 15).
//!
//! `cargo run --release --example stages -- MAP.raw HEIGHT WIDTH [RUNS]` where MAP.raw holds
//! the values (H x W bytes) followed by the unknown mask (H x W bytes, 0/1), row-major
//! (benches/bench.py --stages writes such files for its dense crops). Prints the minimum
//! over RUNS of each stage's time, in ms per million cells, and checks that the stages
//! together give what `evaluate` gives, and `evaluate` with the defaults (the three metrics
//! and the wall angle) against the three metrics alone. The canonical step (SPEC 3a, off by
//! default, as in `bench.py --dense`) follows, by sub-stage, for the map taken as 0.05 m.
//! `stages MAP.raw HEIGHT WIDTH RUNS canonical` runs only the canonical step, RUNS times,
//! and prints its results (for callgrind).

use slamq::canonical::{canonical_corners_in, canonical_map, wall_angle};
use slamq::corners::{corner_runs, count_corners, drop_dots_runs, structure_mask_runs};
use slamq::enclosed::{binarisations, count_binarisation, sweep};
use slamq::evaluate::evaluate;
use slamq::grid::known_bounds;
use slamq::grid::Grid;
use slamq::label::count_components;
use slamq::otsu::threshold_table;
use slamq::params::Params;
use std::time::Instant;

fn time<T>(best: &mut f64, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let out = f();
    *best = best.min(t0.elapsed().as_secs_f64());
    out
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 4 {
        return Err("usage: stages MAP.raw HEIGHT WIDTH [RUNS]".into());
    }
    let bytes = std::fs::read(&args[1])?;
    let (h, w): (usize, usize) = (args[2].parse()?, args[3].parse()?);
    let runs: usize = args.get(4).map(|s| s.parse()).transpose()?.unwrap_or(20);
    // `canonical` as a fifth argument: only the canonical step, RUNS times (for callgrind)
    let only_canonical = args.get(5).is_some_and(|a| a == "canonical");
    if bytes.len() != 2 * h * w {
        return Err(format!(
            "{} holds {} bytes, expected {}",
            args[1],
            bytes.len(),
            2 * h * w
        )
        .into());
    }
    let values = &bytes[..h * w];
    let unknown: Vec<bool> = bytes[h * w..].iter().map(|&b| b != 0).collect();
    let grid = Grid::new(values, &unknown, h, w)?;
    // the defaults: canonical corners off (as in `benches/bench.py --dense`; the OpenCV
    // pipeline has none), the wall angle on
    let p = Params::default();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    pool.install(|| {
        let names = [
            "histogram",
            "structure mask (blur + Laplacian + threshold + runs)",
            "dot removal (sizes by union-find on the runs, clear small)",
            "Harris (sums, response, corner runs)",
            "corner blobs (count the corner runs' components)",
            "Otsu table (256 thresholds)",
        ];
        let mut t = [f64::INFINITY; 6];
        let mut total = f64::INFINITY;
        let mut three = f64::INFINITY;
        let keys = binarisations(&grid.histogram(), &p.enclosed);
        let mut tb = vec![f64::INFINITY; keys.len()];
        let mut tsweep = f64::INFINITY;
        let (mut corners, mut curve) = (0, Vec::new());
        let mut q = None;
        for _ in 0..if only_canonical { 0 } else { runs } {
            let hist = time(&mut t[0], || grid.histogram());
            let (mut mask, runs) = time(&mut t[1], || {
                structure_mask_runs(&grid, p.corners.log_threshold)
            });
            let rr = time(&mut t[2], || {
                drop_dots_runs(&mut mask, runs, h, w, p.corners.min_dot_area)
            });
            let cr = time(&mut t[3], || corner_runs(&mask, &rr, h, w, &p.corners));
            corners = time(&mut t[4], || count_components(&cr.runs, &cr.row_start, h));
            time(&mut t[5], || threshold_table(&hist));
            for (k, b) in keys.iter().enumerate() {
                time(&mut tb[k], || {
                    count_binarisation(&grid, *b, p.enclosed.min_area)
                });
            }
            curve = time(&mut tsweep, || sweep(&grid, &hist, &p.enclosed));
            // the three metrics alone, as evaluate computes them (without the wall angle)
            time(&mut three, || {
                let hist = grid.histogram();
                (count_corners(&grid, &p.corners), sweep(&grid, &hist, &p.enclosed))
            });
            q = Some(time(&mut total, || evaluate(&grid, None, &p, None)));
        }
        // the canonical step (SPEC 3a) of a 0.05 m map at the default reference resolution,
        // by sub-stage, and as evaluate runs it
        let mut pc = Params::default().corners;
        pc.canonical_resolution = 0.07;
        let res = Some(0.05);
        let cnames = [
            "canonical: known box",
            "canonical: wall angle (with the known box)",
            "canonical: resample (with the known box and its packing)",
            "canonical: corners of the canonical map",
        ];
        if only_canonical {
            let b = known_bounds(&grid);
            for _ in 0..runs {
                let c = canonical_corners_in(&grid, b, res, &pc).map_err(|e| e.to_string())?;
                println!("wall angle {} corners_canonical {:?}", c.angle, c.corners);
            }
            return Ok(());
        }
        let mut tc = [f64::INFINITY; 4];
        let mut tcanon = f64::INFINITY;
        let (mut ccount, mut cc, mut ccells) = (None, None, 0);
        for _ in 0..runs {
            time(&mut tc[0], || known_bounds(&grid));
            let a = time(&mut tc[1], || wall_angle(&grid)).map_err(|e| e.to_string())?;
            let m = time(&mut tc[2], || {
                canonical_map(&grid, a, res, pc.canonical_resolution)
            })
            .map_err(|e| e.to_string())?;
            if let Some(m) = m {
                let g = Grid::new(&m.values, &m.unknown, m.height, m.width)
                    .map_err(|e| e.to_string())?;
                ccells = m.height * m.width;
                ccount = Some(time(&mut tc[3], || count_corners(&g, &pc)));
            }
            let b = known_bounds(&grid);
            cc = Some(
                time(&mut tcanon, || canonical_corners_in(&grid, b, res, &pc))
                    .map_err(|e| e.to_string())?,
            );
        }
        assert_eq!(cc.map(|c| c.corners), Some(ccount));
        let q = q.ok_or("no run")?.map_err(|e| e.to_string())?;
        assert_eq!((q.corners, &q.curve), (corners, &curve));
        let mc = (h * w) as f64 / 1e6;
        let ms = |s: f64| s * 1e3 / mc;
        println!("| stage | ms/Mcell |\n|---|---:|");
        for (n, s) in names.iter().zip(t) {
            println!("| {n} | {:.2} |", ms(s));
        }
        for (b, s) in keys.iter().zip(&tb) {
            println!(
                "| labelling: known free iff v >= {}, unknown {} | {:.2} |",
                b.1,
                if b.0 { "free" } else { "not free" },
                ms(*s)
            );
        }
        println!("| enclosed sweep as evaluate runs it | {:.2} |", ms(tsweep));
        println!(
            "| **the three metrics (histogram, corners, full sweep)** | **{:.2}** |",
            ms(three)
        );
        println!(
            "| **evaluate with the defaults (the three metrics and the wall angle)** | **{:.2}** ({:.2}x the three metrics) |",
            ms(total),
            total / three
        );
        for (n, s) in cnames.iter().zip(tc) {
            println!("| {n} | {:.2} |", ms(s));
        }
        println!(
            "| **canonical step as evaluate runs it (0.05 m map, {:.2} Mcell canonical)** | **{:.2}** |",
            ccells as f64 / 1e6,
            ms(tcanon)
        );
        println!(
            "\n{h} x {w}, one thread, minimum of {runs} runs; corners {corners}, enclosed {}, corners_canonical {:?}",
            curve.iter().max().unwrap_or(&0),
            ccount
        );
        Ok::<(), String>(())
    })?;
    Ok(())
}
