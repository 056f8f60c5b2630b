//! Minimum wall time of the canonical step's three stages (wall angle, resample, corners)
//! on one thread.
//!
//! `cargo run --release --example canonical_time` times a 1000 x 1000 grid of walls;
//! `CANON_RAW=MAP.raw:H:W` (the values then the 0/1 unknown mask, as examples/stages.rs
//! reads them) times a real map; `REPS` repetitions (25).

use slamq::canonical::{canonical_map, wall_angle};
use slamq::corners::count_corners;
use slamq::grid::Grid;
use slamq::params::CornerParams;

fn main() {
    // CANON_RAW=MAP.raw:H:W (values then the 0/1 unknown mask, as examples/stages.rs
    // reads them) times a real map; else a 1000 x 1000 grid of walls
    let (v, u, h, w) = match std::env::var("CANON_RAW") {
        Ok(spec) => {
            let parts: Vec<&str> = spec.split(':').collect();
            let (h, w): (usize, usize) = (parts[1].parse().unwrap(), parts[2].parse().unwrap());
            let bytes = std::fs::read(parts[0]).unwrap();
            let u: Vec<bool> = bytes[h * w..].iter().map(|&b| b != 0).collect();
            (bytes[..h * w].to_vec(), u, h, w)
        }
        Err(_) => {
            let n = 1000;
            let mut v = vec![254u8; n * n];
            for (i, x) in v.iter_mut().enumerate() {
                if (i / n) % 37 == 0 || (i % n) % 53 == 0 {
                    *x = 0;
                }
            }
            (v, vec![false; n * n], n, n)
        }
    };
    let g = Grid::new(&v, &u, h, w).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    pool.install(|| {
        let mut best = [f64::MAX; 3];
        let reps: usize = std::env::var("REPS")
            .ok()
            .and_then(|r| r.parse().ok())
            .unwrap_or(25);
        for _ in 0..reps {
            let t = std::time::Instant::now();
            let a = wall_angle(&g).unwrap();
            let t1 = t.elapsed().as_secs_f64();
            let m = canonical_map(&g, a, Some(0.05), 0.07).unwrap().unwrap();
            let t2 = t.elapsed().as_secs_f64();
            let g2 = Grid::new(&m.values, &m.unknown, m.height, m.width).unwrap();
            let _ = count_corners(&g2, &CornerParams::default());
            let t3 = t.elapsed().as_secs_f64();
            for (b, x) in best.iter_mut().zip([t1, t2 - t1, t3 - t2]) {
                *b = b.min(x);
            }
        }
        eprintln!(
            "min ms: angle {:.2} resample {:.2} corners {:.2}",
            best[0] * 1e3,
            best[1] * 1e3,
            best[2] * 1e3
        );
    });
}
