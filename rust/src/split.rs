//! A trajectory against its own scans, split in time (SPEC section 7e): the scans a
//! trajectory places are cut into two halves in time; each half is drawn as a map at its
//! poses, and the other half's scans are scored against that map by SPEC section 7b
//! ([`crate::scans`]). A wall that wrong poses draw in one half is crossed by the other
//! half's beams, while a map drawn from all the scans lets the right poses outvote the wrong
//! ones. The program's own map is not read, so how it draws occupancy does not enter.
//!
//! Drawing: every valid beam of a scan walks from the laser's cell to its end cell
//! (Amanatides and Woo, as [`crate::scans`]; on a tie at a cell corner the walk steps to the
//! row neighbour first), and the scan's polygon (the laser, then its beams' ends) is
//! filled; a scan *visits* each cell one of its beams passes through or ends in and each
//! cell whose centre its polygon covers, and *hits* each cell a beam ends in, each cell at
//! most once per scan. A cell is occupied when hit and its hits are at least
//! `occupied_share` of its visits, free when visited and not occupied, unknown when never
//! visited.
//!
//! The two halves are drawn in parallel (one after the other on a grid of more than
//! [`PARALLEL_CELLS`] cells, to hold one half's counts at a time), each scan after scan
//! (integer counts), and scored by [`crate::scans::consistency`]: the result is the same
//! for any number of threads.
//! `python/slamq/metrics/split.py`'s `scan_split_reference` is this module's numpy twin
//! (the same floating-point operations in the same order).

use crate::scans::{check_recording, consistency, filled, first_boundary, ScanError, ScanGrid};

/// The most cells a drawn map may have (a 410 m x 410 m box at 0.05 m per cell; a half
/// being drawn holds 10 bytes a cell, and the result 2 bytes a cell a map).
pub const MAX_CELLS: usize = 1 << 26;
/// Above this many cells the two halves are drawn one after the other, so that one half's
/// counts are held at a time (the result does not change).
pub const PARALLEL_CELLS: usize = 1 << 24;
/// The most scans one half may draw (the per-cell counts are 16-bit).
pub const MAX_DRAWN: usize = u16::MAX as usize - 1;

/// A drawn map's value for occupied, free and unknown cells (ROS map_server's trinary
/// image: occupied black, free white, unknown grey).
pub const OCCUPIED_VALUE: u8 = 0;
pub const FREE_VALUE: u8 = 254;
pub const UNKNOWN_VALUE: u8 = 205;

/// The grid both halves are drawn on: axis-aligned with the world, `resolution` metres per
/// cell, lower-left corner at `origin` (`(x, y)`, metres).
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub height: usize,
    pub width: usize,
    pub resolution: f64,
    pub origin: [f64; 2],
}

/// One half drawn as a map: `values` (0 occupied, 254 free, 205 unknown) and `unknown`,
/// both `height x width`, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Drawn {
    pub values: Vec<u8>,
    pub unknown: Vec<bool>,
}

/// What [`split`] returns: the frame, the map each half drew, and the SPEC 7b counts
/// (`n x 7`, row-major, [`crate::scans::COLUMNS`]) of the other half's scans against it:
/// `counts[0]` are the scans of `halves[0].1` against the map `halves[0].0` drew.
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    pub frame: Frame,
    pub maps: [Drawn; 2],
    pub counts: [Vec<i64>; 2],
}

/// The drawing's parameters: `resolution` (metres per cell, > 0), `margin` (metres of
/// grid around the drawn scans, >= 0), `occupied_share` (in (0, 1]) and the SPEC 7b
/// `tolerance` (metres) the other half is scored with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitParams {
    pub resolution: f64,
    pub margin: f64,
    pub occupied_share: f64,
    pub tolerance: f64,
}

/// Scans, poses and ranges, checked.
struct Recording<'a> {
    poses: &'a [f64],
    angles: &'a [f64],
    ranges: &'a [f64],
    min_range: f64,
    max_range: f64,
}

impl Recording<'_> {
    /// Scan `k`'s laser pose and ranges.
    fn scan(&self, k: usize) -> (&[f64], &[f64]) {
        let b = self.angles.len();
        (
            &self.poses[3 * k..3 * k + 3],
            &self.ranges[k * b..(k + 1) * b],
        )
    }

    fn valid(&self, r: f64) -> bool {
        r.is_finite() && r > self.min_range && r < self.max_range
    }
}

/// The frame around the laser positions and valid beams' ends of the scans in `drawn`
/// (world coordinates: `x + r cos(yaw + alpha)`, `y + r sin(yaw + alpha)`), `margin`
/// metres on every side.
fn frame(rec: &Recording, drawn: &[&[usize]; 2], p: &SplitParams) -> Result<Frame, ScanError> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &k in drawn.iter().flat_map(|d| d.iter()) {
        let (pose, ranges) = rec.scan(k);
        let mut take = |x: f64, y: f64| {
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        };
        take(pose[0], pose[1]);
        for (&alpha, &r) in rec.angles.iter().zip(ranges) {
            if rec.valid(r) {
                let a = pose[2] + alpha;
                take(pose[0] + r * a.cos(), pose[1] + r * a.sin());
            }
        }
    }
    if !lo[0].is_finite() {
        return Err(ScanError("no scan to draw".into()));
    }
    let origin = [lo[0] - p.margin, lo[1] - p.margin];
    let width = ((hi[0] + p.margin - origin[0]) / p.resolution)
        .ceil()
        .max(1.0);
    let height = ((hi[1] + p.margin - origin[1]) / p.resolution)
        .ceil()
        .max(1.0);
    if width * height > MAX_CELLS as f64 {
        return Err(ScanError(format!(
            "the scans span {:.1} m x {:.1} m: more than {MAX_CELLS} cells at {} m",
            hi[0] - lo[0],
            hi[1] - lo[1],
            p.resolution
        )));
    }
    Ok(Frame {
        height: height as usize,
        width: width as usize,
        resolution: p.resolution,
        origin,
    })
}

/// A cell's running counts: hits, visits, and the last scan (numbered from 1) that hit or
/// visited it.
struct Counts {
    hits: Vec<u16>,
    visits: Vec<u16>,
    hit_by: Vec<u16>,
    visited_by: Vec<u16>,
}

impl Counts {
    #[inline]
    fn visit(&mut self, i: usize, scan: u16) {
        if self.visited_by[i] != scan {
            self.visited_by[i] = scan;
            self.visits[i] += 1;
        }
    }

    #[inline]
    fn hit(&mut self, i: usize, scan: u16) {
        if self.hit_by[i] != scan {
            self.hit_by[i] = scan;
            self.hits[i] += 1;
        }
    }
}

/// The cells of an `h x w` grid whose centre lies inside the closed polygon `verts` (grid
/// units, y up), by the even-odd rule, as disjoint runs `span(y, c0, c1)` (columns `c0..=c1`
/// of row `y`, counted up from the bottom): an edge from p to q crosses the centre line
/// y + 0.5 of the rows with min(p.y, q.y) <= y + 0.5 < max(p.y, q.y) at
/// x = p.x + (y + 0.5 - p.y) (q.x - p.x) / (q.y - p.y); a row's crossings, sorted, pair
/// up, and each pair covers the columns ceil(x0 - 0.5) to floor(x1 - 0.5) (a column two
/// pairs share counted once). `crossings` is scratch space.
fn fill(
    verts: &[(f64, f64)],
    h: isize,
    w: isize,
    crossings: &mut Vec<(isize, f64)>,
    span: &mut impl FnMut(isize, isize, isize),
) {
    crossings.clear();
    for (i, &p) in verts.iter().enumerate() {
        let q = verts[(i + 1) % verts.len()];
        if p.1 == q.1 {
            continue;
        }
        let (lo, hi) = if p.1 < q.1 { (p.1, q.1) } else { (q.1, p.1) };
        // the beams' ends are on the grid (the frame covers them), so these are small
        let r0 = ((lo - 0.5).ceil() as isize).max(0);
        let r1 = ((hi - 0.5).ceil() as isize).min(h);
        for y in r0..r1 {
            let py = y as f64 + 0.5;
            crossings.push((y, p.0 + (py - p.1) * (q.0 - p.0) / (q.1 - p.1)));
        }
    }
    crossings.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    // every row has an even number of crossings (a closed polygon, half-open rows)
    let mut last = (isize::MIN, isize::MIN); // the row and last column covered
    for pair in crossings.chunks_exact(2) {
        let ((y, x0), (y1, x1)) = (pair[0], pair[1]);
        if y != y1 {
            continue; // cannot happen (see above)
        }
        let mut c0 = ((x0 - 0.5).ceil() as isize).max(0);
        if last.0 == y {
            c0 = c0.max(last.1 + 1);
        }
        let c1 = ((x1 - 0.5).floor() as isize).min(w - 1);
        if c0 <= c1 {
            span(y, c0, c1);
            last = (y, c1);
        }
    }
}

/// The scans in `drawn` drawn on `f` (see the module's docs).
fn draw(rec: &Recording, f: &Frame, drawn: &[usize], share: f64) -> Result<Drawn, ScanError> {
    let (h, w) = (f.height, f.width);
    let n = h * w;
    let mut c = Counts {
        hits: filled(n, 0)?,
        visits: filled(n, 0)?,
        hit_by: filled(n, 0)?,
        visited_by: filled(n, 0)?,
    };
    let (hi, wi) = (h as isize, w as isize);
    // the row-major index of the cell (col, y) (y counted up from the bottom row)
    let at = |col: isize, y: isize| -> Option<usize> {
        ((0..wi).contains(&col) && (0..hi).contains(&y)).then(|| ((hi - 1 - y) * wi + col) as usize)
    };
    let mut verts: Vec<(f64, f64)> = Vec::with_capacity(rec.angles.len() + 1);
    let mut crossings: Vec<(isize, f64)> = Vec::new();
    let mut beams: Vec<(f64, f64, f64, f64, f64)> = Vec::with_capacity(rec.angles.len());
    for (i, &k) in drawn.iter().enumerate() {
        let scan = (i + 1) as u16;
        let (pose, ranges) = rec.scan(k);
        let ox = (pose[0] - f.origin[0]) / f.resolution;
        let oy = (pose[1] - f.origin[1]) / f.resolution;
        let (fx, fy) = (ox.floor(), oy.floor());
        verts.clear();
        verts.push((ox, oy));
        beams.clear();
        for (&alpha, &r) in rec.angles.iter().zip(ranges) {
            if !rec.valid(r) {
                verts.push((ox, oy));
                continue;
            }
            let a = pose[2] + alpha;
            let (dx, dy) = (a.cos(), a.sin());
            let len = r / f.resolution;
            let (ex, ey) = (ox + len * dx, oy + len * dy);
            verts.push((ex, ey));
            beams.push((dx, dy, len, ex, ey));
        }
        if beams.is_empty() {
            continue; // a scan without a valid beam draws nothing
        }
        // the polygon first: its runs are disjoint, so they need no check (one beam makes
        // no polygon)
        if verts.len() > 2 {
            fill(&verts, hi, wi, &mut crossings, &mut |y, c0, c1| {
                let base = ((hi - 1 - y) * wi) as usize;
                let (a, b) = (base + c0 as usize, base + c1 as usize);
                c.visited_by[a..=b].fill(scan);
                for v in &mut c.visits[a..=b] {
                    *v += 1;
                }
            });
        }
        for &(dx, dy, len, ex, ey) in &beams {
            let end = (ex.floor() as isize, ey.floor() as isize);
            let (mut col, mut y) = (fx as isize, fy as isize);
            let (mut tx, tdx, sx) = first_boundary(ox, dx, fx);
            let (mut ty, tdy, sy) = first_boundary(oy, dy, fy);
            // every cell entered at t < len up to the end cell; the walk takes at most
            // one step per boundary crossed, and every step moves t past one boundary
            while (col, y) != end {
                let Some(cell) = at(col, y) else { break };
                c.visit(cell, scan);
                let step_x = tx < ty;
                let t = if step_x { tx } else { ty };
                if t >= len {
                    break;
                }
                if step_x {
                    tx += tdx;
                    col += sx;
                } else {
                    ty += tdy;
                    y += sy;
                }
            }
            if let Some(cell) = at(end.0, end.1) {
                c.visit(cell, scan);
                c.hit(cell, scan);
            }
        }
    }
    let mut values = filled(n, UNKNOWN_VALUE)?;
    let mut unknown = filled(n, true)?;
    for i in 0..n {
        let (hits, visits) = (c.hits[i], c.visits[i]);
        if hits > 0 && f64::from(hits) >= share * f64::from(visits) {
            values[i] = OCCUPIED_VALUE;
            unknown[i] = false;
        } else if visits > 0 {
            values[i] = FREE_VALUE;
            unknown[i] = false;
        }
    }
    Ok(Drawn { values, unknown })
}

/// Score the scans `tested` against `map` by SPEC 7b.
fn score(
    rec: &Recording,
    f: &Frame,
    map: &Drawn,
    tested: &[usize],
    tolerance: f64,
) -> Result<Vec<i64>, ScanError> {
    let grid = ScanGrid::new(
        &map.values,
        &map.unknown,
        f.height,
        f.width,
        f.resolution,
        [f.origin[0], f.origin[1], 0.0],
        0.5,
        tolerance,
    )?;
    let b = rec.angles.len();
    let mut poses = Vec::with_capacity(3 * tested.len());
    let mut ranges = Vec::with_capacity(b * tested.len());
    for &k in tested {
        let (pose, r) = rec.scan(k);
        poses.extend_from_slice(pose);
        ranges.extend_from_slice(r);
    }
    Ok(consistency(
        &grid,
        &poses,
        rec.angles,
        &ranges,
        rec.min_range,
        rec.max_range,
    )?
    .counts)
}

/// A trajectory against its own scans, split in time: laser `poses` (`(x, y, yaw)` triples
/// in the world frame, flat), beams at `angles` (relative to the yaw), `ranges`
/// (`n x angles.len()`, row-major, metres; valid when finite and
/// `min_range < r < max_range`). `halves[i] = (drawn, tested)`: the scans (indices into
/// `poses`) drawn as map `i`, and the scans scored against it.
pub fn split(
    poses: &[f64],
    angles: &[f64],
    ranges: &[f64],
    min_range: f64,
    max_range: f64,
    halves: [(&[usize], &[usize]); 2],
    p: &SplitParams,
) -> Result<Split, ScanError> {
    if !(p.resolution.is_finite() && p.resolution > 0.0) {
        return Err(ScanError(format!(
            "resolution must be a positive number of metres, got {}",
            p.resolution
        )));
    }
    if !(p.margin.is_finite() && p.margin >= 0.0) {
        return Err(ScanError(format!(
            "margin must be a number of metres >= 0, got {}",
            p.margin
        )));
    }
    if !(p.occupied_share > 0.0 && p.occupied_share <= 1.0) {
        return Err(ScanError(format!(
            "occupied_share must be in (0, 1], got {}",
            p.occupied_share
        )));
    }
    let (n, _) = check_recording(poses, angles, ranges, min_range, max_range)?;
    for (drawn, tested) in halves {
        if let Some(k) = drawn.iter().chain(tested).find(|&&k| k >= n) {
            return Err(ScanError(format!(
                "scan index {k} is out of range for {n} scans"
            )));
        }
        if drawn.len() > MAX_DRAWN {
            return Err(ScanError(format!(
                "{} scans to draw in one half, at most {MAX_DRAWN}",
                drawn.len()
            )));
        }
    }
    let rec = Recording {
        poses,
        angles,
        ranges,
        min_range,
        max_range,
    };
    let f = frame(&rec, &[halves[0].0, halves[1].0], p)?;
    let one = || draw(&rec, &f, halves[0].0, p.occupied_share);
    let two = || draw(&rec, &f, halves[1].0, p.occupied_share);
    let maps = if f.height * f.width > PARALLEL_CELLS {
        [one()?, two()?]
    } else {
        let (a, b) = rayon::join(one, two);
        [a?, b?]
    };
    let counts = [
        score(&rec, &f, &maps[0], halves[0].1, p.tolerance)?,
        score(&rec, &f, &maps[1], halves[1].1, p.tolerance)?,
    ];
    Ok(Split {
        frame: f,
        maps,
        counts,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: SplitParams = SplitParams {
        resolution: 0.1,
        margin: 0.5,
        occupied_share: 0.5,
        tolerance: 0.1,
    };

    /// A laser at `(x, 0)` looking along +x and -x at walls 1 m away on both sides.
    fn corridor(shift: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let angles = vec![0.0, std::f64::consts::PI];
        let (mut poses, mut ranges) = (Vec::new(), Vec::new());
        for k in 0..10 {
            // the second half's poses are `shift` metres off along x
            let x = if k < 5 { 0.0 } else { shift };
            poses.extend_from_slice(&[x, 0.05, 0.0]);
            ranges.extend_from_slice(&[1.03, 1.03]);
        }
        (poses, angles, ranges)
    }

    /// [`corridor`]'s two halves of five scans.
    const FIRST: [usize; 5] = [0, 1, 2, 3, 4];
    const SECOND: [usize; 5] = [5, 6, 7, 8, 9];

    /// [`corridor`] split into its two halves.
    fn corridor_split(shift: f64, p: &SplitParams) -> Split {
        let (a, b) = (FIRST, SECOND);
        let (poses, angles, ranges) = corridor(shift);
        split(&poses, &angles, &ranges, 0.0, 10.0, [(&a, &b), (&b, &a)], p).unwrap()
    }

    #[test]
    fn right_poses_agree_and_wrong_ones_cross() {
        for (shift, crossings, hits) in [(0.0, 0, 10), (1.5, 5, 0)] {
            let s = corridor_split(shift, &P);
            // shifted, each scan's -x beam passes the first half's wall at x = 1.03 and
            // comes out into the free space the first half saw (ends at 0.47): a crossing;
            // the first half's +x beams cross the shifted half's wall at 0.47 alike
            for counts in &s.counts {
                let got: i64 = counts.chunks(7).map(|c| c[6]).sum();
                assert_eq!(got, crossings, "shift {shift}");
                let got: i64 = counts.chunks(7).map(|c| c[1]).sum();
                assert_eq!(got, hits, "shift {shift}");
            }
        }
    }

    #[test]
    fn a_drawn_map_has_walls_free_space_and_unknown() {
        let s = corridor_split(0.0, &SplitParams { margin: 0.55, ..P });
        let f = &s.frame;
        // x from -1.58 to 1.58: 32 cells; the laser at x = 1.58 / 0.1 = 15.8 cells, its
        // beams end at 5.5 and 26.1; y at 0.55 / 0.1 = 5.5 cells from the bottom
        assert_eq!(f.width, 32);
        let m = &s.maps[0];
        let row = f.height - 1 - 5;
        let line = &m.values[row * f.width..(row + 1) * f.width];
        assert_eq!(line[0], UNKNOWN_VALUE);
        assert_eq!(line[5], OCCUPIED_VALUE);
        assert_eq!(line[15], FREE_VALUE);
        assert_eq!(line[26], OCCUPIED_VALUE);
        assert_eq!(line[31], UNKNOWN_VALUE);
        assert_eq!(m.values.iter().filter(|&&v| v == OCCUPIED_VALUE).count(), 2);
        assert_eq!(m.values.iter().filter(|&&v| v == FREE_VALUE).count(), 20);
        assert!(m
            .unknown
            .iter()
            .zip(&m.values)
            .all(|(&u, &v)| u == (v == UNKNOWN_VALUE)));
        assert_eq!(s.maps[0], s.maps[1]);
    }

    #[test]
    fn a_cell_counts_once_per_scan() {
        // one scan's short beam ends in the cell its long beam passes through: one hit of
        // one visit (not of two), so the cell is occupied even at a share of 1
        let poses = vec![0.0; 6];
        let angles = vec![0.0, 0.0];
        let ranges = vec![0.95, 1.45, 0.95, 1.45];
        let p = SplitParams {
            occupied_share: 1.0,
            ..P
        };
        let s = split(
            &poses,
            &angles,
            &ranges,
            0.0,
            5.0,
            [(&[0], &[1]), (&[1], &[0])],
            &p,
        )
        .unwrap();
        let occ = s.maps[0]
            .values
            .iter()
            .filter(|&&v| v == OCCUPIED_VALUE)
            .count();
        assert_eq!(occ, 2);
    }

    #[test]
    fn bad_input_is_an_error() {
        let (poses, angles, ranges) = corridor(0.0);
        let (a, b) = (FIRST, SECOND);
        let h: [(&[usize], &[usize]); 2] = [(&a, &b), (&b, &a)];
        let bad = |p: SplitParams| split(&poses, &angles, &ranges, 0.0, 10.0, h, &p).is_err();
        assert!(bad(SplitParams {
            resolution: 0.0,
            ..P
        }));
        assert!(bad(SplitParams {
            margin: f64::NAN,
            ..P
        }));
        assert!(bad(SplitParams {
            occupied_share: 0.0,
            ..P
        }));
        assert!(bad(SplitParams {
            tolerance: -1.0,
            ..P
        }));
        assert!(split(
            &poses,
            &angles,
            &ranges,
            0.0,
            10.0,
            [(&[10], &b), (&b, &a)],
            &P
        )
        .is_err());
        assert!(split(&poses[..29], &angles, &ranges, 0.0, 10.0, h, &P).is_err());
        let mut far = poses.clone();
        far[0] = 1e6;
        let e = split(&far, &angles, &ranges, 0.0, 10.0, h, &P).unwrap_err();
        assert!(e.0.contains("cells"), "{e}");
        let none: [(&[usize], &[usize]); 2] = [(&[], &[]), (&[], &[])];
        assert!(split(&poses, &angles, &ranges, 0.0, 10.0, none, &P).is_err());
    }

    #[test]
    fn thread_counts_agree() {
        let mut poses = Vec::new();
        let mut ranges = Vec::new();
        let angles: Vec<f64> = (0..90).map(|j| j as f64 * 0.07).collect();
        for k in 0..40 {
            let t = k as f64 * 0.1;
            poses.extend_from_slice(&[t.cos(), t.sin() * 0.5, t * 0.3]);
            ranges.extend((0..90).map(|j| 1.0 + ((j * 7 + k * 3) % 11) as f64 * 0.2));
        }
        let a: Vec<usize> = (0..20).collect();
        let b: Vec<usize> = (20..40).collect();
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    split(&poses, &angles, &ranges, 0.0, 3.0, [(&a, &b), (&b, &a)], &P).unwrap()
                })
        };
        assert_eq!(run(1), run(3));
    }
}
