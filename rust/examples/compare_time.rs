//! CPU time and results of `compare` on maps dumped to files (issue 27, row 4).
//!
//! `cargo run --release --example compare_time -- CASES RUNS [cells]` where CASES is a text
//! file, one comparison a line: `est.raw H W res x y yaw gt.raw H W res x y yaw align tol
//! max_distance` (`max_distance` `-` for none); a `.raw` file holds the values (H x W bytes)
//! then the unknown mask (H x W bytes, 0/1), row-major. Prints, per line, the minimum over
//! RUNS of the thread's CPU time (one thread) and every count and sum of the comparison
//! (floats as bits), so that two builds can be checked for identical results.

use slamq::compare::compare;
use slamq::grid::Grid;
use slamq::params::{Align, CompareParams};
use slamq::se2::{Frame, Placed, Se2};

#[repr(C)]
struct Timespec {
    sec: i64,
    nsec: i64,
}

extern "C" {
    fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
}

/// The calling thread's CPU time, seconds.
fn cpu() -> f64 {
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // CLOCK_THREAD_CPUTIME_ID = 3 on Linux
    unsafe { clock_gettime(3, &mut ts) };
    ts.sec as f64 + ts.nsec as f64 * 1e-9
}

type Map = (Vec<u8>, Vec<bool>, Frame);

fn load(f: &[&str]) -> Result<Map, Box<dyn std::error::Error>> {
    let bytes = std::fs::read(f[0])?;
    let (h, w): (usize, usize) = (f[1].parse()?, f[2].parse()?);
    if bytes.len() != 2 * h * w {
        return Err(format!("{}: {} bytes, not {}", f[0], bytes.len(), 2 * h * w).into());
    }
    let frame = Frame {
        resolution: f[3].parse()?,
        height: h,
        width: w,
        origin: Se2 {
            tx: f[4].parse()?,
            ty: f[5].parse()?,
            theta: f[6].parse()?,
        },
    };
    let values = bytes[..h * w].to_vec();
    let unknown = bytes[h * w..].iter().map(|&b| b != 0).collect();
    Ok((values, unknown, frame))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: compare_time CASES RUNS [cells]".into());
    }
    let runs: usize = args[2].parse()?;
    let want = args.get(3).is_some_and(|a| a == "cells");
    let text = std::fs::read_to_string(&args[1])?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let (ev, eu, ef) = load(&f[0..7])?;
        let (gv, gu, gf) = load(&f[7..14])?;
        let align = Align::from_name(f[14]).ok_or("bad align")?;
        let params = CompareParams {
            align,
            tolerance: f[15].parse()?,
            max_distance: if f[16] == "-" {
                None
            } else {
                Some(f[16].parse()?)
            },
            ..CompareParams::default()
        };
        let est = Placed {
            grid: Grid::new(&ev, &eu, ef.height, ef.width)?,
            frame: ef,
        };
        let gt = Placed {
            grid: Grid::new(&gv, &gu, gf.height, gf.width)?,
            frame: gf,
        };
        let (best, c) = pool.install(|| {
            let mut best = f64::INFINITY;
            let mut out = None;
            for _ in 0..runs {
                let t0 = cpu();
                let c = compare(&est, &gt, &params, want);
                best = best.min(cpu() - t0);
                out = Some(c);
            }
            (best, out)
        });
        let c = c.ok_or("no run")?.map_err(|e| e.to_string())?;
        let cells = c.cells.as_ref().map_or(0u64, |v| {
            v.iter().fold(0xcbf29ce484222325u64, |h, &b| {
                (h ^ b as u64).wrapping_mul(0x100000001b3)
            })
        });
        println!(
            "{:.3} ms | E {} G {} Em {} Gm {} I {} U {} sr {:x} sn {:x} tr {} tn {} free {} cov {} out {} T {:x} {:x} {:x} rms {:x} it {} in {} cells {:x}",
            best * 1e3,
            c.estimate_occupied,
            c.ground_truth_occupied,
            c.estimate_matched,
            c.ground_truth_matched,
            c.intersection,
            c.union,
            c.sum_reverse.to_bits(),
            c.sum_ne.to_bits(),
            c.truncated_reverse,
            c.truncated_ne,
            c.ground_truth_free,
            c.covered,
            c.outside,
            c.transform.theta.to_bits(),
            c.transform.tx.to_bits(),
            c.transform.ty.to_bits(),
            c.icp_rms.to_bits(),
            c.icp_iterations,
            c.icp_inliers,
            cells
        );
    }
    Ok(())
}
